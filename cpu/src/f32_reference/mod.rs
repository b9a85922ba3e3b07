//! The GPU's f32 step, on the CPU: every XPBD kernel in f32 in the
//! operation order of its WGSL (`shaders/integrate.wgsl`, `project.wgsl`,
//! `measure.wgsl`, `material.wgsl`, `ln_f32.wgsl`, `friction.wgsl`,
//! `residual.wgsl`, `grid.wgsl`, `collide.wgsl`), on the values the GPU
//! backend stores; and the barrier kernels of `barrier.wgsl` ([`barrier`]).
//!
//! ```text
//! stored once, rounded to f32 from the f64 the host computes:
//!   x − o (o: the scene origin, gpu/src/origin.rs), v, f, w, s, g, h,
//!   α / h², exp(−rate h), n, μ, rest (a plane's rest − n·o),
//!   r, μ between particles; pad = r + margin rounded up;
//!   material R, V_0 and Lamé μ, λ
//! step       for every substep: the plan's substep kernels in order
//! read back  x = f64(x₃₂) + o,  v = f64(v₃₂)
//! ```
//! IEEE f32 operations are correctly rounded, so an adapter that runs the
//! WGSL as written (no contraction, no reassociation; lavapipe is one:
//! `tests/common/exact.rs`) gives these bits, and |this − golden|
//! is the exact cost of f32 on a step. A kernel of its own, not the golden
//! path: this file follows the shaders, the golden path DESIGN.md; the
//! f64 bit identity of the two is what ties the orders together.
//!
//! Particle contact as the device runs it: Broadphase builds every particle's ascending list
//! from the f32 swept boxes (`broadphase.rs`), Collide one gather-Jacobi
//! iteration on the last lists (`collide.rs`); the report adds the
//! deepest overlap over the last lists after the families' residuals and
//! the active pairs of the last Collide to the active contacts.
//!
//! Material families (stvk, neo_hookean) run as `material.wgsl` does,
//! Neo-Hookean's ln J by the arithmetic f32 ln of `ln_f32.wgsl` (no
//! built-in log: an adapter's approximation cannot be repeated here); an
//! element the law refuses fails its projection and reads +∞ in the
//! residual.
//!
//! Plans it cannot run are refused at [`F32Reference::new`] with the
//! reason: the incremental-potential (Minimise) step. Guard kernels only
//! read; they are not run here.
//!
//! The barrier path's per-particle kernels stand alone in [`barrier`]:
//! `evaluate` (energy Σ b, gradient Σ b' n, Hessian block Σ b'' n nᵀ,
//! smallest d over every plane and simplex) and `filter_fraction` (the
//! certified step fraction) of `shaders/barrier.wgsl`, in f32 in its order,
//! on the obstacle geometry, κ, d^ and η the device holds (each rounded to
//! f32 once) with the arithmetic f32 ln; `tests/gpu_barrier` holds the
//! kernels' f32 results to them bit for bit on lavapipe. The minimisation
//! around them (ip_gradient, ip_newton) is not here.

// Coordinate loops index several arrays at once, as a kernel does.
#![allow(clippy::needless_range_loop)]

pub mod barrier;
mod broadphase;
mod collide;
mod integrate;
pub mod ln;
mod material;
use material::material_law;
mod mesh_contact;
mod motion;
mod primal;
mod project;
mod residual;

pub use collide::{Iteration, iterate};

use hyperpbd_core::broadphase::key_up;
use hyperpbd_core::expr::Columns;
use hyperpbd_core::kinds;
use hyperpbd_core::{FamilyKind, Kernel, Plan, State};

/// The particle arrays in f32, as the device stores them.
pub struct Particles {
    pub dim: usize,
    pub x: Vec<f32>,
    pub v: Vec<f32>,
    pub p: Vec<f32>,
    pub force: Vec<f32>,
    pub w: Vec<f32>,
    pub gravity_scale: Vec<f32>,
}

/// One family as stored: rest values (planes: in device coordinates),
/// multipliers, the reals of its calls, and a material family's law.
struct Stored {
    rest: Vec<f32>,
    /// An expression family's per-element constants (f32, rounded once).
    constants: Vec<f32>,
    lambda: Vec<f32>,
    alpha_tilde: f32,
    normal: Vec<f32>,
    mu: f32,
    material: Option<material::Law>,
    /// A mesh contact family's mesh.
    mesh: Option<mesh_contact::Mesh32>,
    /// XPBD with the primal residual: d_e of every slot (arity · N each;
    /// empty otherwise), a material family's Newton factors
    /// ((arity · N)² per slot), and whether the family's first sweep of
    /// the substep is done (its later sweeps reuse the factors).
    carried: Vec<f32>,
    factors: Vec<f32>,
    swept: bool,
}

