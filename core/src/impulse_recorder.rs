//! The contact impulses of a step, measured around its kernels when the
//! step is asked for contact forces (`contact_forces.rs` has the
//! definition). The golden path calls it around its own kernels; the GPU
//! backends replay it over the device's states copied out around the same
//! kernels. Nothing here runs otherwise, and nothing here writes the
//! state: the kernels are the same calls with or without it.
//!
//! ```text
//! XPBD, per substep (h):
//!   hyperplane or mesh family of obstacle o, element e (particle i), at the substep's end:
//!     J_i += n λ_e / h,  F_o −= n λ_e / h           (λ_e: the substep's multiplier; n the
//!                                                   plane's normal in this substep, a
//!                                                   mesh's at x_i within reach w λ_e)
//!   around each Project call of a plane with μ > 0 (static friction in the position solve):
//!     Δ = x_i(after) − x_i(before);  J_i += m_i (Δ − (n·Δ) n) / h   (its tangential move;
//!     the normal move is w n Δλ, counted by λ above), also on o
//!   around each Friction call (dynamic friction, a velocity change):
//!     J_i += m_i (v_i(after) − v_i(before)), also on o
//!   around each Collide call (particle–particle, averaged Jacobi moves):
//!     J_i += m_i (x_i(after) − x_i(before)) / h    (dynamic particles)
//! barrier path, per substep at the accepted iterate x:
//!   J_i += −b'(d_io) ∇d_io h for every active obstacle o, also on o
//! moving plane or mesh o, with every impulse J_i above:  W_o += J_i · D_o(p_i) / h
//!   (p_i the particle's position at the substep's start, D_o the obstacle's carry;
//!   a moving mesh's n is taken in its frame and turned back: `moving_mesh`)
//! the step's end:  F = J / dt,  P_o = W_o / dt
//! ```
//! Fixed particles never move, so on the XPBD path their particle contacts
//! report 0 (obstacle families hold dynamic particles only).

// Coordinate loops index several arrays at once, as a kernel does.
#![allow(clippy::needless_range_loop)]

use crate::contact_forces::barrier_forces;
use crate::motion::SubstepMotion;
use crate::moving_mesh::closest_placed;
use crate::{ContactForces, FamilyKind, IncrementalPotentialPlan, Kernel, Plan};

/// The impulses of the step so far, and the snapshot of the kernel
/// being measured.
#[derive(Debug, Clone)]
pub struct ImpulseRecorder {
    impulses: ContactForces,
    before: Vec<f64>,
}

/// What a kernel moves that the recorder measures.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Measured {
    /// Positions of a plane family with friction (static friction).
    PlanePositions {
        /// The contact family.
        family: usize,
    },
    /// Velocities of a plane family (dynamic friction).
    PlaneVelocities {
        /// The contact family.
        family: usize,
    },
    /// Every position (particle contact).
    Positions,
}

impl ImpulseRecorder {
    /// Zero impulses for `plan`'s obstacles and particles.
    pub fn new(plan: &Plan) -> Self {
        ImpulseRecorder {
            impulses: ContactForces::zeros(
                plan.dim,
                plan.obstacle_families.len(),
                plan.particle_count(),
            ),
            before: Vec::new(),
        }
    }

    /// Starts a step (an attempt of one).
    pub fn clear(&mut self) {
        self.impulses.clear();
    }

    /// The forces of the step that just ended (impulses over `dt`).
    pub fn forces(&self, dt: f64) -> ContactForces {
        let mut forces = self.impulses.clone();
        forces.per_time(dt);
        forces
    }

    /// Snapshots what `kernel` will move, when it is measured.
    pub fn before(&mut self, plan: &Plan, kernel: Kernel, x: &[f64], v: &[f64]) {
        let n = plan.dim;
        self.before.clear();
        match measured(plan, kernel) {
            Some(Measured::PlanePositions { family }) => {
                gather(&plan.families[family].elements, n, x, &mut self.before)
            }
            Some(Measured::PlaneVelocities { family }) => {
                gather(&plan.families[family].elements, n, v, &mut self.before)
            }
            Some(Measured::Positions) => self.before.extend_from_slice(x),
            None => {}
        }
    }

