//! XPBD that carries the primal residual (`"solver": {"type": "xpbd",
//! "primal_residual": true}`): each element keeps the displacement its
//! force has put on its particles, so that an update replaces the
//! element's old force instead of adding to it, and the iteration's fixed
//! point is the backward-Euler step's (docs/equilibria.md).
//!
//! Backward Euler with per-element potentials Φ_e (Φ = C² / (2 α~) for a
//! compliant constraint, Φ = W / α~ for a material element, α~ = α / h²;
//! hard constraints are the limit α → 0) asks for
//! ```text
//! M (x − x~) = Σ_e f_e,   f_e = −∇Φ_e(x)              (g = 0 and h = 0)
//! ```
//! Standard XPBD (`project.rs`) moves x by W ∇C Δλ with ∇C taken where it
//! is applied; where ∇C turns between sweeps (a stressed element) the sum
//! of those moves is no longer W Σ ∇C(x) λ: the primal residual
//! g = M(x − x~) − Σ f_e that its update assumes to be 0 is not, and a
//! stressed equilibrium is missed by O(h). Here each element e keeps
//! d_e = W f_e (its displacement on each of its particles), so that always
//! ```text
//! x = x~ + s + Σ_e d_e          (s: moves without a force: static friction,
//!                                particle contact's averaged Jacobi moves)
//! ```
//! i.e. g = 0 by construction, and an update of element e solves the
//! element's own backward-Euler problem with the others' forces held:
//! ```text
//! a   = x − d_e                                  (x without e's force)
//! y   = argmin ½ |y − a|²_M + Φ_e(y)             (e's particles; fixed ones stay)
//! d_e = y − a,  x = y
//! ```
//! This is block-coordinate ascent on the dual of backward Euler's
//! minimisation (one block per element), which converges for convex Φ_e;
//! at its fixed point every f_e = −∇Φ_e(x): the backward-Euler step. The
//! element problems, per kind:
//! ```text
//! distance, tether   exact: n = (a_1 − a_0)/|a_1 − a_0|,  λ = (rest − |a_1 − a_0|)/(W + α~)
//!                    (tether: λ ≤ 0),  d_0 = −w_0 n λ,  d_1 = w_1 n λ
//! hyperplane         exact: λ = max(−(n·a − rest)/(w + α~), 0),  d = w n λ; then
//!                    static friction as in project.rs (its move goes to s)
//! measures,          one Gauss–Newton step from y0 = x:
//! expressions          λ = −(C(y0) + ∇C(y0)·(a − y0)) / (Σ w |∇C|² + α~)  (relation clamp)
//!                      d = W ∇C(y0) λ
//! materials          one Newton step from y0 = x on φ(y) = ½|y − a|²_M + W(y)/α~
//!                    with the law's Hessian K (implicit::material_term; its
//!                    PSD projection K⁺ where M + K/α~ is not positive
//!                    definite), factored at the element's first update of the
//!                    substep and reused by the later sweeps ([`Factors`]):
//!                      (M + K/α~) Δ = −(M (y0 − a) + ∇W(y0)/α~),  y = y0 + t Δ
//!                    t the first of 1, ½, …, 2⁻⁶ with φ(y) ≤ φ(y0) and the
//!                    element accepted by its law, else 0
//! ```
//! (the nonlinear kinds' steps are exact at their fixed point: Δ = 0 there
//! means the element's problem is solved). λ is kept per slot for the
//! report and for friction: f_e = ∇C λ (materials: λ = −C(y0)/α~,
//! C = √(2W)).
//!
//! **Warm start.** d and λ carry over from one substep to the next (scaled
//! by (h / h_d)² when the substep length changes, as in an adaptive retry:
//! both are force · h²), and the substep starts from x = x~ + Σ_e d_e: a
//! state at rest in equilibrium then starts at its solution and stays
//! there, where a start from d = 0 would leave the finite sweeps'
//! error in every substep. The block ascent converges from any start, so
//! this changes where it starts, not where it ends. They are part of the
//! backend's state: a failed or reverted step restores them, and
//! `write_state` starts them over from 0.
//!
//! Runs on the calling thread, element by element in colour order (the
//! same result for any thread count).

