//! One measured configuration of the sweep: what the frontier, the plots
//! and the tables read.

use crate::cases::CaseId;
use hyperpbd::BackendKind;
use serde::Serialize;

/// One measured configuration.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Point {
    /// The case.
    pub case: CaseId,
    /// The backend.
    pub backend: BackendKind,
    /// Substeps per step.
    pub substeps: u32,
    /// Iterations per substep.
    pub iterations: u32,
    /// Median wall ms per simulated second.
    pub ms_per_sim_second: f64,
    /// Fastest rep.
    pub ms_min: f64,
    /// Slowest rep.
    pub ms_max: f64,
    /// Reps run (fewer than configured for long runs).
    pub reps: usize,
    /// The case's error measure (None when it could not be measured).
    pub error: Option<f64>,
    /// Largest constraint violation over the run.
    pub residual: f64,
    /// Relative energy drift (conservative cases only).
    pub energy_drift: Option<f64>,
    /// On its backend's Pareto frontier.
    pub frontier: bool,
    /// Nothing moved at the end: every dynamic velocity exactly 0 in a
    /// scene with gravity (f32 at many substeps: h·|v| is below half an ulp
    /// of x, so x never changes). A frozen run can sit close to a
    /// near-static reference by accident; it is kept off frontiers and
    /// headlines.
    pub frozen: bool,
    /// Why the error is missing, or anything odd (not reproducible).
    pub note: Option<String>,
}
