//! Typed errors: what was wrong, where, and why.
//!
//! Every scene error carries the path of the offending field in the same
//! notation as the JSON document (`particles[3].position[1]`), so a message
//! from the builder API and one from a loaded file read the same way.

use thiserror::Error;

/// A scene that cannot be simulated, with the field that makes it so.
#[derive(Debug, Clone, PartialEq, Error)]
#[non_exhaustive]
pub enum SceneError {
    /// The file could not be read.
    #[error("cannot read scene file {file}: {message}")]
    Io { file: String, message: String },
    /// The document is not valid JSON or does not fit the schema (unknown
    /// key, wrong type, missing key).
    #[error("{path}: {message}")]
    Json { path: String, message: String },
    /// `dim` is 0.
    #[error("dim: the dimension must be at least 1")]
    ZeroDimension,
    /// `dim` above [`crate::MAX_DIM`].
    #[error("dim: {value} is above the supported maximum of {max}")]
    DimensionTooLarge { value: usize, max: usize },
    /// NaN or ±Inf where a finite number is required.
    #[error("{path}: value {value} is not finite")]
    NonFinite { path: String, value: f64 },
    /// A vector whose length is not the scene dimension.
    #[error("{path}: expected {expected} components (the scene dimension), found {found}")]
    WrongLength {
        path: String,
        expected: usize,
        found: usize,
    },
    /// `dt <= 0`.
    #[error("dt: the time step must be > 0, got {value}")]
    NonPositiveTimeStep { value: f64 },
    /// `substeps == 0`.
    #[error("substeps: must be at least 1")]
    ZeroSubsteps,
    /// `iterations == 0`.
    #[error("iterations: must be at least 1")]
    ZeroIterations,
    /// A dynamic particle with mass ≤ 0, or a particle with neither mass nor
    /// `fixed`.
    #[error(
        "{path}: mass must be > 0, got {value} (use \"fixed\": true for an immovable particle)"
    )]
    NonPositiveMass { path: String, value: f64 },
    /// A dynamic particle with no mass at all.
    #[error("{path}: missing mass (give \"mass\" > 0, or \"fixed\": true)")]
    MissingMass { path: String },
    /// A fixed particle authored with a nonzero velocity: fixed particles do
    /// not move, so the velocity would be silently ignored.
    #[error("{path}: a fixed particle does not move; its velocity must be zero or omitted")]
    FixedParticleVelocity { path: String },
    /// A negative value where only values ≥ 0 make sense (radius, damping
    /// rate).
    #[error("{path}: must be >= 0, got {value}")]
    Negative { path: String, value: f64 },
    /// Compliance (inverse stiffness) below zero.
    #[error("{path}: compliance must be >= 0, got {value}")]
    NegativeCompliance { path: String, value: f64 },
    /// Coulomb friction coefficient below zero.
    #[error("{path}: friction coefficient must be >= 0, got {value}")]
    NegativeFriction { path: String, value: f64 },
    /// A hyperplane normal of zero length.
    #[error("{path}: the hyperplane normal has zero length")]
    ZeroNormal { path: String },
    /// A particle index that names no particle.
    #[error("{path}: particle index {index} is out of range ({count} particles)")]
    IndexOutOfRange {
        path: String,
        index: usize,
        count: usize,
    },
    /// The same particle twice in one element.
    #[error("{path}: particle {particle} appears twice in one element")]
    RepeatedParticle { path: String, particle: usize },
    /// An element with the wrong number of particles for its kind.
    #[error("{path}: {kind} elements need {expected} particles, found {found}")]
    WrongArity {
        path: String,
        kind: &'static str,
        expected: String,
        found: usize,
    },
    /// `rest` given with a different count than `elements`.
    #[error("{path}: {found} rest values for {expected} elements")]
    RestCountMismatch {
        path: String,
        expected: usize,
        found: usize,
    },
    /// Rest geometry of an element that gives the constraint no meaning
    /// (an oriented simplex of zero volume, a negative rest length).
    #[error("{path}: degenerate rest geometry: {why}")]
    DegenerateRest { path: String, why: String },
    /// A value that must be strictly positive (barrier stiffness,
    /// activation distance, convergence tolerance, iteration budget).
    #[error("{path}: must be > 0, got {value}")]
    NonPositive { path: String, value: f64 },
    /// Something the chosen solver path cannot represent (a simplex mesh
    /// under XPBD; constraints, friction, compliance or damping under the
    /// incremental-potential path).
    #[error("{path}: not supported by the {solver} solver: {why}")]
    UnsupportedBySolver {
        path: String,
        solver: &'static str,
        why: String,
    },
    /// A mesh simplex with the wrong number of vertices.
    #[error("{path}: a simplex_mesh simplex needs {expected} vertices, found {found}")]
    WrongSimplexArity {
        path: String,
        expected: String,
        found: usize,
    },
    /// A simplex-mesh vertex index that names no vertex.
    #[error("{path}: vertex index {index} is out of range ({count} vertices)")]
    VertexOutOfRange {
        path: String,
        index: usize,
        count: usize,
    },
    /// A mesh simplex that spans less than its order (repeated or
    /// affinely dependent vertices).
    #[error("{path}: degenerate simplex: {why}")]
    DegenerateSimplex { path: String, why: String },
    /// A key the family's kind does not use (a compliance or rest values
    /// on a material family, material parameters on a geometric one).
    #[error("{path}: not used by {kind} families: {why}")]
    FieldNotForKind {
        path: String,
        kind: &'static str,
        why: String,
    },
    /// A key the family's kind requires.
    #[error("{path}: {kind} families need this key")]
    MissingField { path: String, kind: &'static str },
    /// Material parameters that define no material (E, ν, density).
    #[error("{path}: {source}")]
    Material {
        path: String,
        source: crate::material::MaterialError,
    },
    /// An expression that does not compile, with where in it.
    #[error("{path}: {source}")]
    Expression {
        path: String,
        source: Box<crate::expr::ExprError>,
    },
    /// `rest_positions` with a count other than one per scene particle.
    #[error("{path}: {found} rest positions for {expected} particles (one per scene particle)")]
    RestPositionsCount {
        path: String,
        expected: usize,
        found: usize,
    },
    /// A value outside its admissible interval.
    #[error("{path}: must be in {range}, got {value}")]
    OutOfRange {
        path: String,
        value: f64,
        range: &'static str,
    },
    /// A setting that makes no sense with the rest of the scene.
    #[error("{path}: {why}")]
    Inconsistent { path: String, why: String },
    /// A free particle that starts at d <= 0 from a barrier obstacle.
    #[error(
        "{path}: starts at distance {distance:e} <= 0 from obstacles[{obstacle}]; the barrier path needs every free particle strictly outside every obstacle"
    )]
    BarrierInfeasible {
        path: String,
        obstacle: usize,
        distance: f64,
    },
}