// Coordinate loops index several arrays at once, as a kernel does.
#![allow(clippy::needless_range_loop)]

use crate::dim::{Dim, with_dim};
use crate::project::{Batch, Workspace, gathered_value};
use hyperpbd_core::implicit::{
    MaterialHessianScratch, PsdScratch, material_hessian_block, material_term, project_psd,
};
use hyperpbd_core::kinds;
use hyperpbd_core::kinds::contact_friction::static_friction;
use hyperpbd_core::kinds::primal_element::{distance_element, gauss_newton_lambda};
use hyperpbd_core::material::{cholesky, element_energy, solve_factored};
use hyperpbd_core::{Family, FamilyKind, Plan};
use std::ops::Range;

/// Scratch of the element problems.
#[derive(Default)]
pub struct Scratch {
    /// a (e's particles without its force).
    anchor: Vec<f64>,
    /// The material element's Newton system (dynamic coordinates).
    dynamic: Vec<usize>,
    system: Vec<f64>,
    rhs: Vec<f64>,
    /// The points of a trial step.
    trial: Vec<f64>,
    frame: Vec<f64>,
    block: Vec<f64>,
    hessian: MaterialHessianScratch,
    psd: PsdScratch,
}

/// A material family's Newton matrices, factored once per substep (at an
/// element's first update) and reused by its later sweeps: a chord step,
/// whose fixed point is the same (Δ = 0 where the element's gradient is).
#[derive(Debug, Default)]
pub struct Factors {
    /// The current substep's stamp; slot e's factor is current when
    /// `valid[e] == stamp`.
    pub stamp: u64,
    valid: Vec<u64>,
    values: Vec<f64>,
    stride: usize,
}

impl Factors {
    /// Storage for `family` (empty unless it is a material family).
    pub fn for_family(family: &Family, dim: usize) -> Self {
        if !matches!(family.kind, FamilyKind::Material { .. }) {
            return Factors::default();
        }
        let stride = (family.arity * dim).pow(2);
        Factors {
            stamp: 1,
            valid: vec![0; family.len()],
            values: vec![0.0; stride * family.len()],
            stride,
        }
    }
}

/// Per-slot displacements d_e of a family (`arity · dim` per slot).
pub fn displacement_len(family: &Family, dim: usize) -> usize {
    family.len() * family.arity * dim
}

/// x += Σ_e d_e over every family's slots in order (the warm start of a
/// substep: x = x~ + Σ d); fixed particles are never written.
pub fn apply(plan: &Plan, displacement: &[f64], starts: &[usize], x: &mut [f64]) {
    let dim = plan.dim;
    for (f, family) in plan.families.iter().enumerate() {
        let d = &displacement[starts[f]..starts[f + 1]];
        for (k, &i) in family.elements.iter().enumerate() {
            let i = i as usize;
            if plan.inverse_mass[i] == 0.0 {
                continue;
            }
            for a in 0..dim {
                x[i * dim + a] += d[k * dim + a];
            }
        }
    }
}

/// What a family carries between its updates: d_e and λ per slot (all the
/// family's slots) and the material elements' factors.
pub struct Carried<'a> {
    pub displacement: &'a mut [f64],
    pub lambda: &'a mut [f64],
    pub factors: &'a mut Factors,
}

