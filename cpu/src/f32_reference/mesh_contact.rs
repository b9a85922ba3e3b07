//! Simplex-mesh contact in f32 (`hyperpbd_core::kinds::mesh_contact` has
//! the constraint; `mesh_contact.rs` of the golden path the same steps in
//! f64).
//!
//! ```text
//! vertices   each f64 rounded to f32 once, after subtracting the scene
//!            origin o in f64 (positions here are x − o)
//! candidates the mesh hierarchy's simplices whose (f64) box meets
//!            barrier::candidate_box((x + o) in f64, r, reach) with the pad
//!            M = 16 N (N + 4) ε_f32, in index order
//! distance   barrier.rs's `obstacle_distance` (the shader's f32 closest
//!            point: every face's Gram solve, the first smallest |x − q|²)
//! (C, n)     the first smallest C over the candidates; none when
//!            C > reach = w λ or n = 0
//! project    Δλ = (−C − α~ λ)/(w + α~);  λ' = max(λ + Δλ, 0);  x += w n Δλ;
//!            static friction (project.rs's) with this n
//! friction   n at the substep's final x (reach w λ), then integrate.rs's
//!            dynamic friction of one element with that n
//! residual   max(0, −C) with reach 0
//! moving     the query point mapped into the mesh's frame and n turned
//!            back (`hyperpbd_core::moving_mesh`, the frame rounded once);
//!            friction against the carry, as a moving plane's (motion.rs)
//! ```

use std::sync::Arc;

use hyperpbd_core::barrier::{BarrierObstacles, SIMPLEX_SLOTS, candidate_box, distance_margin};
use hyperpbd_core::kinds::mesh_contact::first_closest;
use hyperpbd_core::{Family, FamilyKind, MAX_DIM, Plan};

use super::Particles;
use super::barrier::{BarrierInputs, obstacle_distance};
use super::integrate::{Friction, friction as plane_friction};
use super::motion::{Mesh32At, carried_friction, carried_static_friction};
use super::project::Colour;
use hyperpbd_core::kinds::contact_friction::static_friction;
use hyperpbd_core::kinds::hyperplane_contact::contact_update;

/// One mesh as the f32 reference holds it.
#[derive(Debug, Clone)]
pub struct Mesh32 {
    /// The golden mesh (its hierarchy and boxes, world coordinates).
    mesh: Arc<BarrierObstacles>,
    /// The vertices in f32 device coordinates (no planes).
    inputs: BarrierInputs,
    /// The scene origin o.
    origin: Vec<f64>,
}

impl Mesh32 {
    /// The mesh of family `f` of `plan` when it is a mesh contact family.
    pub fn of(plan: &Plan, f: &Family, origin: &[f64]) -> Option<Self> {
        let FamilyKind::MeshContact { mesh, .. } = &f.kind else {
            return None;
        };
        Some(Mesh32::new(plan.dim, &plan.meshes[*mesh], origin))
    }

    /// `mesh` with positions stored relative to `origin`.
    pub fn new(dim: usize, mesh: &Arc<BarrierObstacles>, origin: &[f64]) -> Self {
        let geometry = mesh
            .simplex_vertices
            .chunks_exact(dim)
            .flat_map(|v| v.iter().zip(origin).map(|(c, o)| (c - o) as f32))
            .collect();
        debug_assert_eq!(
            mesh.simplex_vertices.len(),
            mesh.simplex_count() * SIMPLEX_SLOTS * dim
        );
        Mesh32 {
            mesh: mesh.clone(),
            inputs: BarrierInputs {
                dim,
                planes: 0,
                geometry,
                arity: mesh.simplex_arity.clone(),
                stiffness: 0.0,
                activation: 0.0,
                safety: 0.0,
            },
            origin: origin.to_vec(),
        }
    }

    /// C and n (into `normal`) of a particle at `x` (device coordinates)
    /// with radius `r` and reach `reach` (module docs).
    pub fn closest(&self, x: &[f32], r: f32, reach: f32, normal: &mut [f32]) -> Option<f32> {
        let dim = x.len();
        let mut world = [0.0f64; MAX_DIM];
        for a in 0..dim {
            world[a] = f64::from(x[a]) + self.origin[a];
        }
        let (mut lo, mut hi) = ([0.0f64; MAX_DIM], [0.0f64; MAX_DIM]);
        let (lo, hi) = (&mut lo[..dim], &mut hi[..dim]);
        let margin = distance_margin(dim, f64::from(f32::EPSILON));
        let scale = self.mesh.scale;
        candidate_box(&world[..dim], r.into(), reach.into(), scale, margin, lo, hi);
        let mut n = [0.0f32; MAX_DIM];
        let n = &mut n[..dim];
        first_closest(self.mesh.near(lo, hi), reach, (n, normal), |s, n| {
            obstacle_distance(&self.inputs, s, x, r, n)
        })
    }

