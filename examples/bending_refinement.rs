//! The refinement study of the two bending models (docs/bending.md): a
//! strip 1 m × 0.1 m, one cell across, n = 8, 16, 32, 64 cells along its
//! length, bending hinges on every interior edge (`grid_bending`), both
//! models at one compliance each. Prints markdown tables.
//!
//! ```text
//! cargo run --release --example bending_refinement
//! ```
//! 1. **Bent in place** (the seed's measurement): the flat-authored strip
//!    placed on a cylinder of curvature κ = 1/m, total bending energy per
//!    unit stiffness Σ ½ (C − rest)² (C²/(2α) with α = 1). The continuum
//!    limit of the quadratic model is ½ B L κ² with B = 3 k w on this mesh
//!    (bending.rs: E_hinge ≈ ½ k · 3|e|²/(A_A + A_B) · φ², φ = κ h over the
//!    n − 1 interior edges across the strip; the diagonals stay flat).
//! 2. **Cantilever under gravity**: clamped over its first 1/8 m (every
//!    particle with x ≤ 0.125 m fixed), 0.1 kg in all, g = 9.81 m/s²,
//!    nearly inextensible (the links as stiff penalty springs), at its
//!    static equilibrium, found by minimising the energy directly
//!    ([`cantilever`]: the equilibrium of the models themselves, free of
//!    any solver's iteration count). Tip deflection (mean drop of the free
//!    end) and the total bending energy Σ C²/(2α) there. Euler–Bernoulli
//!    for the quadratic model: δ = q L_f⁴ / (8 B), q = M g / L, L_f = 7/8 m.
//!
//! On this strip the cells become long across (h = L/n < w from n = 16
//! on), and the equilibrium bends every cell's diagonal hinge as much as
//! its rungs (a slight twist): the strip's stiffness tends to B/2, the
//! bent-in-place B with the diagonals held flat halved.
//!
//! Exponents: least-squares slope of log(quantity) on log(n); for a
//! quantity that converges, the slope of log|q(n) − q(2n)| (the order at
//! which it settles).

use hyperpbd::builders::GridSpec;
use hyperpbd::kinds::BendingModel;
use hyperpbd::{FamilyKind, Plan, Scene, SceneBuilder};

const LENGTH: f64 = 1.0;
const WIDTH: f64 = 0.1;
const MASS: f64 = 0.1;
const CLAMP: f64 = 0.125;
const REFINEMENTS: [usize; 4] = [8, 16, 32, 64];

/// The strip with n cells along its length and one bending family of
/// `model` at compliance `alpha`; (scene, bending family index).
fn strip(n: usize, model: BendingModel, alpha: f64) -> (Scene, usize) {
    let h = LENGTH / n as f64;
    let mut b = SceneBuilder::new(3).dt(1.0 / 60.0).gravity_along(1, 9.81);
    let grid = b.grid(&GridSpec {
        counts: vec![n + 1, 2],
        axes: vec![0, 2],
        origin: vec![0.0; 3],
        spacing: h,
        mass: MASS / (2 * (n + 1)) as f64,
        compliance: 0.0,
        shear: false,
    });
    // One diagonal per cell, the one the hinges' triangles share.
    let diagonals = (0..n).map(|i| vec![grid.index(&[i, 0]), grid.index(&[i + 1, 1])]);
    b.family(hyperpbd::ConstraintFamily::new(
        hyperpbd::ConstraintKind::Distance,
        0.0,
        diagonals.collect(),
    ));
    let family = b.grid_bending(&grid, alpha, model).expect("hinges");
    let mut scene = b.build().expect("valid");
    for p in &mut scene.particles {
        // The builder's spacing is h both ways: the strip is WIDTH across.
        p.position[2] *= WIDTH / h;
        if p.position[0] <= CLAMP + 1e-12 {
            *p = hyperpbd::Particle::fixed(p.position.clone());
        }
    }
    (scene, family)
}

/// Σ ½ (C − rest)² over the bending family of `plan` at positions `x`.
fn bending_energy(plan: &Plan, family: usize, x: &[f64], alpha: f64) -> f64 {
    let f = &plan.families[family];
    let FamilyKind::Expression(kind) = &f.kind else {
        panic!("bending is an expression family")
    };
    let dim = plan.dim;
    let mut columns = hyperpbd::core::expr::Columns::new();
    let mut points = vec![0.0; 4 * dim];
    let mut total = 0.0;
    for e in 0..f.len() {
        for (j, &i) in f.elements[4 * e..4 * e + 4].iter().enumerate() {
            let i = i as usize;
            points[j * dim..(j + 1) * dim].copy_from_slice(&x[i * dim..(i + 1) * dim]);
        }
        let c = kind.value_at(e, &points, &mut columns) - f.rest[e];
        total += c * c / (2.0 * alpha);
    }
    total
}