    /// Adds the impulses `kernel` applied (after [`ImpulseRecorder::before`];
    /// `start`: the positions at the substep's start).
    pub fn after(
        &mut self,
        plan: &Plan,
        (now, lambda, starts): (&SubstepMotion, &[f64], &[usize]),
        kernel: Kernel,
        (x, v, start): (&[f64], &[f64], &[f64]),
    ) {
        let (n, h) = (plan.dim, plan.h);
        let mut j = vec![0.0; n];
        let mut buf = vec![0.0; n];
        match measured(plan, kernel) {
            Some(Measured::PlanePositions { family }) => {
                let o = obstacle_of(plan, family);
                let lambda = &lambda[starts[family]..starts[family + 1]];
                for (e, &i) in plan.families[family].elements.iter().enumerate() {
                    let normal = normal_at(plan, now, (family, e, lambda[e]), x, &mut buf);
                    let i = i as usize;
                    let m = 1.0 / plan.inverse_mass[i];
                    let moved = |a: usize| x[i * n + a] - self.before[e * n + a];
                    let along: f64 = (0..n).map(|a| moved(a) * normal[a]).sum();
                    for a in 0..n {
                        j[a] = m * (moved(a) - along * normal[a]) / h;
                    }
                    add(&mut self.impulses, o, i, &j);
                    self.work(plan, now, (family, o), &start[i * n..(i + 1) * n], &j);
                }
            }
            Some(Measured::PlaneVelocities { family }) => {
                let o = obstacle_of(plan, family);
                for (e, &i) in plan.families[family].elements.iter().enumerate() {
                    let i = i as usize;
                    let m = 1.0 / plan.inverse_mass[i];
                    for a in 0..n {
                        j[a] = m * (v[i * n + a] - self.before[e * n + a]);
                    }
                    add(&mut self.impulses, o, i, &j);
                    self.work(plan, now, (family, o), &start[i * n..(i + 1) * n], &j);
                }
            }
            Some(Measured::Positions) => {
                for (i, &w) in plan.inverse_mass.iter().enumerate() {
                    if w == 0.0 {
                        continue;
                    }
                    for a in 0..n {
                        j[a] = (x[i * n + a] - self.before[i * n + a]) / w / h;
                    }
                    self.impulses.add_particle_impulse(i, &j);
                }
            }
            None => {}
        }
    }

    /// The normal impulses n λ / h of the substep that just ended, from
    /// every plane family's multipliers (`lambda` of family f at
    /// `lambda[starts[f]..starts[f + 1]]`; `x`: the positions now, `start`:
    /// at the substep's start).
    pub fn end_substep(
        &mut self,
        plan: &Plan,
        now: &SubstepMotion,
        (lambda, starts): (&[f64], &[usize]),
        (x, start): (&[f64], &[f64]),
    ) {
        let (n, h) = (plan.dim, plan.h);
        let mut j = vec![0.0; n];
        let mut buf = vec![0.0; n];
        for (o, family) in plan.obstacle_families.iter().enumerate() {
            let Some(family) = *family else { continue };
            let elements = &plan.families[family].elements;
            let lambda = &lambda[starts[family]..starts[family + 1]];
            for (e, (&i, &l)) in elements.iter().zip(lambda).enumerate() {
                if l == 0.0 {
                    continue;
                }
                let normal = normal_at(plan, now, (family, e, l), x, &mut buf);
                for a in 0..n {
                    j[a] = normal[a] * l / h;
                }
                let i = i as usize;
                self.impulses.add_obstacle_impulse(o, i, &j);
                self.work(plan, now, (family, Some(o)), &start[i * n..(i + 1) * n], &j);
            }
        }
    }

    /// The work J·D(p)/h of impulse `j` of contact family `family`
    /// (obstacle `o`) on a particle that started the substep at `p`, when
    /// the plane or mesh moves.
    fn work(
        &mut self,
        plan: &Plan,
        now: &SubstepMotion,
        (family, o): (usize, Option<usize>),
        p: &[f64],
        j: &[f64],
    ) {
        let moving = now
            .plane(plan.motion.as_ref(), family)
            .map(|plane| &plane.carry)
            .or_else(|| {
                now.mesh(plan.motion.as_ref(), family)
                    .map(|mesh| &mesh.carry)
            });
        let (Some(o), Some(carry)) = (o, moving) else {
            return;
        };
        let mut u = vec![0.0; p.len()];
        carry.at(p, &mut u);
        let w: f64 = j.iter().zip(&u).map(|(j, u)| j * u / plan.h).sum();
        self.impulses.add_obstacle_work(o, w);
    }