    /// [`Mesh32::closest`] for a mesh placed by `moving` (`None`: static):
    /// the query in its frame, the normal turned back
    /// (`hyperpbd_core::moving_mesh`).
    pub fn closest_placed(
        &self,
        moving: Option<&Mesh32At>,
        x: &[f32],
        (r, reach): (f32, f32),
        normal: &mut [f32],
    ) -> Option<f32> {
        let Some(at) = moving else {
            return self.closest(x, r, reach, normal);
        };
        let dim = x.len();
        let (mut y, mut scratch) = ([0.0f32; MAX_DIM], [0.0f32; MAX_DIM]);
        at.frame.to_frame(x, &mut y[..dim]);
        let c = self.closest(&y[..dim], r, reach, normal)?;
        at.frame.normal_back(normal, &mut scratch[..dim]);
        Some(c)
    }
}

/// Projects colour `c` of a mesh family with friction `mu` (a moving mesh
/// where `moving` places it); the first slot whose update was not finite
/// (every slot is still visited).
pub fn project(
    s: &mut Particles,
    c: &Colour,
    (mesh, moving): (&Mesh32, Option<&Mesh32At>),
    mu: f32,
    lambda: &mut [f32],
) -> Result<(), usize> {
    let n = s.dim;
    let mut normal = [0.0f32; MAX_DIM];
    let normal = &mut normal[..n];
    let mut q = [0.0f32; MAX_DIM];
    let mut failed = None;
    for e in c.slots.clone() {
        let i = c.elements[e] as usize;
        let w = s.w[i];
        let l = lambda[e];
        let (x, p) = (&mut s.x[i * n..(i + 1) * n], &s.p[i * n..(i + 1) * n]);
        let Some(cval) = mesh.closest_placed(moving, x, (c.rest[e], w * l), normal) else {
            continue;
        };
        let Some(l_new) = contact_update(cval, (l, w, c.alpha_tilde), normal, x) else {
            failed = failed.or(Some(e));
            continue;
        };
        lambda[e] = l_new;
        if mu > 0.0 && l_new > 0.0 {
            let bound = mu * w * l_new;
            match moving {
                None => static_friction(normal, bound, p, x),
                Some(at) => carried_static_friction(&at.carry, (normal, bound), p, &mut q[..n], x),
            }
        }
    }
    failed.map_or(Ok(()), Err)
}

/// Dynamic friction of mesh family `f` (stored rest values `rest`; a
/// moving mesh where `moving` places it); the smallest particle whose
/// velocity became non-finite.
pub fn friction(
    s: &mut Particles,
    (f, rest, mesh, moving): (&Family, &[f32], &Mesh32, Option<&Mesh32At>),
    (mu, h): (f32, f32),
    lambda: &[f32],
) -> Result<(), usize> {
    let n = s.dim;
    let mut normal = [0.0f32; MAX_DIM];
    let normal = &mut normal[..n];
    let mut rel = [0.0f32; MAX_DIM];
    let mut failed: Option<usize> = None;
    for (e, (&i, &l)) in f.elements.iter().zip(lambda).enumerate() {
        if l <= 0.0 {
            continue;
        }
        let iu = i as usize;
        let x = &s.x[iu * n..(iu + 1) * n];
        let reach = s.w[iu] * l;
        if mesh
            .closest_placed(moving, x, (rest[e], reach), normal)
            .is_none()
        {
            continue;
        }
        if let Some(at) = moving {
            let limit = mu * s.w[iu] * l / h;
            let (p, v) = (&s.p[iu * n..(iu + 1) * n], &mut s.v[iu * n..(iu + 1) * n]);
            let applied = carried_friction(&at.carry, (normal, limit, h), p, &mut rel[..n], v);
            if applied && !v.iter().all(|c| c.is_finite()) {
                failed = Some(failed.map_or(iu, |f| f.min(iu)));
            }
            continue;
        }
        let one = Friction {
            normal,
            mu,
            h,
            particles: &[i],
            lambda: &[l],
        };
        if let Err(p) = plane_friction(s, &one) {
            failed = Some(failed.map_or(p, |f| f.min(p)));
        }
    }
    failed.map_or(Ok(()), Err)
}

/// max(0, −C) of a particle at `x` with radius `r` (a moving mesh where
/// `moving` places it).
pub fn violation(mesh: &Mesh32, moving: Option<&Mesh32At>, x: &[f32], r: f32) -> f32 {
    let mut normal = [0.0f32; MAX_DIM];
    let normal = &mut normal[..x.len()];
    (mesh.closest_placed(moving, x, (r, 0.0), normal)).map_or(0.0, |c| (-c).max(0.0))
}