/// Updates the slots `range` (one colour) of `batch.family` (module docs).
/// Returns the first slot whose update was not finite or whose material
/// was refused.
pub fn project(
    batch: &Batch,
    range: Range<usize>,
    x: &mut [f64],
    carried: Carried<'_>,
    ws: &mut Workspace,
    sc: &mut Scratch,
) -> Result<(), usize> {
    let Carried {
        displacement,
        lambda,
        factors,
    } = carried;
    let (dim, f) = (batch.dim, batch.family);
    let arity = f.arity;
    if matches!(f.kind, FamilyKind::Distance | FamilyKind::Tether) {
        return with_dim!(dim, distances(batch, range, x, displacement, lambda));
    }
    if let FamilyKind::Expression(kind) = &f.kind {
        kind.gradient_slots(dim, &f.elements, range.clone(), x, &mut ws.columns);
    }
    sc.anchor.resize(arity * dim, 0.0);
    ws.points.resize(arity * dim, 0.0);
    ws.grad.resize(arity * dim, 0.0);
    for e in range.clone() {
        let element = &f.elements[e * arity..(e + 1) * arity];
        let d = &mut displacement[e * arity * dim..(e + 1) * arity * dim];
        for (j, &i) in element.iter().enumerate() {
            let i = i as usize;
            for a in 0..dim {
                sc.anchor[j * dim + a] = x[i * dim + a] - d[j * dim + a];
                ws.points[j * dim + a] = x[i * dim + a];
            }
        }
        let l = match &f.kind {
            // Taken by `distances` above.
            FamilyKind::Distance | FamilyKind::Tether => return Err(e),
            // Refused with the primal residual (validate_solver.rs).
            FamilyKind::MeshContact { .. } => return Err(e),
            FamilyKind::HyperplaneContact { normal, .. } => {
                hyperplane(batch, normal, element[0] as usize, e, sc, d)
            }
            FamilyKind::Material { .. } => material(batch, element, e, ws, sc, factors, d)?,
            FamilyKind::Expression(kind) => {
                let lane = e - range.start;
                for (k, &slot) in kind.gradient.gradient.iter().enumerate() {
                    ws.grad[k] = ws.columns.column(slot)[lane];
                }
                let value = ws.columns.column(kind.gradient.value)[lane];
                gauss_newton(batch, element, e, value, ws, sc, d)
            }
            FamilyKind::SimplexMeasure { .. } | FamilyKind::OrientedMeasure => {
                let value = gathered_value(f, e, dim, ws)?;
                gauss_newton(batch, element, e, value, ws, sc, d)
            }
        };
        if !l.is_finite() || d.iter().any(|v| !v.is_finite()) {
            return Err(e);
        }
        lambda[e] = l;
        for (j, &i) in element.iter().enumerate() {
            let i = i as usize;
            if batch.inverse_mass[i] == 0.0 {
                continue;
            }
            for a in 0..dim {
                x[i * dim + a] = sc.anchor[j * dim + a] + d[j * dim + a];
            }
        }
        if let FamilyKind::HyperplaneContact { normal, friction } = &f.kind
            && *friction > 0.0
            && l > 0.0
        {
            let i = element[0] as usize;
            let bound = *friction * batch.inverse_mass[i] * l;
            let p = &batch.start[i * dim..(i + 1) * dim];
            static_friction(normal, bound, p, &mut x[i * dim..(i + 1) * dim]);
        }
    }
    Ok(())
}

/// The exact element problems of distances or tethers (slots `range`,
/// in order): the same arithmetic as the generic loop would do, on
/// fixed-size vectors.
fn distances<D: Dim>(
    dim: D,
    batch: &Batch,
    range: Range<usize>,
    x: &mut [f64],
    displacement: &mut [f64],
    lambda: &mut [f64],
) -> Result<(), usize> {
    let n = dim.n();
    let f = batch.family;
    let relation = kinds::relation(&f.kind);
    let (mut ai, mut aj) = (dim.zeros(), dim.zeros());
    let (ai, aj) = (ai.as_mut(), aj.as_mut());
    for e in range {
        let (i, j) = (f.elements[2 * e] as usize, f.elements[2 * e + 1] as usize);
        let (wi, wj) = (batch.inverse_mass[i], batch.inverse_mass[j]);
        let d = &mut displacement[2 * n * e..2 * n * (e + 1)];
        let (di, dj) = d.split_at_mut(n);
        let points = [&x[i * n..(i + 1) * n], &x[j * n..(j + 1) * n]];
        let constants = (wi, wj, f.rest[e], batch.alpha_tilde);
        let l = distance_element(points, [&mut *ai, &mut *aj], [di, dj], constants, relation)
            .ok_or(e)?;
        lambda[e] = l;
        if wi != 0.0 {
            for k in 0..n {
                x[i * n + k] = ai[k] + d[k];
            }
        }
        if wj != 0.0 {
            for k in 0..n {
                x[j * n + k] = aj[k] + d[n + k];
            }
        }
    }
    Ok(())
}