    /// The impulses so far (the coupled step adds its contacts' own,
    /// `hyperpbd-cpu`'s `coupled::contact_impulses`).
    pub fn impulses_mut(&mut self) -> &mut ContactForces {
        &mut self.impulses
    }

    /// The barrier path's obstacle impulses −∇B h at the accepted iterate
    /// `x` of a substep (every dynamic particle).
    pub fn barriers(&mut self, plan: &Plan, ip: &IncrementalPotentialPlan, x: &[f64]) {
        let (n, h) = (plan.dim, plan.h);
        let mut j = vec![0.0; n];
        for (i, &w) in plan.inverse_mass.iter().enumerate() {
            if w == 0.0 {
                continue;
            }
            let xi = &x[i * n..(i + 1) * n];
            barrier_forces(&ip.law, &ip.obstacles, xi, plan.radius[i], |o, force| {
                for a in 0..n {
                    j[a] = force[a] * h;
                }
                self.impulses.add_obstacle_impulse(o, i, &j);
            });
        }
    }
}

/// What `kernel` moves that is measured, if anything.
pub fn measured(plan: &Plan, kernel: Kernel) -> Option<Measured> {
    match kernel {
        Kernel::Project { family, .. } => match &plan.families[family].kind {
            FamilyKind::HyperplaneContact { friction, .. }
            | FamilyKind::MeshContact { friction, .. } => {
                (*friction > 0.0).then_some(Measured::PlanePositions { family })
            }
            FamilyKind::Distance
            | FamilyKind::Tether
            | FamilyKind::SimplexMeasure { .. }
            | FamilyKind::OrientedMeasure
            | FamilyKind::Material { .. }
            | FamilyKind::Expression(_) => None,
        },
        Kernel::Friction { family } => Some(Measured::PlaneVelocities { family }),
        Kernel::Collide => Some(Measured::Positions),
        Kernel::Motion
        | Kernel::Predict
        | Kernel::Velocity
        | Kernel::Damping
        | Kernel::Broadphase
        | Kernel::Minimise
        | Kernel::GuardMeasure { .. }
        | Kernel::GuardSpeed => None,
    }
}

/// The authored obstacle of plane family `family` (every plane family
/// has one in a compiled plan).
fn obstacle_of(plan: &Plan, family: usize) -> Option<usize> {
    plan.obstacle_families
        .iter()
        .position(|&f| f == Some(family))
}

/// The unit normal of element `e` (multiplier `l`) of contact family
/// `family` in this substep: the plane's, or the mesh's at `x` within
/// reach w λ (zeros out of reach: `kinds::mesh_contact`), written to `buf`.
fn normal_at<'a>(
    plan: &'a Plan,
    now: &'a SubstepMotion,
    (family, e, l): (usize, usize, f64),
    x: &[f64],
    buf: &'a mut [f64],
) -> &'a [f64] {
    if let Some(plane) = now.plane(plan.motion.as_ref(), family) {
        return &plane.normal;
    }
    let f = &plan.families[family];
    match &f.kind {
        FamilyKind::HyperplaneContact { normal, .. } => normal,
        FamilyKind::MeshContact { mesh, .. } => {
            let (n, i) = (plan.dim, f.elements[e] as usize);
            let reach = plan.inverse_mass[i] * l;
            let xi = &x[i * n..(i + 1) * n];
            let mesh = &plan.meshes[*mesh];
            let frame = now.mesh(plan.motion.as_ref(), family).map(|m| m.frame(&[]));
            if closest_placed(mesh, frame.as_ref(), (xi, f.rest[e], reach), buf, None).is_none() {
                buf.fill(0.0);
            }
            buf
        }
        FamilyKind::Distance
        | FamilyKind::Tether
        | FamilyKind::SimplexMeasure { .. }
        | FamilyKind::OrientedMeasure
        | FamilyKind::Material { .. }
        | FamilyKind::Expression(_) => &[],
    }
}

/// Impulse `j` on particle i from obstacle `o` (counted on both).
fn add(impulses: &mut ContactForces, o: Option<usize>, i: usize, j: &[f64]) {
    match o {
        Some(o) => impulses.add_obstacle_impulse(o, i, j),
        None => impulses.add_particle_impulse(i, j),
    }
}

/// The values of `particles` (N each) from `values` into `out`.
fn gather(particles: &[u32], n: usize, values: &[f64], out: &mut Vec<f64>) {
    for &i in particles {
        let i = i as usize;
        out.extend_from_slice(&values[i * n..(i + 1) * n]);
    }
}
