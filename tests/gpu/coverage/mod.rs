//! Coverage that kills wrong kernels (issue 18; the mutants are
//! `scripts/mutants.toml`, the results `docs/mutation.md`).
//!
//! Every test here reaches a term, a field or a decision that the other
//! GPU tests leave at a default, and compares against the golden path by
//! the rules of `common::exact` (f64 on lavapipe: bit for bit) and the
//! per-frame models (`hyperpbd_verify::compare_frame`, `hyperpbd_verify::compare_barrier`):
//!
//! ```text
//! scene_fields   every scene field non-default on every XPBD kernel: gravity
//!                off-axis, per-particle gravity scales (0, negative, > 1),
//!                masses, radii and forces, every family kind with compliance
//!                and 3 iterations (α~λ with λ ≠ 0), friction per obstacle
//!                (0, 0.2, 0.7), contact compliance, damping; in 2, 3, 4 D; and
//!                the barrier path with gravity scales, masses and forces
//! lambda         each projection kernel called repeatedly on one color
//!                without a prediction between (λ ≠ 0 enters α~λ and the
//!                contact and tether clamps): kernel level, f64 bit for bit
//! boundaries     decisions hit exactly: balls exactly touching (C = 0) next
//!                to an overlapping pair, particles exactly on a plane
//! line_search    barrier scenes whose first filtered Newton trial must be
//!                rejected (F rises; F falls by less than the Armijo amount)
//! f32_paths      the f32 scene-origin shift against the same scene at the
//!                world origin, bit for bit in device coordinates
//! ```

use crate::common;

mod boundaries;
mod f32_paths;
mod lambda;
mod line_search;
mod scene_fields;

use common::Lcg;
use hyperpbd::Scene;

fn valid(scene: Scene) -> Scene {
    scene.validate().expect("test scene is valid");
    scene
}

/// A unit vector in R^dim from the leading components `lead` (the rest 0).
fn unit(dim: usize, lead: &[f64]) -> Vec<f64> {
    let mut n: Vec<f64> = (0..dim)
        .map(|a| lead.get(a).copied().unwrap_or(0.0))
        .collect();
    let len = n.iter().map(|c| c * c).sum::<f64>().sqrt();
    for c in &mut n {
        *c /= len;
    }
    n
}
