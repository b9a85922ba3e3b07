//! The Plan: a validated scene compiled into the stages it calls for.
//!
//! ```text
//! per step, substeps × {
//!   Motion                       moving planes, meshes and pins at the substep's
//!                                end time (only with a `motion`; motion.rs)
//!   Predict                      v += h (s g + w f); p = x; x += h v; λ = 0
//!                                (gravity / force terms only if authored)
//!   iterations × for family in order, for color in family:
//!     Project(family, color)     one XPBD update per element of the color
//!   Velocity                     v = (x − p) / h
//!   (with `collisions`: Broadphase after Predict, and one Collide — a
//!    gather-Jacobi sweep over the candidate pairs — at the start of every
//!    iteration; see hyperpbd-cpu's collide.rs)
//!   Friction(family)             per hyperplane or simplex mesh with μ > 0
//!   Damping                      v *= exp(−rate h), if rate > 0
//!   GuardMeasure(family), GuardSpeed   read-only checks (with `guards`)
//! }
//! ```
//! Constraint families are projected in authored order, then each
//! obstacle (hyperplane or simplex mesh) as one contact family (every
//! dynamic particle, one color). A stage the scene does not use is absent: it costs nothing.
//! Both backends execute [`Plan::substep_kernels`], so they run the same
//! algorithm in the same order.

use crate::IncrementalPotentialPlan;
use crate::coloring::greedy_colors;
use crate::expr::Columns;
use crate::geometry::{Scratch, unit_vector};
use crate::guard_rules::{Adaptive, Guards, guarded_families};
use crate::kinds;
use crate::material_plan::{self, FamilyMass};
use crate::motion::{MotionPlan, MovingMesh, MovingPlane, Pin};
use crate::{Family, FamilyKind, Obstacle, Scene, SceneError, Solver, StageName, XpbdSettings};

/// Which terms prediction includes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PredictTerms {
    /// s_i g (scene gravity nonzero and some dynamic particle with s ≠ 0).
    pub gravity: bool,
    /// w_i f_i (some dynamic particle with a nonzero force).
    pub force: bool,
}

/// One call of one kernel; a step is `substeps` repetitions of
/// [`Plan::substep_kernels`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kernel {
    /// Prescribed motion (`motion.rs`): the moving hyperplanes and the
    /// animated pins placed at the substep's end time; first kernel of
    /// the substep, only when the scene has a `motion`.
    Motion,
    /// Prediction, saving p = x and resetting every multiplier.
    Predict,
    /// XPBD update of every element of one color of one family.
    Project {
        /// Family index in [`Plan::families`].
        family: usize,
        /// Color index within the family.
        color: usize,
    },
    /// v = (x − p) / h.
    Velocity,
    /// Dynamic Coulomb friction of one hyperplane contact family.
    Friction {
        /// Family index in [`Plan::families`].
        family: usize,
    },
    /// v *= exp(−rate h).
    Damping,
    /// Candidate particle pairs from boxes swept from p to x (radius +
    /// margin), and each particle's sorted contact list.
    Broadphase,
    /// One gather-Jacobi iteration of particle–particle contact.
    Collide,
    /// One incremental-potential minimisation (barrier path): the whole
    /// substep, x~ = x + h v, Newton under the filter, v = (x − x_prev)/h.
    Minimise,
    /// Orientation / measure-ratio guards over one family (read-only).
    GuardMeasure {
        /// Family index in [`Plan::families`].
        family: usize,
    },
    /// Speed guard over the dynamic particles (read-only).
    GuardSpeed,
}

impl Kernel {
    /// The stage this kernel belongs to.
    pub fn stage(self) -> StageName {
        match self {
            Kernel::Motion => StageName::Motion,
            Kernel::Predict => StageName::Predict,
            Kernel::Project { .. } => StageName::Project,
            Kernel::Velocity => StageName::Velocity,
            Kernel::Friction { .. } => StageName::Friction,
            Kernel::Damping => StageName::Damping,
            Kernel::Broadphase => StageName::Broadphase,
            Kernel::Collide => StageName::Project,
            Kernel::Minimise => StageName::Minimise,
            Kernel::GuardMeasure { .. } | Kernel::GuardSpeed => StageName::Guard,
        }
    }
}