/// Where in a step something failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
#[non_exhaustive]
pub enum StageName {
    /// Prescribed motion: moving obstacles and pins placed (`motion.rs`).
    Motion,
    /// Prediction: v += h (s g + w f); x += h v.
    Predict,
    /// Constraint projection (families and contacts).
    Project,
    /// Velocity reconstruction v = (x − p) / h.
    Velocity,
    /// Dynamic Coulomb friction (velocity response).
    Friction,
    /// Exponential damping (velocity response).
    Damping,
    /// Candidate particle pairs from swept boxes (particle–particle contact).
    Broadphase,
    /// Incremental-potential minimisation (barrier path).
    Minimise,
    /// Read-only guards at the end of a substep.
    Guard,
}

impl StageName {
    /// Lower-case name as printed by the CLI and used in JSON reports.
    pub fn as_str(self) -> &'static str {
        match self {
            StageName::Motion => "motion",
            StageName::Predict => "predict",
            StageName::Project => "project",
            StageName::Velocity => "velocity",
            StageName::Friction => "friction",
            StageName::Damping => "damping",
            StageName::Broadphase => "broadphase",
            StageName::Minimise => "minimise",
            StageName::Guard => "guard",
        }
    }
}

impl std::fmt::Display for StageName {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}

/// A step that could not complete. The backend's state is restored to the
/// start of the step, byte for byte, before this is returned.
#[derive(Debug, Clone, PartialEq, Error)]
#[non_exhaustive]
pub enum StepError {
    /// A particle's position or velocity became NaN/Inf.
    #[error(
        "step aborted in stage {stage}, substep {substep}: particle {particle} became non-finite; state rolled back"
    )]
    NonFiniteParticle {
        stage: StageName,
        substep: u32,
        particle: usize,
    },
    /// A constraint produced a non-finite multiplier update.
    #[error(
        "step aborted in stage {stage}, substep {substep}: {family_label} element {element} produced a non-finite correction; state rolled back"
    )]
    NonFiniteConstraint {
        stage: StageName,
        substep: u32,
        /// Index of the family in the plan.
        family: usize,
        /// Human-readable family name (`constraints[2]`, `obstacles[0]`).
        family_label: String,
        /// Element index in the authored order.
        element: usize,
    },
    /// A material element left its law's domain (a Neo-Hookean element
    /// collapsed or inverted).
    #[error(
        "step aborted in stage {stage}, substep {substep}: {family_label} element {element}: {refusal}; state rolled back"
    )]
    MaterialRefused {
        stage: StageName,
        substep: u32,
        /// Index of the family in the plan.
        family: usize,
        /// Human-readable family name (`constraints[2]`).
        family_label: String,
        /// Element index in the authored order.
        element: usize,
        /// Which refusal, with the element's measure ratio J.
        refusal: crate::material::LawRefusal,
    },
    /// The incremental-potential minimisation was refused.
    #[error("step aborted in substep {substep}: minimisation refused: {reason}; state rolled back")]
    MinimisationRefused {
        substep: u32,
        reason: crate::Refusal,
        /// The full report (criterion, residuals, iterations).
        report: Box<crate::MinimisationReport>,
    },
    /// A guard rejected a completed substep (`guards` in the scene).
    #[error("step rejected: {0}; state rolled back")]
    GuardRejected(crate::guard_rules::GuardRejection),
}

