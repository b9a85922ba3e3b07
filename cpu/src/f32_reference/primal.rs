//! XPBD with the primal residual in f32, as `shaders/primal.wgsl` computes
//! it (the golden path: `cpu/src/consistent.rs`).
//!
//! ```text
//! a = x − d_e (x without element e's force), per kind:
//! distance, tether  λ = (rest − |a₁ − a₀|) / (w₀ + w₁ + α~)   (tether: λ ≤ 0)
//!                   d₀ = −w₀ u λ, d₁ = w₁ u λ, u = (a₁ − a₀) / |a₁ − a₀|
//! hyperplane        λ = max(−(n·a − rest) / (w + α~), 0), d = w n λ;
//!                   then static friction
//! measures,         one Gauss–Newton step from x:
//! expressions       λ = −(C + ∇C·(a − x)) / (Σ w |∇C|² + α~),  d = w ∇C λ
//! materials         one Newton step: (M + K/α~) Δ = −(M (x − a) + ∇W/α~),
//!                   d = x + Δ − a, λ = −√(2W)/α~ (K: the frame Hessian's vertex
//!                   block, PSD-projected on a failed factor; the factor made
//!                   at the substep's first sweep and reused)
//! then              x = a + d (dynamic particles), λ stored
//! warm start        x += Σ_e d_e after the prediction, in family, slot order
//! ```
//! A clamp is a comparison (−0 and NaN go to +0, as the WGSL's select).
//! A failing element writes nothing; the first one is returned.

// Coordinate loops index several arrays at once, as a kernel does.
#![allow(clippy::needless_range_loop)]

use hyperpbd_core::expr::Columns;
use hyperpbd_core::implicit::{PsdScratch, project_psd};
use hyperpbd_core::kinds::{ExpressionKind, Relation};
use hyperpbd_core::{Family, FamilyKind, Plan};

use super::material::{Law, cholesky};
use super::project::{Colour, Plane};
use super::{Particles, Stored};
use hyperpbd_core::geometry::{Scratch, oriented_measure, simplex_squared_measure};
use hyperpbd_core::kinds::contact_friction::static_friction;
use hyperpbd_core::kinds::primal_element::{distance_element, gauss_newton_lambda};
use hyperpbd_core::material::solve_factored;

/// d of every slot of `f` (arity · N each) with the primal residual;
/// nothing otherwise.
pub(super) fn displacements(plan: &Plan, f: &Family) -> Vec<f32> {
    match plan.primal_residual {
        true => vec![0.0; f.elements.len() * plan.dim],
        false => Vec::new(),
    }
}

/// A material family's Newton factors ((arity · N)² per slot) with the
/// primal residual; nothing otherwise.
pub(super) fn factors(plan: &Plan, f: &Family) -> Vec<f32> {
    match plan.primal_residual && f.kind.is_material() {
        true => vec![0.0; f.len() * (f.arity * plan.dim).pow(2)],
        false => Vec::new(),
    }
}

/// λ and d of every family, for the step's rollback (primal residual).
pub(super) fn save(plan: &Plan, families: &[Stored]) -> Vec<(Vec<f32>, Vec<f32>)> {
    match plan.primal_residual {
        true => (families.iter())
            .map(|f| (f.lambda.clone(), f.carried.clone()))
            .collect(),
        false => Vec::new(),
    }
}

/// Puts back what [`save`] kept.
pub(super) fn restore(families: &mut [Stored], saved: Vec<(Vec<f32>, Vec<f32>)>) {
    for (f, (lambda, d)) in families.iter_mut().zip(saved) {
        (f.lambda, f.carried) = (lambda, d);
    }
}

/// λ and d start over from 0 (a written state; primal residual).
pub(super) fn clear(plan: &Plan, families: &mut [Stored]) {
    if plan.primal_residual {
        for f in families {
            f.lambda.fill(0.0);
            f.carried.fill(0.0);
        }
    }
}