/// Particle–particle contact settings of a plan (from `collisions`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ParticleContacts {
    /// Coulomb coefficient μ between particles.
    pub friction: f64,
    /// Broadphase box margin.
    pub margin: f64,
}

/// The compiled scene.
#[derive(Debug, Clone, PartialEq)]
pub struct Plan {
    /// Dimension N.
    pub dim: usize,
    /// Step length.
    pub dt: f64,
    /// Substeps per step.
    pub substeps: u32,
    /// Projection iterations per substep.
    pub iterations: u32,
    /// Substep length h = dt / substeps.
    pub h: f64,
    /// Gravity (zeros when absent).
    pub gravity: Vec<f64>,
    /// Prediction terms in use.
    pub predict: PredictTerms,
    /// Inverse mass per particle; 0 for fixed particles. A particle
    /// without an authored `mass` has the lumped mass of the material
    /// families with `density` it belongs to.
    pub inverse_mass: Vec<f64>,
    /// The lumped mass of every family with `density` (element and vertex
    /// totals), in authored order.
    pub lumped_mass: Vec<FamilyMass>,
    /// Gravity scale per particle.
    pub gravity_scale: Vec<f64>,
    /// Radius per particle.
    pub radius: Vec<f64>,
    /// External force per particle, flat.
    pub force: Vec<f64>,
    /// Families in projection order.
    pub families: Vec<Family>,
    /// Damping rate (1/s) and the per-substep factor exp(−rate h), when used.
    pub damping: Option<(f64, f64)>,
    /// Particle–particle contact, when the scene has `collisions` and a
    /// dynamic particle.
    pub contacts: Option<ParticleContacts>,
    /// Stages run in each substep, in order.
    pub stages: Vec<StageName>,
    /// Kernel calls of one substep, in order.
    pub substep_kernels: Vec<Kernel>,
    /// Which solver the substeps run, with that solver's own data.
    pub solver: SolverPlan,
    /// XPBD's update carries the primal residual (`primal_residual`): the
    /// projections keep each element's displacement (`cpu/src/consistent.rs`).
    pub primal_residual: bool,
    /// The checks of every completed substep, when the scene has `guards`.
    pub guards: Option<Guards>,
    /// The retry policy of a guard-rejected step.
    pub adaptive: Option<Adaptive>,
    /// Prescribed motions (`None`: the scene has none; nothing evaluates).
    pub motion: Option<MotionPlan>,
    /// Per authored obstacle, the contact family that projects it on the
    /// XPBD path (`None` on the barrier path, whose obstacles live in its
    /// own plan, and for a plane with no dynamic particle to touch): where
    /// contact forces are credited.
    pub obstacle_families: Vec<Option<usize>>,
    /// The simplex meshes of the XPBD path's mesh contact families
    /// (`FamilyKind::MeshContact::mesh` indexes here), each with its
    /// hierarchy; empty on the barrier path and without meshes.
    pub meshes: Vec<std::sync::Arc<crate::barrier::BarrierObstacles>>,
}

/// The solver a plan's substeps run: one variant per solver path.
///
/// XPBD's stages live in [`Plan::families`], [`Plan::damping`] and
/// [`Plan::contacts`] (all empty on the barrier path, whose validation
/// refuses constraints, friction, damping and collisions); the barrier path
/// carries its settings and obstacles here.
#[derive(Debug, Clone, PartialEq)]
pub enum SolverPlan {
    /// Substepped XPBD: predict, project by colour, velocity, responses.
    Xpbd,
    /// One incremental-potential minimisation per substep (boxed: its
    /// obstacles carry the mesh hierarchy).
    IncrementalPotential(Box<IncrementalPotentialPlan>),
}