impl StepError {
    /// The error of a minimisation in `substep` that `report` says was
    /// refused; `None` when the minimiser accepted its result. Both
    /// backends turn a refusal into this one error.
    pub fn refused(substep: u32, report: &crate::MinimisationReport) -> Option<StepError> {
        match &report.status {
            crate::MinimisationStatus::Refused(reason) => Some(StepError::MinimisationRefused {
                substep,
                reason: reason.clone(),
                report: Box::new(report.clone()),
            }),
            _ => None,
        }
    }
}

/// Errors of the GPU device layer. There is never a silent fallback to the
/// CPU: asking for the GPU and not getting it is an error.
#[derive(Debug, Clone, PartialEq, Error)]
#[non_exhaustive]
pub enum GpuError {
    /// No adapter matched the request.
    #[error("no GPU adapter found{detail}")]
    NoAdapter { detail: String },
    /// The adapter lacks a feature the request needs (e.g. `SHADER_F64`).
    #[error("adapter {adapter} lacks the required feature {feature}")]
    MissingFeature { adapter: String, feature: String },
    /// Device creation failed.
    #[error("could not create a device on {adapter}: {message}")]
    DeviceRequest { adapter: String, message: String },
    /// The device was lost.
    #[error("GPU device lost: {message}")]
    DeviceLost { message: String },
    /// An allocation was refused by the device.
    #[error("GPU out of memory: {message}")]
    OutOfMemory { message: String },
    /// A buffer larger than the device allows.
    #[error("buffer {buffer} needs {requested} bytes; the device allows at most {maximum}")]
    BufferTooLarge {
        buffer: String,
        requested: u64,
        maximum: u64,
    },
    /// The scene or adapter needs something the GPU kernels do not offer.
    #[error("unsupported on the GPU: {what}")]
    Unsupported { what: String },
    /// Anything else the device layer reported.
    #[error("GPU error: {message}")]
    Other { message: String },
}

/// Any failure a backend can report.
#[derive(Debug, Clone, PartialEq, Error)]
#[non_exhaustive]
pub enum BackendError {
    #[error(transparent)]
    Step(#[from] StepError),
    #[error(transparent)]
    Gpu(#[from] GpuError),
    /// A call that does not fit the loaded plan (wrong vector length, family
    /// index out of range, …).
    #[error("invalid call: {0}")]
    InvalidCall(String),
    /// A step failed and restoring the state of its start failed too: the
    /// resident state is no longer the state before the step. The step's
    /// own failure is the [`source`](std::error::Error::source).
    #[error("rolling the state back after a failed step failed: {rollback}")]
    RollbackFailed {
        /// Why the rollback failed.
        rollback: GpuError,
        /// Why the step failed.
        #[source]
        original: Box<BackendError>,
    },
}

impl BackendError {
    /// This step failure after an attempt to roll the state back: itself
    /// when `rollback` succeeded, else [`BackendError::RollbackFailed`]
    /// with itself as the source (the original failure is never dropped).
    pub fn after_rollback(self, rollback: Result<(), GpuError>) -> BackendError {
        match rollback {
            Ok(()) => self,
            Err(e) => BackendError::RollbackFailed {
                rollback: e,
                original: Box::new(self),
            },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::error::Error as _;

    fn step_failure() -> BackendError {
        StepError::NonFiniteParticle {
            stage: StageName::Predict,
            substep: 2,
            particle: 7,
        }
        .into()
    }

    #[test]
    fn a_failed_rollback_keeps_the_step_error_as_its_source() {
        assert_eq!(step_failure().after_rollback(Ok(())), step_failure());
        let lost = GpuError::DeviceLost {
            message: "gone".into(),
        };
        let e = step_failure().after_rollback(Err(lost.clone()));
        assert_eq!(
            e,
            BackendError::RollbackFailed {
                rollback: lost,
                original: Box::new(step_failure()),
            }
        );
        let source = e.source().map(ToString::to_string);
        assert_eq!(source, Some(step_failure().to_string()));
        assert!(e.to_string().contains("GPU device lost: gone"), "{e}");
    }
}