/// The exact element problem of a hyperplane contact; returns λ.
fn hyperplane(
    batch: &Batch,
    normal: &[f64],
    i: usize,
    e: usize,
    sc: &Scratch,
    d: &mut [f64],
) -> f64 {
    let n = batch.dim;
    let w = batch.inverse_mass[i];
    let mut c = -batch.family.rest[e];
    for k in 0..n {
        c += normal[k] * sc.anchor[k];
    }
    let l = kinds::relation(&batch.family.kind).clamp(-c / (w + batch.alpha_tilde));
    for k in 0..n {
        d[k] = w * normal[k] * l;
    }
    l
}

/// One Gauss–Newton step of a nonlinear scalar constraint whose value at
/// y0 = x is `value` with ∇C in `ws.grad`; returns λ.
fn gauss_newton(
    batch: &Batch,
    element: &[u32],
    e: usize,
    value: f64,
    ws: &Workspace,
    sc: &Scratch,
    d: &mut [f64],
) -> f64 {
    let n = batch.dim;
    d.fill(0.0);
    if !value.is_finite() {
        return f64::NAN;
    }
    let weight = |j: usize| batch.inverse_mass[element[j] as usize];
    let residual = value - batch.family.rest[e];
    let relation = kinds::relation(&batch.family.kind);
    let vectors = [&ws.grad[..], &sc.anchor, &ws.points];
    // ∇C zero or undefined (an expression's norm at 0): no response, the
    // standard update's rule.
    let Some(l) = gauss_newton_lambda(n, weight, vectors, (residual, batch.alpha_tilde), relation)
    else {
        return 0.0;
    };
    for (j, &i) in element.iter().enumerate() {
        let w = batch.inverse_mass[i as usize];
        for k in j * n..(j + 1) * n {
            d[k] = w * ws.grad[k] * l;
        }
    }
    l
}