impl Plan {
    /// Validates `scene` and compiles it.
    pub fn compile(scene: &Scene) -> Result<Plan, SceneError> {
        scene.validate()?;
        let dim = scene.dim;
        let n = scene.particles.len();
        let h = scene.dt / f64::from(scene.substeps);
        let materials = material_plan::compile(scene)?;
        let inverse_mass: Vec<f64> = scene
            .particles
            .iter()
            .zip(&materials.lumped)
            .map(|(p, &lumped)| material_plan::effective_mass(p, lumped).map_or(0.0, |m| 1.0 / m))
            .collect();
        let dynamic = |i: usize| inverse_mass[i] > 0.0;
        let gravity = scene.gravity.clone().unwrap_or_else(|| vec![0.0; dim]);
        let gravity_scale: Vec<f64> = scene.particles.iter().map(|p| p.gravity_scale).collect();
        let mut force = vec![0.0; n * dim];
        for (i, p) in scene.particles.iter().enumerate() {
            if let Some(f) = &p.force {
                force[i * dim..(i + 1) * dim].copy_from_slice(f);
            }
        }
        let predict = PredictTerms {
            gravity: gravity.iter().any(|&g| g != 0.0)
                && (0..n).any(|i| dynamic(i) && gravity_scale[i] != 0.0),
            force: (0..n)
                .any(|i| dynamic(i) && force[i * dim..(i + 1) * dim].iter().any(|&f| f != 0.0)),
        };
        let radius: Vec<f64> = scene.particles.iter().map(|p| p.radius).collect();

        let mut families = Vec::new();
        let mut moving = MotionPlan::default();
        for (i, p) in scene.particles.iter().enumerate() {
            if !p.motion.is_empty() {
                moving.pins.push(Pin {
                    particle: i,
                    position: p.position.clone(),
                    motion: p.motion.clone(),
                });
            }
        }
        let mut scratch = Scratch::new();
        let mut columns = Columns::new();
        for (f, authored) in scene.constraints.iter().enumerate() {
            if authored.elements.is_empty() {
                continue;
            }
            let arity = authored.elements[0].len();
            let material = materials.shapes[f].as_ref().map(|(material, _)| *material);
            let expression =
                kinds::expression_of(f, authored, arity, dim, |i| &scene.particles[i].position)?;
            let kind = kinds::family_kind(authored.kind, arity, material, expression);
            let flat: Vec<usize> = authored.elements.iter().flatten().copied().collect();
            let rest: Vec<f64> = match &authored.rest {
                Some(rest) => rest.clone(),
                None => {
                    let mut points = vec![0.0; arity * dim];
                    let mut grad = vec![0.0; arity * dim];
                    flat.chunks_exact(arity)
                        .enumerate()
                        .map(|(e, element)| {
                            for (j, &i) in element.iter().enumerate() {
                                points[j * dim..(j + 1) * dim]
                                    .copy_from_slice(&scene.particles[i].position);
                            }
                            match kind.expression() {
                                Some(kind) => kind.default_rest(e, &points, &mut columns),
                                None => kinds::value(
                                    authored.kind,
                                    &points,
                                    dim,
                                    &mut grad,
                                    &mut scratch,
                                ),
                            }
                        })
                        .collect()
                }
            };
            // Material families: compliance 1 (α = 1 of C = √(2W)).
            let compliance = if materials.shapes[f].is_some() {
                1.0
            } else {
                authored.compliance
            };
            let mut family = colored_family(
                format!("constraints[{f}]"),
                kind,
                compliance,
                arity,
                &flat,
                &rest,
                &inverse_mass,
            );
            // Per-element constants follow their elements into colour order.
            if let FamilyKind::Expression(kind) = &family.kind
                && kind.element_constants > 0
            {
                let reordered = kind.reordered(&family.source);
                family.kind = FamilyKind::Expression(std::sync::Arc::new(reordered));
            }
            families.push(match &materials.shapes[f] {
                Some((_, shapes)) => material_plan::with_rest_shapes(family, shapes),
                None => family,
            });
        }
        let solver = match &scene.solver {
            Solver::Xpbd(_) => SolverPlan::Xpbd,
            Solver::IncrementalPotential(settings) => SolverPlan::IncrementalPotential(Box::new(
                IncrementalPotentialPlan::compile(scene, settings),
            )),
        };
        // XPBD projects each hyperplane as a contact family; the barrier
        // path keeps its obstacles in its own plan.
        let xpbd_planes = match solver {
            SolverPlan::Xpbd => scene.obstacles.as_slice(),
            SolverPlan::IncrementalPotential(_) => &[],
        };
        let mut obstacle_families = vec![None; scene.obstacles.len()];
        let mut meshes = Vec::new();
        for (o, obstacle) in xpbd_planes.iter().enumerate() {
            let particles: Vec<usize> = (0..n).filter(|&i| dynamic(i)).collect();
            if particles.is_empty() {
                continue;
            }
            let (normal, offset, friction, compliance, motion) = match obstacle {
                Obstacle::Hyperplane {
                    normal,
                    offset,
                    friction,
                    compliance,
                    motion,
                } => (normal, offset, friction, compliance, motion),
                Obstacle::SimplexMesh {
                    vertices,
                    simplices,
                    friction,
                    motion,
                } => {
                    // kinds/mesh_contact.rs: C = dist(x, mesh) − radius.
                    let mesh = crate::barrier::BarrierObstacles::mesh(dim, o, vertices, simplices);
                    let rest: Vec<f64> = particles.iter().map(|&i| radius[i]).collect();
                    if !motion.is_empty() {
                        let mut bounds = [vec![f64::INFINITY; dim], vec![f64::NEG_INFINITY; dim]];
                        for v in vertices {
                            for (a, &c) in v.iter().enumerate() {
                                bounds[0][a] = bounds[0][a].min(c);
                                bounds[1][a] = bounds[1][a].max(c);
                            }
                        }
                        moving.meshes.push(MovingMesh {
                            family: families.len(),
                            obstacle: o,
                            motion: motion.clone(),
                            bounds,
                            smallest_radius: rest.iter().copied().fold(f64::INFINITY, f64::min),
                        });
                    }
                    obstacle_families[o] = Some(families.len());
                    families.push(colored_family(
                        format!("obstacles[{o}]"),
                        FamilyKind::MeshContact {
                            mesh: meshes.len(),
                            friction: *friction,
                        },
                        0.0,
                        1,
                        &particles,
                        &rest,
                        &inverse_mass,
                    ));
                    meshes.push(std::sync::Arc::new(mesh));
                    continue;
                }
            };
            let unit = unit_vector(normal);
            let rest: Vec<f64> = particles.iter().map(|&i| offset + radius[i]).collect();
            if !motion.is_empty() {
                moving.planes.push(MovingPlane {
                    family: families.len(),
                    normal: unit.clone(),
                    motion: motion.clone(),
                });
            }
            obstacle_families[o] = Some(families.len());
            families.push(colored_family(
                format!("obstacles[{o}]"),
                FamilyKind::HyperplaneContact {
                    normal: unit,
                    friction: *friction,
                },
                *compliance,
                1,
                &particles,
                &rest,
                &inverse_mass,
            ));
        }

        let any_dynamic = (0..n).any(dynamic);
        let damping = scene
            .damping
            .as_ref()
            .filter(|d| d.rate > 0.0)
            .map(|d| (d.rate, libm::exp(-d.rate * h)));
        let contacts =
            scene
                .collisions
                .as_ref()
                .filter(|_| any_dynamic)
                .map(|c| ParticleContacts {
                    friction: c.friction,
                    margin: c.margin,
                });
        let motion = (!moving.is_empty()).then_some(moving);
        let mut substep_kernels = Vec::new();
        if motion.is_some() {
            substep_kernels.push(Kernel::Motion);
        }
        if !any_dynamic {
            // Nothing moves: no kernel runs.
        } else if let SolverPlan::IncrementalPotential(_) = solver {
            substep_kernels.push(Kernel::Minimise);
        } else {
            substep_kernels.push(Kernel::Predict);
            if contacts.is_some() {
                substep_kernels.push(Kernel::Broadphase);
            }
            for _ in 0..scene.iterations {
                if contacts.is_some() {
                    substep_kernels.push(Kernel::Collide);
                }
                for (family, fam) in families.iter().enumerate() {
                    for color in 0..fam.color_count() {
                        substep_kernels.push(Kernel::Project { family, color });
                    }
                }
            }
            substep_kernels.push(Kernel::Velocity);
            for (family, fam) in families.iter().enumerate() {
                if fam.kind.contact_friction() > 0.0 {
                    substep_kernels.push(Kernel::Friction { family });
                }
            }
            if damping.is_some() {
                substep_kernels.push(Kernel::Damping);
            }
        }
        if any_dynamic && let Some(guards) = &scene.guards {
            for family in guarded_families(&families, guards) {
                substep_kernels.push(Kernel::GuardMeasure { family });
            }
            if guards.max_speed.is_some() {
                substep_kernels.push(Kernel::GuardSpeed);
            }
        }
        let mut stages: Vec<StageName> = Vec::new();
        for k in &substep_kernels {
            if stages.last() != Some(&k.stage()) {
                stages.push(k.stage());
            }
        }
        Ok(Plan {
            dim,
            dt: scene.dt,
            substeps: scene.substeps,
            iterations: scene.iterations,
            h,
            gravity,
            predict,
            inverse_mass,
            lumped_mass: materials.report,
            gravity_scale,
            radius,
            force,
            families,
            damping,
            contacts,
            stages,
            substep_kernels,
            primal_residual: matches!(
                scene.solver,
                Solver::Xpbd(XpbdSettings {
                    primal_residual: true
                })
            ),
            solver,
            guards: scene.guards.clone(),
            adaptive: scene.adaptive,
            motion,
            obstacle_families,
            meshes,
        })
    }