/// Colour `color` of family `f` (its stored data `stored`): the family's
/// kind's update below.
pub(super) fn project(
    s: &mut Particles,
    (f, color): (&Family, usize),
    stored: &mut Stored,
    columns: &mut Columns<f32>,
) -> Result<(), usize> {
    let colour = Colour {
        slots: f.color(color),
        arity: f.arity,
        elements: &f.elements,
        rest: &stored.rest,
        alpha_tilde: stored.alpha_tilde,
    };
    let (lambda, d) = (&mut stored.lambda, &mut stored.carried);
    let first = !stored.swept;
    if color + 1 == f.color_count() {
        stored.swept = true;
    }
    match &f.kind {
        FamilyKind::Distance => distance(s, &colour, lambda, d, false),
        FamilyKind::Tether => distance(s, &colour, lambda, d, true),
        FamilyKind::SimplexMeasure { k } => measure(s, &colour, lambda, d, Some(*k)),
        FamilyKind::OrientedMeasure => measure(s, &colour, lambda, d, None),
        FamilyKind::HyperplaneContact { .. } => {
            let plane = Plane {
                normal: &stored.normal,
                mu: stored.mu,
            };
            contact(s, &colour, &plane, lambda, d)
        }
        // Refused with the primal residual (validate_solver.rs): fails the colour.
        FamilyKind::MeshContact { .. } => Err(colour.slots.start),
        FamilyKind::Expression(kind) => {
            let kind = (kind.as_ref(), &stored.constants[..]);
            expression(s, &colour, kind, (lambda, d), columns)
        }
        FamilyKind::Material { .. } => match &stored.material {
            Some(law) => material(
                s,
                &colour,
                law,
                (lambda, d),
                (&mut stored.factors[..], first),
            ),
            None => Ok(()),
        },
    }
}

/// x += d over `elements` (one family's, `dim` reals of `d` per entry),
/// dynamic particles only.
pub fn warm_start(s: &mut Particles, elements: &[u32], d: &[f32]) {
    let n = s.dim;
    for (k, &i) in elements.iter().enumerate() {
        let i = i as usize;
        if s.w[i] == 0.0 {
            continue;
        }
        for a in 0..n {
            s.x[i * n + a] += d[k * n + a];
        }
    }
}

pub fn distance(
    s: &mut Particles,
    c: &Colour,
    lambda: &mut [f32],
    d: &mut [f32],
    tether: bool,
) -> Result<(), usize> {
    let n = s.dim;
    let mut failed = None;
    let (mut ai, mut aj) = (vec![0.0f32; n], vec![0.0f32; n]);
    let relation = if tether {
        Relation::AtMost
    } else {
        Relation::Equal
    };
    for e in c.slots.clone() {
        let (i, j) = (c.elements[2 * e] as usize, c.elements[2 * e + 1] as usize);
        let (wi, wj) = (s.w[i], s.w[j]);
        let base = 2 * n * e;
        let (di, dj) = d[base..base + 2 * n].split_at_mut(n);
        let points = [&s.x[i * n..(i + 1) * n], &s.x[j * n..(j + 1) * n]];
        let constants = (wi, wj, c.rest[e], c.alpha_tilde);
        let anchors = [&mut ai[..], &mut aj[..]];
        let Some(l) = distance_element(points, anchors, [di, dj], constants, relation) else {
            failed = failed.or(Some(e));
            continue;
        };
        lambda[e] = l;
        if wi != 0.0 {
            for a in 0..n {
                s.x[i * n + a] = ai[a] + d[base + a];
            }
        }
        if wj != 0.0 {
            for a in 0..n {
                s.x[j * n + a] = aj[a] + d[base + n + a];
            }
        }
    }
    failed.map_or(Ok(()), Err)
}

/// The Gauss–Newton step of element `e` (particles `element`, points
/// `pts` = x, C = `value`, ∇C in `grad`); false: it failed.
#[allow(clippy::too_many_arguments)]
fn gauss_newton(
    s: &mut Particles,
    c: &Colour,
    e: usize,
    (value, pts, grad): (f32, &[f32], &[f32]),
    relation: Relation,
    lambda: &mut [f32],
    d: &mut [f32],
) -> bool {
    let n = s.dim;
    let count = c.arity * n;
    let element = &c.elements[e * c.arity..(e + 1) * c.arity];
    let base = e * count;
    let anchor: Vec<f32> = (0..count).map(|k| pts[k] - d[base + k]).collect();
    if !value.is_finite() {
        return false;
    }
    let weight = |j: usize| s.w[element[j] as usize];
    let vectors = [grad, &anchor[..], pts];
    let residual = (value - c.rest[e], c.alpha_tilde);
    let mut l = 0.0f32;
    let mut out = vec![0.0f32; count];
    if let Some(lambda) = gauss_newton_lambda(n, weight, vectors, residual, relation) {
        l = lambda;
        for k in 0..count {
            out[k] = s.w[element[k / n] as usize] * grad[k] * l;
        }
    }
    if !l.is_finite() || out.iter().any(|v| !v.is_finite()) {
        return false;
    }
    d[base..base + count].copy_from_slice(&out);
    lambda[e] = l;
    place(s, element, &anchor, &out);
    true
}

/// x = a + d on the element's dynamic particles (fixed ones stay).
fn place(s: &mut Particles, element: &[u32], anchor: &[f32], d: &[f32]) {
    let n = s.dim;
    for (j, &i) in element.iter().enumerate() {
        let i = i as usize;
        if s.w[i] == 0.0 {
            continue;
        }
        for a in 0..n {
            s.x[i * n + a] = anchor[j * n + a] + d[j * n + a];
        }
    }
}