/// The authored strip laid on a cylinder of curvature `kappa` (axis along
/// the width: arc length x ↦ (sin(κx)/κ, (1 − cos κx)/κ)).
fn on_cylinder(scene: &Scene, kappa: f64) -> Vec<f64> {
    let bend = |p: &[f64]| {
        let t = kappa * p[0];
        [t.sin() / kappa, (1.0 - t.cos()) / kappa, p[2]]
    };
    scene
        .particles
        .iter()
        .flat_map(|p| bend(&p.position))
        .collect()
}

/// The static equilibrium of the clamped strip under gravity, found by
/// minimising its energy directly (Levenberg–Marquardt on dense Newton
/// steps): U(x) = Σ_hinges (C − rest)²/(2α) + Σ_links ½ K_S (|d| − ℓ)² +
/// Σ_i m_i g y_i, the links' penalty K_S standing in for inextensibility.
/// Bending's gradient and Hessian come from the kind itself: the
/// quadratic model's constant ½k|v|² Hessian k·k_j k_l δ_ab from its
/// per-element weights ([`hyperpbd::kinds::ExpressionKind::constants`]),
/// the cosine's from its derived ∇C and ∇²C tapes. Returns (tip drop,
/// bending energy, Newton iterations, wall ms).
fn cantilever(n: usize, model: BendingModel, alpha: f64) -> (f64, f64, usize, f64) {
    let (scene, family) = strip(n, model, alpha);
    let plan = Plan::compile(&scene).expect("compiles");
    let start = std::time::Instant::now();
    let count = scene.particles.len();
    let mut dof = vec![usize::MAX; count];
    let mut free = 0;
    for (i, p) in scene.particles.iter().enumerate() {
        if !p.fixed {
            dof[i] = free;
            free += 3;
        }
    }
    let mut x: Vec<f64> = scene
        .particles
        .iter()
        .flat_map(|p| p.position.clone())
        .collect();
    let FamilyKind::Expression(kind) = &plan.families[family].kind else {
        panic!("bending is an expression family")
    };
    let tape = kind.hessian_tape().expect("the Hessian tape fits");
    let system = |x: &[f64]| assemble((&plan, family, tape), &dof, free, x, alpha);
    let mut mu = 1e-3;
    let mut iterations = 0;
    let (mut energy, mut gradient, mut hessian) = system(&x);
    loop {
        let norm = gradient.iter().fold(0.0f64, |m, g| m.max(g.abs()));
        if norm < 1e-8 {
            break;
        }
        assert!(
            iterations < 1000,
            "n {n} {model:?}: |∇U| = {norm:e} after 1000 steps"
        );
        iterations += 1;
        let mut damped = hessian.clone();
        for d in 0..free {
            damped[d * free + d] += mu * (1.0 + hessian[d * free + d].abs());
        }
        let step = solve(&mut damped, free, &gradient);
        let mut trial = x.clone();
        for (i, &d) in dof.iter().enumerate() {
            if d != usize::MAX {
                for a in 0..3 {
                    trial[3 * i + a] -= step[d + a];
                }
            }
        }
        let next = system(&trial);
        if next.0.is_finite() && next.0 <= energy {
            (x, energy, gradient, hessian) = (trial, next.0, next.1, next.2);
            mu = (mu / 3.0).max(1e-12);
        } else {
            mu *= 4.0;
        }
    }
    let ms = start.elapsed().as_secs_f64() * 1e3;
    let tip: Vec<usize> = (0..count)
        .filter(|&i| (scene.particles[i].position[0] - LENGTH).abs() < 1e-9)
        .collect();
    let drop = -tip.iter().map(|&i| x[3 * i + 1]).sum::<f64>() / tip.len() as f64;
    (
        drop,
        bending_energy(&plan, family, &x, alpha),
        iterations,
        ms,
    )
}

/// Stiffness of the links' penalty, N/m (the strip weighs 0.98 N: links
/// stretch by ~1e-6 m).
const K_S: f64 = 1e6;

