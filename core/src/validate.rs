//! `Scene::validate`: every rule a scene must satisfy before it compiles.
//!
//! The first violated rule is reported, in document order, with the path of
//! the offending field. Nothing downstream re-checks what is checked here.

use crate::geometry::Scratch;
use crate::kinds::{self, Arity};
use crate::{MAX_DIM, Obstacle, Scene, SceneError};

fn finite(path: impl FnOnce() -> String, value: f64) -> Result<(), SceneError> {
    if value.is_finite() {
        Ok(())
    } else {
        Err(SceneError::NonFinite {
            path: path(),
            value,
        })
    }
}

pub(crate) fn vector(path: &str, v: &[f64], dim: usize) -> Result<(), SceneError> {
    if v.len() != dim {
        return Err(SceneError::WrongLength {
            path: path.to_string(),
            expected: dim,
            found: v.len(),
        });
    }
    for (a, &x) in v.iter().enumerate() {
        finite(|| format!("{path}[{a}]"), x)?;
    }
    Ok(())
}

fn non_negative(path: impl Fn() -> String, value: f64) -> Result<(), SceneError> {
    finite(&path, value)?;
    if value < 0.0 {
        return Err(SceneError::Negative {
            path: path(),
            value,
        });
    }
    Ok(())
}

fn compliance(path: String, value: f64) -> Result<(), SceneError> {
    finite(|| path.clone(), value)?;
    if value < 0.0 {
        return Err(SceneError::NegativeCompliance { path, value });
    }
    Ok(())
}

impl Scene {
    /// Checks every rule; returns the first violation with its field path.
    pub fn validate(&self) -> Result<(), SceneError> {
        let dim = self.dim;
        if dim == 0 {
            return Err(SceneError::ZeroDimension);
        }
        if dim > MAX_DIM {
            return Err(SceneError::DimensionTooLarge {
                value: dim,
                max: MAX_DIM,
            });
        }
        finite(|| "dt".into(), self.dt)?;
        if self.dt <= 0.0 {
            return Err(SceneError::NonPositiveTimeStep { value: self.dt });
        }
        if self.substeps == 0 {
            return Err(SceneError::ZeroSubsteps);
        }
        if self.iterations == 0 {
            return Err(SceneError::ZeroIterations);
        }
        if let Some(g) = &self.gravity {
            vector("gravity", g, dim)?;
        }
        self.validate_particles()?;
        self.validate_constraints()?;
        self.validate_obstacles()?;
        self.validate_solver()?;
        self.validate_guards()?;
        if let Some(d) = &self.damping {
            non_negative(|| "damping.rate".into(), d.rate)?;
        }
        if let Some(c) = &self.collisions {
            finite(|| "collisions.friction".into(), c.friction)?;
            if c.friction < 0.0 {
                return Err(SceneError::NegativeFriction {
                    path: "collisions.friction".into(),
                    value: c.friction,
                });
            }
            non_negative(|| "collisions.margin".into(), c.margin)?;
        }
        Ok(())
    }

    fn validate_particles(&self) -> Result<(), SceneError> {
        let dim = self.dim;
        let lumped = self.lumped_particles();
        for (i, p) in self.particles.iter().enumerate() {
            let at = |field: &str| format!("particles[{i}].{field}");
            vector(&at("position"), &p.position, dim)?;
            if let Some(v) = &p.velocity {
                vector(&at("velocity"), v, dim)?;
                if p.fixed && v.iter().any(|&x| x != 0.0) {
                    return Err(SceneError::FixedParticleVelocity {
                        path: at("velocity"),
                    });
                }
            }
            if let Some(f) = &p.force {
                vector(&at("force"), f, dim)?;
            }
            match p.mass {
                Some(m) => {
                    finite(|| at("mass"), m)?;
                    if m <= 0.0 {
                        return Err(SceneError::NonPositiveMass {
                            path: at("mass"),
                            value: m,
                        });
                    }
                }
                None if !p.fixed && !lumped[i] => {
                    return Err(SceneError::MissingMass { path: at("mass") });
                }
                None => {}
            }
            non_negative(|| at("radius"), p.radius)?;
            finite(|| at("gravity_scale"), p.gravity_scale)?;
            if !p.motion.is_empty() && !p.fixed {
                return Err(SceneError::Inconsistent {
                    path: at("motion"),
                    why: "only a fixed particle (\"fixed\": true) follows a prescribed motion; \
                          a dynamic particle moves by the solver"
                        .into(),
                });
            }
            self.validate_motion(&at("motion"), &p.motion)?;
        }
        Ok(())
    }