/// One Newton step of a material element's problem; returns λ = −C/α~
/// (C = √(2W) at y0). Err: the law refused the element at y0.
fn material(
    batch: &Batch,
    element: &[u32],
    e: usize,
    ws: &mut Workspace,
    sc: &mut Scratch,
    factors: &mut Factors,
    d: &mut [f64],
) -> Result<f64, usize> {
    let (n, f, at) = (batch.dim, batch.family, batch.alpha_tilde);
    let m = f.kind.material_element(e, &ws.points, n).ok_or(e)?;
    let k = f.arity - 1;
    let (size, count) = (n * k, f.arity * n);
    sc.frame.resize(size * size, 0.0);
    sc.block.resize(count * count, 0.0);
    // The dynamic coordinates of the element, in order.
    sc.dynamic.clear();
    sc.dynamic
        .extend((0..count).filter(|&c| batch.inverse_mass[element[c / n] as usize] != 0.0));
    let q = sc.dynamic.len();
    sc.rhs.resize(q, 0.0);
    let factor = &mut factors.values[e * factors.stride..e * factors.stride + q * q];
    let energy = if factors.valid[e] == factors.stamp {
        element_energy(m, &mut ws.grad, &mut ws.material).map_err(|_| e)?
    } else {
        let energy = material_term(
            m,
            &mut ws.grad,
            &mut sc.frame,
            &mut ws.material,
            &mut sc.hessian,
        )
        .map_err(|_| e)?;
        let (_, rest) = f.kind.rest_view(e).ok_or(e)?;
        sc.system.resize(q * q, 0.0);
        // M + K/α~ with the law's exact Hessian K when that is positive
        // definite (the mass term usually makes it so), else with its
        // PSD projection K⁺ (implicit::project_psd), which always is.
        let mut projected = false;
        loop {
            material_hessian_block(&sc.frame, rest, n, f.arity, &mut sc.block, &mut sc.hessian);
            for (r, &cr) in sc.dynamic.iter().enumerate() {
                let w = batch.inverse_mass[element[cr / n] as usize];
                for (c, &cc) in sc.dynamic.iter().enumerate() {
                    sc.system[r * q + c] = sc.block[cr * count + cc] / at;
                }
                sc.system[r * q + r] += 1.0 / w;
            }
            match cholesky(&sc.system, q, factor) {
                Ok(()) => break,
                Err(_) if !projected => {
                    if !project_psd(&mut sc.frame, size, &mut sc.psd).finite {
                        return Err(e);
                    }
                    projected = true;
                }
                Err(_) => return Err(e),
            }
        }
        factors.valid[e] = factors.stamp;
        energy
    };
    for (r, &cr) in sc.dynamic.iter().enumerate() {
        let w = batch.inverse_mass[element[cr / n] as usize];
        sc.rhs[r] = -((ws.points[cr] - sc.anchor[cr]) / w + ws.grad[cr] / at);
    }
    solve_factored(factor, q, &mut sc.rhs);
    let t = step_length(batch, (element, e), energy, ws, sc);
    d.fill(0.0);
    for (r, &cr) in sc.dynamic.iter().enumerate() {
        d[cr] = ws.points[cr] + t * sc.rhs[r] - sc.anchor[cr];
    }
    // (W may round to a hair below 0 at rest; −0 and NaN go to +0, as
    // shaders/primal_material.wgsl's select sends them.)
    let energy = if energy > 0.0 { energy } else { 0.0 };
    Ok(-(2.0 * energy).sqrt() / at)
}

/// Halvings of the material step before the element keeps its point.
const HALVINGS: u32 = 6;

/// The element's objective φ(y) = ½ Σ_dyn (y − a)²/w + W/α~ at `points`
/// (W = `energy` there).
fn objective(batch: &Batch, element: &[u32], points: &[f64], energy: f64, sc: &Scratch) -> f64 {
    let n = batch.dim;
    let mut m = 0.0;
    for &cr in &sc.dynamic {
        let w = batch.inverse_mass[element[cr / n] as usize];
        let u = points[cr] - sc.anchor[cr];
        m += u * u / w;
    }
    0.5 * m + energy / batch.alpha_tilde
}

/// The step length t of y = y0 + t Δ (Δ in `sc.rhs`): the first of 1, ½,
/// … (HALVINGS halvings) at which the law accepts the element and
/// φ(y) ≤ φ(y0); 0 (the element keeps y0) when none does. A chord step
/// with a factor made earlier in the substep, or a Newton step across the
/// law's non-convex region, can overshoot: this keeps every update from
/// raising its element's objective (docs/equilibria.md).
fn step_length(
    batch: &Batch,
    (element, e): (&[u32], usize),
    energy: f64,
    ws: &mut Workspace,
    sc: &mut Scratch,
) -> f64 {
    let (f, n) = (batch.family, batch.dim);
    let start = objective(batch, element, &ws.points, energy, sc);
    sc.trial.clone_from(&ws.points);
    let mut t = 1.0;
    for _ in 0..=HALVINGS {
        for (r, &cr) in sc.dynamic.iter().enumerate() {
            sc.trial[cr] = ws.points[cr] + t * sc.rhs[r];
        }
        let accepted = f.kind.material_element(e, &sc.trial, n).and_then(|m| {
            let energy = element_energy(m, &mut ws.grad, &mut ws.material).ok()?;
            Some(objective(batch, element, &sc.trial, energy, sc) <= start)
        });
        if accepted == Some(true) {
            return t;
        }
        t *= 0.5;
    }
    0.0
}
