//! The bound of one kernel: scales, element conditioning κ, roundings per
//! chain (module docs of main.rs).

use super::*;

/// Scales of one comparison.
pub(super) struct Scales {
    pub(super) x: f64,
    pub(super) v: f64,
}

pub(super) fn scales(states: &[&State]) -> Scales {
    Scales {
        x: states
            .iter()
            .map(|s| coordinate_scale(s))
            .fold(0.0, f64::max),
        v: states
            .iter()
            .map(|s| max_abs(&s.velocities))
            .fold(0.0, f64::max),
    }
}

/// Largest element conditioning κ of family `family` at `state` (1 for
/// distance and contact families).
fn conditioning(plan: &Plan, family: usize, state: &State) -> f64 {
    let f = &plan.families[family];
    let dim = plan.dim;
    let k = match f.kind {
        FamilyKind::SimplexMeasure { k } => k,
        FamilyKind::OrientedMeasure => dim,
        _ => return 1.0,
    };
    let mut worst: f64 = 1.0;
    for e in 0..f.len() {
        let ids = &f.elements[e * f.arity..(e + 1) * f.arity];
        let x0 = state.position(ids[0] as usize);
        // Edge matrix as columns e_j = x_j − x_0.
        let edges: Vec<Vec<f64>> = ids[1..]
            .iter()
            .map(|&i| {
                state
                    .position(i as usize)
                    .iter()
                    .zip(x0)
                    .map(|(a, b)| a - b)
                    .collect()
            })
            .collect();
        let norms: f64 = edges
            .iter()
            .map(|e| e.iter().map(|c| c * c).sum::<f64>().sqrt())
            .product();
        let kappa = if matches!(f.kind, FamilyKind::OrientedMeasure) {
            let m = nalgebra::DMatrix::from_fn(dim, k, |r, c| edges[c][r]);
            norms / m.determinant().abs()
        } else {
            let m = nalgebra::DMatrix::from_fn(k, k, |r, c| {
                edges[r]
                    .iter()
                    .zip(&edges[c])
                    .map(|(a, b)| a * b)
                    .sum::<f64>()
            });
            norms * norms / m.determinant().abs()
        };
        worst = worst.max(kappa);
    }
    worst
}

/// Roundings of one projection chain (see the module docs).
fn project_roundings(plan: &Plan, family: usize) -> f64 {
    let n = plan.dim as f64;
    match plan.families[family].kind {
        FamilyKind::Distance => 2.0 * n + 13.0,
        // The distance chain plus the clamp's two roundings (λ + Δλ, − λ).
        FamilyKind::Tether => 2.0 * n + 15.0,
        FamilyKind::HyperplaneContact { .. } => 4.0 * n + 15.0,
        FamilyKind::SimplexMeasure { k } => 4.0 * n + 8.0 * k as f64 + 20.0,
        FamilyKind::OrientedMeasure => 4.0 * n + 8.0 * n + 20.0,
        // No derived f32 rounding count for the material kernel yet
        // (tests/gpu/materials.rs: f64 exact, f32 measured).
        FamilyKind::Material { .. } => f64::NAN,
        // Nor for expressions (held bit for bit to the f32 reference
        // instead: tests/gpu/expressions.rs).
        FamilyKind::Expression(_) => f64::NAN,
        // Mesh contacts have no GPU kernel yet (tests/gpu/xpbd_mesh.rs).
        FamilyKind::MeshContact { .. } => f64::NAN,
    }
}

/// Bounds of one kernel on (positions, velocities).
pub(super) fn kernel_bounds(
    kernel: Kernel,
    plan: &Plan,
    precision: Precision,
    s: &Scales,
    before: &State,
    lambda_bound: &[f64],
) -> (f64, f64) {
    let e = eps(precision);
    let f64_run = precision == Precision::F64;
    let r = |rounds: f64| if f64_run { R64 } else { rounds };
    let h = plan.h;
    match kernel {
        Kernel::Predict => {
            let a = hyperpbd_verify::compare_frame::largest_acceleration(plan);
            (
                e * r(8.0) * (s.x + h * (s.v + h * a)),
                e * r(8.0) * (s.v + h * a),
            )
        }
        Kernel::Project { family, .. } => {
            let kappa = conditioning(plan, family, before);
            (
                e * s.x * (2.0 + 2.0 * kappa * r(project_roundings(plan, family))),
                0.0,
            )
        }
        Kernel::Velocity => (0.0, e * r(3.0) * s.v),
        Kernel::Friction { family } => {
            let FamilyKind::HyperplaneContact { friction, .. } = plan.families[family].kind else {
                unreachable!("friction of a contact family")
            };
            let n = plan.dim as f64;
            (
                0.0,
                e * r(5.0 * n + 14.0) * s.v + friction * lambda_bound[family] / h,
            )
        }
        Kernel::Damping => (0.0, e * r(2.0) * s.v),
        Kernel::Broadphase | Kernel::Collide => {
            unreachable!("these cases have no collisions (the GPU backend refuses them)")
        }
        Kernel::Minimise => {
            unreachable!("XPBD scenes only; the barrier path has tests/gpu/barrier/")
        }
        Kernel::Motion => {
            unreachable!("these cases have no prescribed motion (tests/cpu/motion.rs has it)")
        }
        Kernel::GuardMeasure { .. } | Kernel::GuardSpeed => {
            unreachable!("these cases have no guards (tests/gpu/guards.rs has them)")
        }
    }
}