    /// This plan with 2^`subdivision` times the substeps over the same dt
    /// (an adaptive retry): h and the damping factor follow as
    /// [`Plan::compile`] computes them; nothing else depends on h.
    pub fn subdivided(&self, subdivision: u32) -> Plan {
        let substeps = self.substeps << subdivision;
        let h = self.dt / f64::from(substeps);
        Plan {
            substeps,
            h,
            damping: self.damping.map(|(rate, _)| (rate, libm::exp(-rate * h))),
            ..self.clone()
        }
    }

    /// Number of particles.
    pub fn particle_count(&self) -> usize {
        self.inverse_mass.len()
    }

    /// Kernel calls per step for each stage, in stage order.
    pub fn kernel_counts(&self) -> Vec<(StageName, u64)> {
        self.stages
            .iter()
            .map(|&s| {
                let per_substep = self
                    .substep_kernels
                    .iter()
                    .filter(|k| k.stage() == s)
                    .count();
                (s, per_substep as u64 * u64::from(self.substeps))
            })
            .collect()
    }

    /// Constraint projections (element updates) per step.
    pub fn projections_per_step(&self) -> u64 {
        let per_iteration: u64 = self.families.iter().map(|f| f.len() as u64).sum();
        per_iteration * u64::from(self.iterations) * u64::from(self.substeps)
    }