/// U, ∇U and ∇²U (dense, over the free coordinates `dof`) at `x`.
fn assemble(
    (plan, family, tape): (&Plan, usize, &hyperpbd::core::expr::Tape),
    dof: &[usize],
    free: usize,
    x: &[f64],
    alpha: f64,
) -> (f64, Vec<f64>, Vec<f64>) {
    let (mut u, mut g, mut h) = (0.0, vec![0.0; free], vec![0.0; free * free]);
    let mut add = |members: &[u32], ge: &[f64], he: &dyn Fn(usize, usize) -> f64| {
        let k = members.len() * 3;
        for p in 0..k {
            let dp = dof[members[p / 3] as usize];
            if dp == usize::MAX {
                continue;
            }
            g[dp + p % 3] += ge[p];
            for q in 0..k {
                let dq = dof[members[q / 3] as usize];
                if dq != usize::MAX {
                    h[(dp + p % 3) * free + dq + q % 3] += he(p, q);
                }
            }
        }
    };
    for (i, m) in plan.inverse_mass.iter().enumerate() {
        if *m > 0.0 {
            u += 9.81 * x[3 * i + 1] / m;
            add(&[i as u32], &[0.0, 9.81 / m, 0.0], &|_, _| 0.0);
        }
    }
    for (f, fam) in plan.families.iter().enumerate() {
        for e in 0..fam.len() {
            let members = &fam.elements[fam.arity * e..fam.arity * (e + 1)];
            let pts: Vec<f64> = (members.iter())
                .flat_map(|&i| x[3 * i as usize..3 * i as usize + 3].to_vec())
                .collect();
            if f != family {
                // A link: ½ K_S (|d| − ℓ)².
                let d: Vec<f64> = (0..3).map(|a| pts[3 + a] - pts[a]).collect();
                let l = d.iter().map(|c| c * c).sum::<f64>().sqrt();
                let (s, t) = (l - fam.rest[e], (l - fam.rest[e]) / l);
                u += 0.5 * K_S * s * s;
                let n: Vec<f64> = d.iter().map(|c| c / l).collect();
                let ge: Vec<f64> = (0..6)
                    .map(|p| K_S * s * n[p % 3] * if p < 3 { -1.0 } else { 1.0 })
                    .collect();
                let block = |a: usize, b: usize| {
                    let eye = if a == b { 1.0 } else { 0.0 };
                    // Gauss–Newton where compressed (t < 0): PSD.
                    K_S * (n[a] * n[b] + t.max(0.0) * (eye - n[a] * n[b]))
                };
                let sign = |p: usize| if p < 3 { -1.0 } else { 1.0 };
                add(members, &ge, &|p, q| {
                    sign(p) * sign(q) * block(p % 3, q % 3)
                });
                continue;
            }
            let FamilyKind::Expression(kind) = &fam.kind else {
                panic!("bending is an expression family")
            };
            let k = kind.constants(e);
            if k.len() == 3 {
                // Quadratic: ½ k |v|², v = Σ_j k_j x_j (k_0 = −k_1 − k_2 − k_3).
                let w = [-(k[0] + k[1] + k[2]), k[0], k[1], k[2]];
                let v: Vec<f64> = (0..3)
                    .map(|a| (0..4).map(|j| w[j] * pts[3 * j + a]).sum())
                    .collect();
                u += v.iter().map(|c| c * c).sum::<f64>() / (2.0 * alpha);
                let ge: Vec<f64> = (0..12).map(|p| w[p / 3] * v[p % 3] / alpha).collect();
                let he = |p: usize, q: usize| match p % 3 == q % 3 {
                    true => w[p / 3] * w[q / 3] / alpha,
                    false => 0.0,
                };
                add(members, &ge, &he);
            } else {
                // Cosine: (C − rest)²/(2α) from the derived ∇C, ∇²C.
                let mut columns = hyperpbd::core::expr::Columns::new();
                let read = |k: usize| pts[k];
                kind.eval_slots(tape, 3, &[0, 1, 2, 3], &[], 0..1, read, &mut columns);
                let out: Vec<f64> = tape.outputs().map(|s| columns.get(s, 0)).collect();
                let c = out[0] - fam.rest[e];
                u += c * c / (2.0 * alpha);
                let gc = &out[1..13];
                let ge: Vec<f64> = gc.iter().map(|g| c * g / alpha).collect();
                let he = |p: usize, q: usize| {
                    (gc[p] * gc[q] + c * out[13 + tape.hessian_index(p, q)]) / alpha
                };
                add(members, &ge, &he);
            }
        }
    }
    (u, g, h)
}

/// Solves (symmetric) `a` y = `b` by LDLᵀ with a floor on the pivots
/// (a·b notation: a is n × n, row-major, overwritten).
fn solve(a: &mut [f64], n: usize, b: &[f64]) -> Vec<f64> {
    for j in 0..n {
        for k in 0..j {
            let l = a[j * n + k];
            for i in j..n {
                a[i * n + j] -= l * a[i * n + k] * a[k * n + k];
            }
        }
        let d = a[j * n + j].max(1e-12);
        a[j * n + j] = d;
        for i in j + 1..n {
            a[i * n + j] /= d;
        }
    }
    let mut y = b.to_vec();
    for i in 0..n {
        for k in 0..i {
            y[i] -= a[i * n + k] * y[k];
        }
    }
    for i in 0..n {
        y[i] /= a[i * n + i];
    }
    for i in (0..n).rev() {
        for k in i + 1..n {
            y[i] -= a[k * n + i] * y[k];
        }
    }
    y
}