/// Simplex (`Some(k)`) or oriented (`None`) measures.
pub fn measure(
    s: &mut Particles,
    c: &Colour,
    lambda: &mut [f32],
    d: &mut [f32],
    simplex: Option<usize>,
) -> Result<(), usize> {
    let n = s.dim;
    let mut failed = None;
    let mut pts = vec![0.0f32; c.arity * n];
    let mut grad = vec![0.0f32; c.arity * n];
    let mut scratch = Scratch::<f32>::default();
    for e in c.slots.clone() {
        for (j, &i) in c.elements[e * c.arity..(e + 1) * c.arity]
            .iter()
            .enumerate()
        {
            let i = i as usize;
            pts[j * n..(j + 1) * n].copy_from_slice(&s.x[i * n..(i + 1) * n]);
        }
        let value = match simplex {
            Some(_) => simplex_squared_measure(&pts, n, &mut grad, &mut scratch),
            None => oriented_measure(&pts, n, &mut grad, &mut scratch),
        };
        let point = (value, &pts[..], &grad[..]);
        if !gauss_newton(s, c, e, point, Relation::Equal, lambda, d) {
            failed = failed.or(Some(e));
        }
    }
    failed.map_or(Ok(()), Err)
}

/// An expression family's colour (its tape evaluated in f32 at x).
pub fn expression(
    s: &mut Particles,
    c: &Colour,
    (kind, constants): (&ExpressionKind, &[f32]),
    (lambda, d): (&mut [f32], &mut [f32]),
    columns: &mut Columns<f32>,
) -> Result<(), usize> {
    let (n, arity) = (s.dim, kind.arity);
    let tape = &kind.gradient;
    let x = &s.x;
    let slots = c.slots.clone();
    kind.eval_slots(tape, n, c.elements, constants, slots, |k| x[k], columns);
    let mut failed = None;
    let mut pts = vec![0.0f32; arity * n];
    let mut grad = vec![0.0f32; arity * n];
    for (lane, e) in c.slots.clone().enumerate() {
        for (j, &i) in c.elements[e * arity..(e + 1) * arity].iter().enumerate() {
            let i = i as usize;
            pts[j * n..(j + 1) * n].copy_from_slice(&s.x[i * n..(i + 1) * n]);
        }
        for (k, &slot) in tape.gradient.iter().enumerate() {
            grad[k] = columns.column(slot)[lane];
        }
        let value = columns.column(tape.value)[lane];
        let point = (value, &pts[..], &grad[..]);
        if !gauss_newton(s, c, e, point, kind.relation, lambda, d) {
            failed = failed.or(Some(e));
        }
    }
    failed.map_or(Ok(()), Err)
}

pub fn contact(
    s: &mut Particles,
    c: &Colour,
    plane: &Plane,
    lambda: &mut [f32],
    d: &mut [f32],
) -> Result<(), usize> {
    let n = s.dim;
    let normal = plane.normal;
    let mut failed = None;
    let mut anchor = vec![0.0f32; n];
    for e in c.slots.clone() {
        let i = c.elements[e] as usize;
        let w = s.w[i];
        let (x, p) = (&mut s.x[i * n..(i + 1) * n], &s.p[i * n..(i + 1) * n]);
        let de = &mut d[e * n..(e + 1) * n];
        let mut cval = -c.rest[e];
        for a in 0..n {
            anchor[a] = x[a] - de[a];
            cval += normal[a] * anchor[a];
        }
        let l = Relation::AtLeast.clamp(-cval / (w + c.alpha_tilde));
        for a in 0..n {
            de[a] = w * normal[a] * l;
        }
        if !l.is_finite() || de.iter().any(|v| !v.is_finite()) {
            failed = failed.or(Some(e));
            continue;
        }
        lambda[e] = l;
        for a in 0..n {
            x[a] = anchor[a] + de[a];
        }
        if plane.mu > 0.0 && l > 0.0 {
            static_friction(normal, plane.mu * w * l, p, x);
        }
    }
    failed.map_or(Ok(()), Err)
}