    /// The barrier path's settings and obstacles (`None` on the XPBD path).
    pub fn incremental_potential(&self) -> Option<&IncrementalPotentialPlan> {
        match &self.solver {
            SolverPlan::IncrementalPotential(ip) => Some(&**ip),
            SolverPlan::Xpbd => None,
        }
    }
}

fn colored_family(
    label: String,
    kind: FamilyKind,
    compliance: f64,
    arity: usize,
    flat: &[usize],
    rest: &[f64],
    inverse_mass: &[f64],
) -> Family {
    let colors = greedy_colors(flat, arity, inverse_mass);
    let color_count = colors.iter().max().map_or(0, |&c| c as usize + 1);
    let mut order: Vec<usize> = (0..colors.len()).collect();
    order.sort_by_key(|&e| (colors[e], e));
    let mut color_starts = vec![0; color_count + 1];
    for &c in &colors {
        color_starts[c as usize + 1] += 1;
    }
    for c in 0..color_count {
        color_starts[c + 1] += color_starts[c];
    }
    Family {
        label,
        kind,
        compliance,
        arity,
        elements: order
            .iter()
            .flat_map(|&e| flat[e * arity..(e + 1) * arity].iter().map(|&i| i as u32))
            .collect(),
        rest: order.iter().map(|&e| rest[e]).collect(),
        source: order.iter().map(|&e| e as u32).collect(),
        color_starts,
    }
}