/// Least-squares slope of log y on log n.
fn slope(ns: &[usize], ys: &[f64]) -> f64 {
    let xs: Vec<f64> = ns.iter().map(|&n| (n as f64).ln()).collect();
    let ls: Vec<f64> = ys.iter().map(|y| y.abs().ln()).collect();
    let k = xs.len() as f64;
    let (mx, my) = (xs.iter().sum::<f64>() / k, ls.iter().sum::<f64>() / k);
    let sxy: f64 = xs.iter().zip(&ls).map(|(x, y)| (x - mx) * (y - my)).sum();
    let sxx: f64 = xs.iter().map(|x| (x - mx) * (x - mx)).sum();
    sxy / sxx
}

/// The slope of the successive differences |y(n) − y(2n)|.
fn settling(ns: &[usize], ys: &[f64]) -> f64 {
    let d: Vec<f64> = ys.windows(2).map(|w| w[1] - w[0]).collect();
    slope(&ns[..d.len()], &d)
}

fn main() {
    let models = [(BendingModel::Cosine, 1e-4), (BendingModel::Quadratic, 0.2)];
    println!("## Bent in place: κ = 1/m, energy per unit stiffness Σ ½ (C − rest)²\n");
    println!("| n | hinges | cosine | quadratic | quadratic limit ½·3w·L·κ² |");
    println!("|---|---|---|---|---|");
    let limit = 0.5 * 3.0 * WIDTH * LENGTH;
    let mut columns: Vec<Vec<f64>> = vec![Vec::new(); 2];
    for &n in &REFINEMENTS {
        let mut hinges = 0;
        for (m, &(model, _)) in models.iter().enumerate() {
            let (scene, family) = strip(n, model, 1.0);
            let plan = Plan::compile(&scene).expect("compiles");
            hinges = plan.families[family].len();
            columns[m].push(bending_energy(
                &plan,
                family,
                &on_cylinder(&scene, 1.0),
                1.0,
            ));
        }
        let k = columns[0].len() - 1;
        println!(
            "| {n} | {hinges} | {:.4e} | {:.6} | {limit:.6} |",
            columns[0][k], columns[1][k]
        );
    }
    let errors: Vec<f64> = columns[1].iter().map(|e| e - limit).collect();
    println!(
        "\nslopes in n: cosine total {:+.2}; quadratic error to the limit {:+.2}\n",
        slope(&REFINEMENTS, &columns[0]),
        slope(&REFINEMENTS, &errors)
    );

    println!("## Cantilever under gravity, at rest\n");
    let q = MASS * 9.81 / LENGTH;
    let free: f64 = LENGTH - CLAMP;
    let b = 3.0 * (1.0 / models[1].1) * WIDTH;
    let euler_bernoulli = q * free.powi(4) / (8.0 * b);
    println!(
        "| n | cosine (α = {:e}) tip drop m | cosine energy J | quadratic (α = {}) tip drop m | quadratic energy J | Newton iterations (cos / quad) | wall ms (cos / quad) |",
        models[0].1, models[1].1
    );
    println!("|---|---|---|---|---|---|---|");
    let mut drops: Vec<Vec<f64>> = vec![Vec::new(); 2];
    let mut energies: Vec<Vec<f64>> = vec![Vec::new(); 2];
    for &n in &REFINEMENTS {
        let runs: Vec<_> = (models.iter())
            .map(|&(model, alpha)| cantilever(n, model, alpha))
            .collect();
        for (m, run) in runs.iter().enumerate() {
            drops[m].push(run.0);
            energies[m].push(run.1);
        }
        println!(
            "| {n} | {:.5} | {:.4e} | {:.5} | {:.4e} | {} / {} | {:.0} / {:.0} |",
            runs[0].0, runs[0].1, runs[1].0, runs[1].1, runs[0].2, runs[1].2, runs[0].3, runs[1].3
        );
    }
    println!(
        "\nEuler–Bernoulli (small deflection), quadratic model: δ = q L_f⁴/(8B) = {euler_bernoulli:.5} m \
         with B = 3 k w = {b} N m² (planar cells), {:.5} m with B/2 (cells longer across than along: \
         the diagonal hinges share the bend with the rungs)",
        2.0 * euler_bernoulli
    );
    println!(
        "slopes in n: tip drop cosine {:+.2}, quadratic {:+.2}; successive differences of the tip drop cosine {:+.2}, quadratic {:+.2}",
        slope(&REFINEMENTS, &drops[0]),
        slope(&REFINEMENTS, &drops[1]),
        settling(&REFINEMENTS, &drops[0]),
        settling(&REFINEMENTS, &drops[1]),
    );
}