/// Particle contact as stored: radii, box pads and μ in f32, the lists of
/// the last Broadphase and the active pairs (m > k) of the last Collide
/// per particle.
struct Contacts {
    radius: Vec<f32>,
    pad: Vec<f32>,
    mu: f32,
    lists: Vec<Vec<u32>>,
    ahead: Vec<u32>,
}

/// Why the reference cannot run a plan or a step.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ReferenceError {
    /// A stage the GPU's f32 XPBD kernels do not run on the device.
    #[error("the f32 reference does not run {0}")]
    Unsupported(String),
    /// A kernel produced a non-finite value; the state is as before the step.
    #[error("substep {substep}: {kernel:?} became non-finite at index {index}")]
    NonFinite {
        substep: u32,
        kernel: Kernel,
        index: usize,
    },
    /// A state or force vector of the wrong length.
    #[error("{what}: {got} values, the plan needs {expected}")]
    Length {
        what: &'static str,
        got: usize,
        expected: usize,
    },
}

/// The f32 step of the GPU backend, on the CPU.
pub struct F32Reference {
    plan: Plan,
    origin: Vec<f64>,
    particles: Particles,
    families: Vec<Stored>,
    h: f32,
    gravity: Vec<f32>,
    factor: f32,
    contacts: Option<Contacts>,
    /// An expression family's columns, and its projection's scratch.
    columns: Columns<f32>,
    projection: kinds::ProjectionScratch<f32>,
    /// Steps completed (the clock of prescribed motion).
    step_count: u64,
    /// The substep being run.
    substep: u32,
    /// The prescribed values of the current substep (with `motion`).
    motion_now: motion::Motion32,
}

fn round(values: &[f64]) -> Vec<f32> {
    values.iter().map(|&v| v as f32).collect()
}

impl F32Reference {
    /// The reference for `plan` from `state`, positions stored relative
    /// to `origin` (the GPU backend's scene origin; zeros for none).
    pub fn new(plan: Plan, state: &State, origin: &[f64]) -> Result<Self, ReferenceError> {
        for k in &plan.substep_kernels {
            if matches!(k, Kernel::Minimise) {
                return Err(ReferenceError::Unsupported(format!("{k:?}")));
            }
        }
        let shifted = origin.iter().any(|&o| o != 0.0);
        if shifted && let Some(f) = plan.families.iter().find(|f| f.kind.is_expression()) {
            // An expression need not be translation-invariant (a param may
            // be a point): it reads world coordinates.
            return Err(ReferenceError::Unsupported(format!(
                "{} (an expression family) in coordinates shifted by a scene origin",
                f.label
            )));
        }
        let families = plan
            .families
            .iter()
            .enumerate()
            .map(|(index, f)| {
                let (normal, mu) = match &f.kind {
                    FamilyKind::HyperplaneContact { normal, friction } => {
                        (normal.as_slice(), *friction)
                    }
                    FamilyKind::MeshContact { friction, .. } => (&[][..], *friction),
                    FamilyKind::Distance
                    | FamilyKind::Tether
                    | FamilyKind::SimplexMeasure { .. }
                    | FamilyKind::OrientedMeasure
                    | FamilyKind::Material { .. }
                    | FamilyKind::Expression(_) => (&[][..], 0.0),
                };
                // A moving plane's origin term is in its per-substep shift.
                let moving = plan
                    .motion
                    .as_ref()
                    .is_some_and(|m| m.plane_of(index).is_some());
                let rest = f.rest.iter().map(|&r| {
                    if normal.is_empty() || !shifted || moving {
                        return r as f32;
                    }
                    let shift: f64 = normal.iter().zip(origin).map(|(n, o)| n * o).sum();
                    (r - shift) as f32
                });
                Stored {
                    rest: rest.collect(),
                    constants: project::expression_constants(&f.kind),
                    lambda: vec![0.0; f.len()],
                    alpha_tilde: f.alpha_tilde(plan.h) as f32,
                    normal: round(normal),
                    mu: mu as f32,
                    material: material_law(&f.kind),
                    mesh: mesh_contact::Mesh32::of(&plan, f, origin),
                    carried: primal::displacements(&plan, f),
                    factors: primal::factors(&plan, f),
                    swept: false,
                }
            })
            .collect();
        let particles = Particles {
            dim: plan.dim,
            x: Vec::new(),
            v: Vec::new(),
            p: vec![0.0; plan.particle_count() * plan.dim],
            force: round(&plan.force),
            w: round(&plan.inverse_mass),
            gravity_scale: round(&plan.gravity_scale),
        };
        let contacts = plan.contacts.map(|c| Contacts {
            radius: round(&plan.radius),
            pad: plan.radius.iter().map(|&r| key_up(r + c.margin)).collect(),
            mu: c.friction as f32,
            lists: vec![Vec::new(); plan.particle_count()],
            ahead: vec![0; plan.particle_count()],
        });
        if contacts.is_none()
            && let Some(k) = plan
                .substep_kernels
                .iter()
                .find(|k| matches!(k, Kernel::Broadphase | Kernel::Collide))
        {
            return Err(ReferenceError::Unsupported(format!(
                "{k:?} without particle contact settings"
            )));
        }
        let mut reference = F32Reference {
            h: plan.h as f32,
            gravity: round(&plan.gravity),
            factor: plan.damping.map_or(1.0, |(_, factor)| factor) as f32,
            origin: if shifted { origin.to_vec() } else { Vec::new() },
            families,
            particles,
            contacts,
            plan,
            columns: Columns::new(),
            projection: kinds::ProjectionScratch::new(),
            step_count: 0,
            substep: 0,
            motion_now: motion::Motion32::default(),
        };
        reference.write_state(state)?;
        Ok(reference)
    }

