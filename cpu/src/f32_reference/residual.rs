//! The step report's residuals in f32, as `shaders/residual.wgsl`
//! computes them: per family the largest violation over its elements
//! (max is exact, so the order of the GPU's reduction does not matter).
//!
//! ```text
//! distance         |d − rest|        d = √(Σ_a (x1 − x0)_a²)
//! tether           max(d − rest, 0)
//! simplex measure  |S − rest|        oriented measure  |V − rest|
//! contact          max(rest − n·x, 0)    (rest in device coordinates)
//! mesh contact     max(0, −C)            (mesh_contact.rs)
//! material         C = √(2W)  (+∞ for an element the law refuses)
//! particle contact max(0, max over listed pairs of r_k + r_m − |x_m − x_k|)
//! ```

// Coordinate loops index several arrays at once, as a kernel does.
#![allow(clippy::needless_range_loop)]

use hyperpbd_core::geometry::overlap;
use hyperpbd_core::kinds::contact_friction::dot_from_zero;
use hyperpbd_core::{Family, FamilyKind};

use super::material::Law;
use hyperpbd_core::geometry::{Scratch, oriented_measure, simplex_squared_measure};

/// |x1 − x0| of the two points in `pts`.
fn distance(pts: &[f32], n: usize) -> f32 {
    let mut d2 = 0.0f32;
    for a in 0..n {
        let e = pts[n + a] - pts[a];
        d2 += e * e;
    }
    d2.sqrt()
}

/// What the residual reads of a stored family: rest values, the plane
/// normal, a material family's law.
pub struct StoredFamily<'a> {
    pub rest: &'a [f32],
    pub normal: &'a [f32],
    pub material: Option<&'a Law>,
    /// A mesh contact family's mesh.
    pub mesh: Option<&'a super::mesh_contact::Mesh32>,
    /// Where the last substep placed it, if it moves.
    pub moving_mesh: Option<&'a super::motion::Mesh32At>,
}

/// Largest violation of family `f` at positions `x` (device coordinates).
pub fn residual(f: &Family, n: usize, x: &[f32], stored: &StoredFamily) -> f32 {
    let (rest, normal) = (stored.rest, stored.normal);
    let mut pts = vec![0.0f32; f.arity * n];
    let mut grad = vec![0.0f32; f.arity * n];
    let mut worst = 0.0f32;
    let mut columns = hyperpbd_core::expr::Columns::new();
    let mut scratch = Scratch::<f32>::default();
    for e in 0..f.len() {
        for (j, &i) in f.elements[e * f.arity..(e + 1) * f.arity]
            .iter()
            .enumerate()
        {
            let i = i as usize;
            pts[j * n..(j + 1) * n].copy_from_slice(&x[i * n..(i + 1) * n]);
        }
        let violation = match &f.kind {
            FamilyKind::Distance => (distance(&pts, n) - rest[e]).abs(),
            FamilyKind::Tether => (distance(&pts, n) - rest[e]).max(0.0),
            FamilyKind::SimplexMeasure { .. } => {
                (simplex_squared_measure(&pts, n, &mut grad, &mut scratch) - rest[e]).abs()
            }
            FamilyKind::OrientedMeasure => {
                (oriented_measure(&pts, n, &mut grad, &mut scratch) - rest[e]).abs()
            }
            FamilyKind::HyperplaneContact { .. } => {
                (rest[e] - dot_from_zero(normal, &pts[..n])).max(0.0)
            }
            FamilyKind::MeshContact { .. } => match stored.mesh {
                Some(mesh) => {
                    super::mesh_contact::violation(mesh, stored.moving_mesh, &pts[..n], rest[e])
                }
                None => 0.0,
            },
            FamilyKind::Expression(kind) => {
                kind.violation(kind.value_at(e, &pts, &mut columns), rest[e])
            }
            FamilyKind::Material { .. } => match stored.material {
                Some(law) => law
                    .constraint(e, &pts, n, &mut grad)
                    .unwrap_or(f32::INFINITY),
                None => 0.0,
            },
        };
        worst = worst.max(violation);
    }
    worst
}

/// The particle-contact residual as `contact_report` computes it: the
/// deepest overlap r_k + r_m − |x_m − x_k| over the pairs of the last
/// lists (m > k), at least 0.
pub fn deepest_overlap(n: usize, x: &[f32], radius: &[f32], lists: &[Vec<u32>]) -> f32 {
    let mut deepest = 0.0f32;
    for (k, list) in lists.iter().enumerate() {
        for &m in list.iter().filter(|&&m| m as usize > k) {
            let m = m as usize;
            deepest = deepest.max(overlap(n, x, [k, m], radius[k] + radius[m]));
        }
    }
    deepest
}