/// A material family's colour: one Newton step per element
/// (`shaders/primal_material.wgsl`); `first`: the family's first sweep of
/// the substep, which makes each element's factor (kept in `factors`,
/// (arity · N)² per slot) for the later sweeps.
pub fn material(
    s: &mut Particles,
    c: &Colour,
    law: &Law,
    (lambda, d): (&mut [f32], &mut [f32]),
    (factors, first): (&mut [f32], bool),
) -> Result<(), usize> {
    let n = s.dim;
    let count = c.arity * n;
    let size = n * (c.arity - 1);
    let mut failed = None;
    let (mut pts, mut grad) = (vec![0.0f32; count], vec![0.0f32; count]);
    let mut anchor = vec![0.0f32; count];
    let mut h = vec![0.0f32; size * size];
    let mut column = vec![0.0f32; count];
    for e in c.slots.clone() {
        let element = &c.elements[e * c.arity..(e + 1) * c.arity];
        let base = e * count;
        let at = e * count * count;
        for (j, &i) in element.iter().enumerate() {
            let i = i as usize;
            pts[j * n..(j + 1) * n].copy_from_slice(&s.x[i * n..(i + 1) * n]);
        }
        for k in 0..count {
            anchor[k] = pts[k] - d[base + k];
        }
        let Some(energy) = law.element_energy(e, &pts, n, &mut grad) else {
            failed = failed.or(Some(e));
            continue;
        };
        let wc: Vec<f32> = (0..count).map(|k| s.w[element[k / n] as usize]).collect();
        let dynamic: Vec<usize> = (0..count).filter(|&k| wc[k] != 0.0).collect();
        let q = dynamic.len();
        if first {
            let factor = &mut factors[at..at + q * q];
            let mut made = false;
            if law.frame_hessian(e, &pts, n, &mut h) {
                let mut scratch = PsdScratch::new();
                let mut system = vec![0.0f32; q * q];
                for attempt in 0..2 {
                    for (col, &cc) in dynamic.iter().enumerate() {
                        law.block_column(e, &h, n, cc, &mut column);
                        for (r, &cr) in dynamic.iter().enumerate() {
                            system[r * q + col] = column[cr] / c.alpha_tilde;
                        }
                    }
                    for (r, &cr) in dynamic.iter().enumerate() {
                        system[r * q + r] += 1.0 / wc[cr];
                    }
                    if cholesky(&system, q, factor) {
                        made = true;
                        break;
                    }
                    if attempt == 1 || !project_psd(&mut h, size, &mut scratch).finite {
                        break;
                    }
                }
            }
            if !made {
                failed = failed.or(Some(e));
                continue;
            }
        }
        let factor = &factors[at..at + q * q];
        let mut rhs: Vec<f32> = dynamic
            .iter()
            .map(|&cr| -((pts[cr] - anchor[cr]) / wc[cr] + grad[cr] / c.alpha_tilde))
            .collect();
        solve_factored(factor, q, &mut rhs);
        let t = step_length(
            law,
            e,
            (energy, &pts, &anchor),
            (&dynamic, &wc),
            &rhs,
            c.alpha_tilde,
        );
        let mut out = vec![0.0f32; count];
        for (r, &cr) in dynamic.iter().enumerate() {
            out[cr] = pts[cr] + t * rhs[r] - anchor[cr];
        }
        let energy = if energy > 0.0 { energy } else { 0.0 };
        let l = -(2.0 * energy).sqrt() / c.alpha_tilde;
        if !l.is_finite() || out.iter().any(|v| !v.is_finite()) {
            failed = failed.or(Some(e));
            continue;
        }
        d[base..base + count].copy_from_slice(&out);
        lambda[e] = l;
        place(s, element, &anchor, &out);
    }
    failed.map_or(Ok(()), Err)
}

/// φ(y) = ½ Σ_dyn (y − a)²/w + W/α~ at `points` (W = `energy` there).
fn objective(
    points: &[f32],
    anchor: &[f32],
    (dynamic, w): (&[usize], &[f32]),
    energy: f32,
    alpha_tilde: f32,
) -> f32 {
    let mut m = 0.0f32;
    for &cr in dynamic {
        let u = points[cr] - anchor[cr];
        m += u * u / w[cr];
    }
    0.5 * m + energy / alpha_tilde
}

/// The material step's length (primal_material.wgsl's
/// `primal_step_length`): the first of 1, ½, … (6 halvings) at which the
/// law accepts the element and φ does not rise; 0 when none does.
fn step_length(
    law: &Law,
    e: usize,
    (energy, pts, anchor): (f32, &[f32], &[f32]),
    (dynamic, w): (&[usize], &[f32]),
    step: &[f32],
    alpha_tilde: f32,
) -> f32 {
    let n = pts.len() / (law.k + 1);
    let start = objective(pts, anchor, (dynamic, w), energy, alpha_tilde);
    let mut trial = pts.to_vec();
    let mut grad = vec![0.0f32; pts.len()];
    let mut t = 1.0f32;
    for _ in 0..=6 {
        for (r, &cr) in dynamic.iter().enumerate() {
            trial[cr] = pts[cr] + t * step[r];
        }
        if let Some(energy) = law.element_energy(e, &trial, n, &mut grad)
            && objective(&trial, anchor, (dynamic, w), energy, alpha_tilde) <= start
        {
            return t;
        }
        t *= 0.5;
    }
    0.0
}