    fn check(&self, what: &'static str, got: usize) -> Result<(), ReferenceError> {
        let expected = self.plan.particle_count() * self.plan.dim;
        if got == expected {
            Ok(())
        } else {
            Err(ReferenceError::Length {
                what,
                got,
                expected,
            })
        }
    }

    /// Stores `state` as the device would: (x − o) and v rounded to f32.
    pub fn write_state(&mut self, state: &State) -> Result<(), ReferenceError> {
        self.check("positions", state.positions.len())?;
        self.check("velocities", state.velocities.len())?;
        let n = self.plan.dim;
        self.particles.x = if self.origin.is_empty() {
            round(&state.positions)
        } else {
            let local = state
                .positions
                .chunks_exact(n)
                .flat_map(|p| p.iter().zip(&self.origin).map(|(x, o)| (x - o) as f32));
            local.collect()
        };
        self.particles.v = round(&state.velocities);
        // A written state starts the carried forces over (as the GPU).
        primal::clear(&self.plan, &mut self.families);
        Ok(())
    }

    /// External forces (per particle, `dim` each), rounded to f32.
    pub fn set_forces(&mut self, forces: &[f64]) -> Result<(), ReferenceError> {
        self.check("forces", forces.len())?;
        self.particles.force = round(forces);
        Ok(())
    }

    /// The state as the GPU backend reads it back: x = f64(x₃₂) + o.
    pub fn read_state(&self) -> State {
        let n = self.plan.dim;
        let mut positions: Vec<f64> = self.particles.x.iter().map(|&x| f64::from(x)).collect();
        if !self.origin.is_empty() {
            for p in positions.chunks_exact_mut(n) {
                for (x, o) in p.iter_mut().zip(&self.origin) {
                    *x += o;
                }
            }
        }
        State {
            dim: n,
            positions,
            velocities: self.particles.v.iter().map(|&v| f64::from(v)).collect(),
        }
    }