    fn validate_constraints(&self) -> Result<(), SceneError> {
        let dim = self.dim;
        let count = self.particles.len();
        let mut scratch = Scratch::new();
        let mut columns = crate::expr::Columns::new();
        let mut points = Vec::new();
        let mut grad = Vec::new();
        for (f, family) in self.constraints.iter().enumerate() {
            let at = |field: &str| format!("constraints[{f}].{field}");
            self.validate_family_keys(f, family)?;
            compliance(at("compliance"), family.compliance)?;
            let kind = family.kind.as_str();
            let first_arity = family.elements.first().map_or(0, Vec::len);
            for (e, element) in family.elements.iter().enumerate() {
                let path = format!("constraints[{f}].elements[{e}]");
                let arity_error = |expected: String| SceneError::WrongArity {
                    path: path.clone(),
                    kind,
                    expected,
                    found: element.len(),
                };
                match kinds::arity(family.kind) {
                    Arity::Exactly(n) if element.len() != n => {
                        return Err(arity_error(n.to_string()));
                    }
                    Arity::Full if element.len() != dim + 1 => {
                        return Err(arity_error(format!("{} (dim + 1)", dim + 1)));
                    }
                    Arity::Simplex if !(2..=dim + 1).contains(&element.len()) => {
                        return Err(arity_error(format!(
                            "k + 1 with 1 <= k <= {dim} (2..={})",
                            dim + 1
                        )));
                    }
                    Arity::Family if element.is_empty() => {
                        return Err(arity_error("at least 1".into()));
                    }
                    Arity::Simplex if element.len() != first_arity => {
                        return Err(arity_error(format!(
                            "{first_arity} (one k per family, as in elements[0])"
                        )));
                    }
                    Arity::Family if element.len() != first_arity => {
                        return Err(arity_error(format!(
                            "{first_arity} (one arity per family, as in elements[0])"
                        )));
                    }
                    Arity::Exactly(_) | Arity::Full | Arity::Simplex | Arity::Family => {}
                }
                for (j, &index) in element.iter().enumerate() {
                    if index >= count {
                        return Err(SceneError::IndexOutOfRange {
                            path: format!("{path}[{j}]"),
                            index,
                            count,
                        });
                    }
                    if element[..j].contains(&index) {
                        return Err(SceneError::RepeatedParticle {
                            path: format!("{path}[{j}]"),
                            particle: index,
                        });
                    }
                }
            }
            if let Some(why) = kinds::dimension_problem(family.kind, dim) {
                return Err(SceneError::Inconsistent {
                    path: at("type"),
                    why,
                });
            }
            // An empty family still has its expression checked (any
            // particle index is then in range).
            let arity = match first_arity {
                0 => crate::expr::limits::MAX_ARITY,
                arity => arity,
            };
            let expression =
                kinds::expression_of(f, family, arity, dim, |i| &self.particles[i].position)?;
            if family.kind.law().is_some() {
                self.validate_material(f, family)?;
            } else if let Some(rest) = &family.rest {
                if rest.len() != family.elements.len() {
                    return Err(SceneError::RestCountMismatch {
                        path: at("rest"),
                        expected: family.elements.len(),
                        found: rest.len(),
                    });
                }
                for (e, &r) in rest.iter().enumerate() {
                    let path = format!("constraints[{f}].rest[{e}]");
                    finite(|| path.clone(), r)?;
                    if let Some(why) = kinds::rest_problem(family, r) {
                        return Err(SceneError::DegenerateRest {
                            path,
                            why: why.into(),
                        });
                    }
                }
            } else {
                for (e, element) in family.elements.iter().enumerate() {
                    points.clear();
                    for &i in element {
                        points.extend_from_slice(&self.particles[i].position);
                    }
                    grad.resize(points.len(), 0.0);
                    let value = match &expression {
                        Some(expression) => expression.value_at(e, &points, &mut columns),
                        None => kinds::value(family.kind, &points, dim, &mut grad, &mut scratch),
                    };
                    let path = || format!("constraints[{f}].elements[{e}]");
                    if !value.is_finite() {
                        return Err(SceneError::DegenerateRest {
                            path: path(),
                            why: format!(
                                "the authored geometry gives the rest value {value}: the \
                                 coordinates are too large for {kind}"
                            ),
                        });
                    }
                    if let Some(why) = kinds::authored_problem(family.kind, &points, dim, value) {
                        return Err(SceneError::DegenerateRest { path: path(), why });
                    }
                }
            }
        }
        Ok(())
    }

    fn validate_obstacles(&self) -> Result<(), SceneError> {
        for (o, obstacle) in self.obstacles.iter().enumerate() {
            let at = |field: &str| format!("obstacles[{o}].{field}");
            // The shape first, then what every kind has: μ finite and
            // ≥ 0, the motion valid.
            match obstacle {
                Obstacle::Hyperplane {
                    normal,
                    offset,
                    compliance: alpha,
                    ..
                } => {
                    vector(&at("normal"), normal, self.dim)?;
                    if normal.iter().all(|&x| x == 0.0) {
                        return Err(SceneError::ZeroNormal { path: at("normal") });
                    }
                    finite(|| at("offset"), *offset)?;
                    compliance(at("compliance"), *alpha)?;
                }
                Obstacle::SimplexMesh {
                    vertices,
                    simplices,
                    ..
                } => {
                    for (v, vertex) in vertices.iter().enumerate() {
                        vector(&at(&format!("vertices[{v}]")), vertex, self.dim)?;
                    }
                    crate::validate_solver::validate_simplex_mesh(o, vertices, simplices)?;
                }
            }
            let friction = obstacle.friction();
            finite(|| at("friction"), friction)?;
            if friction < 0.0 {
                return Err(SceneError::NegativeFriction {
                    path: at("friction"),
                    value: friction,
                });
            }
            self.validate_motion(&at("motion"), obstacle.motion())?;
        }
        Ok(())
    }
}