    /// The step report's residuals as the GPU computes them in f32: per
    /// family the largest violation (f64 of the f32 value), then with
    /// particle contact the deepest overlap over the last lists; and the
    /// contacts active in the last substep (λ > 0), plus the pairs the
    /// last Collide found active.
    pub fn residuals(&self) -> (Vec<f64>, usize) {
        let n = self.plan.dim;
        let mut residuals = self
            .plan
            .families
            .iter()
            .zip(&self.families)
            .enumerate()
            .map(|(index, (f, stored))| {
                let plane = self
                    .plan
                    .motion
                    .as_ref()
                    .and_then(|m| m.plane_of(index))
                    .and_then(|k| self.motion_now.planes.get(k));
                if let Some(plane) = plane {
                    let contact = motion::Contact::of(plane, &f.elements, stored);
                    return f64::from(motion::residual(&contact, n, &self.particles.x));
                }
                let stored_family = residual::StoredFamily {
                    rest: &stored.rest,
                    normal: &stored.normal,
                    material: stored.material.as_ref(),
                    mesh: stored.mesh.as_ref(),
                    moving_mesh: (self.plan.motion.as_ref())
                        .and_then(|m| m.mesh_of(index))
                        .and_then(|k| self.motion_now.meshes.get(k)),
                };
                let r = residual::residual(f, n, &self.particles.x, &stored_family);
                f64::from(r)
            })
            .collect::<Vec<f64>>();
        let mut active: usize = self
            .plan
            .families
            .iter()
            .zip(&self.families)
            .filter(|(f, _)| f.kind.is_inequality())
            .map(|(_, stored)| stored.lambda.iter().filter(|&&l| l > 0.0).count())
            .sum();
        if let Some(c) = &self.contacts {
            let x = &self.particles.x;
            let deepest = residual::deepest_overlap(n, x, &c.radius, &c.lists);
            residuals.push(f64::from(deepest));
            active += c.ahead.iter().map(|&a| a as usize).sum::<usize>();
        }
        (residuals, active)
    }

    /// One step (every substep of the plan). On a non-finite value the
    /// state is restored and the first failing kernel named.
    pub fn step(&mut self) -> Result<(), ReferenceError> {
        let (x, v) = (self.particles.x.clone(), self.particles.v.clone());
        // The primal residual's λ and d roll back with the state.
        let carried = primal::save(&self.plan, &self.families);
        for substep in 0..self.plan.substeps {
            self.substep = substep;
            for k in 0..self.plan.substep_kernels.len() {
                let kernel = self.plan.substep_kernels[k];
                if let Err(index) = self.kernel(kernel) {
                    self.particles.x = x;
                    self.particles.v = v;
                    primal::restore(&mut self.families, carried);
                    return Err(ReferenceError::NonFinite {
                        substep,
                        kernel,
                        index,
                    });
                }
            }
        }
        self.step_count += 1;
        Ok(())
    }

    /// One kernel call alone (as `Backend::run_kernel`: kernel-level
    /// comparisons; λ persists between calls, Predict resets it). A
    /// failure is reported as substep 0 and not rolled back.
    pub fn run_kernel(&mut self, kernel: Kernel) -> Result<(), ReferenceError> {
        self.kernel(kernel)
            .map_err(|index| ReferenceError::NonFinite {
                substep: 0,
                kernel,
                index,
            })
    }

    /// One kernel call; the first failing index.
    fn kernel(&mut self, kernel: Kernel) -> Result<(), usize> {
        let moving = |family: usize| {
            let k = self.plan.motion.as_ref()?.plane_of(family)?;
            self.motion_now.planes.get(k)
        };
        let moving_mesh = |family: usize| {
            let k = self.plan.motion.as_ref()?.mesh_of(family)?;
            self.motion_now.meshes.get(k)
        };
        let s = &mut self.particles;
        match kernel {
            Kernel::Motion => {
                let Some(m) = &self.plan.motion else {
                    return Ok(());
                };
                let now = hyperpbd_core::motion::substep_time;
                let (step, dt, h) = (self.step_count, self.plan.dt, self.plan.h);
                let (t0, t1) = (
                    now(step, dt, self.substep, h),
                    now(step, dt, self.substep + 1, h),
                );
                let values = m.substep(self.plan.dim, t0, t1, h);
                self.motion_now = motion::round(&values, &self.origin, self.plan.dim);
                let pins: Vec<usize> = m.pins.iter().map(|p| p.particle).collect();
                motion::place(s, &pins, &self.motion_now);
                Ok(())
            }
            Kernel::Predict => {
                let primal = self.plan.primal_residual;
                if !primal {
                    for f in &mut self.families {
                        f.lambda.fill(0.0);
                    }
                }
                let terms = integrate::Predict {
                    h: self.h,
                    gravity: self.plan.predict.gravity.then_some(&self.gravity[..]),
                    force: self.plan.predict.force,
                };
                let predicted = integrate::predict(s, &terms);
                if primal {
                    for (f, stored) in self.plan.families.iter().zip(&mut self.families) {
                        primal::warm_start(s, &f.elements, &stored.carried);
                        stored.swept = false;
                    }
                }
                predicted
            }
            Kernel::Project { family, color } if self.plan.primal_residual => {
                let f = &self.plan.families[family];
                primal::project(s, (f, color), &mut self.families[family], &mut self.columns)
            }
            Kernel::Project { family, color } => {
                let f = &self.plan.families[family];
                let stored = &mut self.families[family];
                let colour = project::Colour {
                    slots: f.color(color),
                    arity: f.arity,
                    elements: &f.elements,
                    rest: &stored.rest,
                    alpha_tilde: stored.alpha_tilde,
                };
                let lambda = &mut stored.lambda;
                match &f.kind {
                    FamilyKind::Distance => project::distance(s, &colour, lambda, false),
                    FamilyKind::Tether => project::distance(s, &colour, lambda, true),
                    FamilyKind::SimplexMeasure { .. } => {
                        project::measure(s, &colour, lambda, project::Measure::Simplex)
                    }
                    FamilyKind::OrientedMeasure => {
                        project::measure(s, &colour, lambda, project::Measure::Oriented)
                    }
                    FamilyKind::HyperplaneContact { .. } => match moving(family) {
                        Some(plane) => {
                            let contact = motion::Contact {
                                plane,
                                mu: stored.mu,
                                elements: &f.elements,
                                rest: &stored.rest,
                                alpha_tilde: stored.alpha_tilde,
                            };
                            motion::contact(s, &contact, lambda)
                        }
                        None => {
                            let plane = project::Plane {
                                normal: &stored.normal,
                                mu: stored.mu,
                            };
                            project::contact(s, &colour, &plane, lambda)
                        }
                    },
                    FamilyKind::MeshContact { .. } => match &stored.mesh {
                        Some(mesh) => {
                            let placed = (mesh, moving_mesh(family));
                            mesh_contact::project(s, &colour, placed, stored.mu, lambda)
                        }
                        None => Ok(()),
                    },
                    FamilyKind::Expression(kind) => {
                        let colour = kinds::Colour {
                            kind,
                            dim: s.dim,
                            elements: &f.elements,
                            rest: &stored.rest,
                            constants: &stored.constants,
                            alpha_tilde: stored.alpha_tilde,
                            inverse_mass: &s.w,
                            slots: f.color(color),
                        };
                        let (lambda, ws) = (&mut lambda[f.color(color)], &mut self.projection);
                        kinds::project(&colour, &mut s.x[..], lambda, ws)
                    }
                    FamilyKind::Material { .. } => match &stored.material {
                        Some(law) => {
                            project::measure(s, &colour, lambda, project::Measure::Material(law))
                        }
                        None => Ok(()),
                    },
                }
            }
            Kernel::Velocity => integrate::velocity(s, self.h),
            Kernel::Friction { family } => {
                let stored = &self.families[family];
                if let Some(plane) = moving(family) {
                    let elements = &self.plan.families[family].elements;
                    let contact = motion::Contact::of(plane, elements, stored);
                    return motion::friction(s, &contact, self.h, &stored.lambda);
                }
                if let Some(mesh) = &stored.mesh {
                    let f = &self.plan.families[family];
                    let (mu, h) = (stored.mu, self.h);
                    return mesh_contact::friction(
                        s,
                        (f, &stored.rest, mesh, moving_mesh(family)),
                        (mu, h),
                        &stored.lambda,
                    );
                }
                let friction = integrate::Friction {
                    normal: &stored.normal,
                    mu: stored.mu,
                    h: self.h,
                    particles: &self.plan.families[family].elements,
                    lambda: &stored.lambda,
                };
                integrate::friction(s, &friction)
            }
            Kernel::Damping => {
                integrate::damping(s, self.factor);
                Ok(())
            }
            Kernel::Broadphase => {
                if let Some(c) = self.contacts.as_mut() {
                    broadphase::lists(s, &c.pad, &mut c.lists);
                }
                Ok(())
            }
            Kernel::Collide => match self.contacts.as_mut() {
                Some(c) => {
                    let contact = collide::Contact {
                        radius: &c.radius,
                        mu: c.mu,
                        lists: &c.lists,
                    };
                    collide::collide(s, &contact, &mut c.ahead)
                }
                None => Ok(()),
            },
            // Read-only checks (not run here); Minimise is refused in `new`.
            Kernel::GuardMeasure { .. } | Kernel::GuardSpeed | Kernel::Minimise => Ok(()),
        }
    }
}
