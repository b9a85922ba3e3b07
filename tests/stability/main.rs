//! What stays stable: hard scenes on every backend (cpu-f64, gpu-f32,
//! gpu-f64), each asserting no NaN/Inf, bounded energy and a residual
//! within a stated bound — or a typed refusal where the input is
//! impossible. One test per case per backend; each prints
//!
//! ```text
//! STABLE | case | backend | result | metric = measured | bound (rationale)
//! ```
//! and the table of docs/stability.md is written from
//! `cargo test --release --test stability -- --nocapture --test-threads 1 | grep '^STABLE'`.
//!
//! # The metrics
//!
//! ```text
//! finite     every position and velocity finite after every step (asserted
//!            every step, no bound)
//! energy     ΔE = max over steps of E(t) − E(0), with
//!              E = Σ_dynamic m_i (½|v_i|² − s_i g·(x_i − x_i(0))) − f_i·(x_i − x_i(0))
//!            XPBD is dissipative (implicit Euler on the constraint forces,
//!            inelastic contacts, friction, damping): ΔE ≤ 0 up to rounding
//!            of E itself, bound ε·64·E_scale, E_scale = Σ m (|g|·L + ½ v0² + ½ v²)
//!            + |f|·L with L = max_a |x_a(0)| + |x_a − x_a(0)| per particle
//!            (positions round relative to their magnitude); a case
//!            that starts with violated constraints may release at most the
//!            energy of correcting them in one substep, ½ Σ m (C₀/h)², and
//!            says so
//! residual   max over steps of the step report's max violation of the
//!            length-unit families (distance |C| and contact max(0, −C)),
//!            in metres; each case states its bound and why
//! ```
//! ε is the backend's unit roundoff (f64 2⁻⁵², f32 2⁻²³).

#[path = "../common/mod.rs"]
mod common;

use common::bound::print_bound;
use common::gpu::{adapter_or_skip, load_or_skip};
use hyperpbd::core::builders::{BlockSpec, ChainSpec, GridSpec};
use hyperpbd::gpu::{GpuBackend, Precision, SceneOrigin, XpbdOptions};
use hyperpbd::{
    Backend, BackendError, BackendKind, ConstraintFamily, ConstraintKind, CpuBackend, FamilyKind,
    GpuError, Particle, Plan, Scene, SceneBuilder, SceneError, State,
};

// ---------------------------------------------------------------- backends

/// The gpu-f32 backend (a constant, so cases can match on it).
const GPU_F32: BackendKind = BackendKind::Gpu(Precision::F32);
/// The gpu-f64 backend.
const GPU_F64: BackendKind = BackendKind::Gpu(Precision::F64);

/// Unit roundoff of the backend's arithmetic.
fn epsilon(kind: BackendKind) -> f64 {
    kind.precision().map_or(f64::EPSILON, Precision::epsilon)
}

/// One `STABLE` line.
fn report(case: &str, kind: BackendKind, result: &str, metric: &str, measured: f64, bound: &str) {
    println!(
        "STABLE | {case} | {} | {result} | {metric} = {measured:.3e} | {bound}",
        kind.name()
    );
}

// ---------------------------------------------------------------- the run

/// What a run measured.
#[derive(Debug, Clone)]
struct Measured {
    /// Largest E(t) − E(0) over the steps.
    energy_gain: f64,
    /// E_scale of the energy bound.
    energy_scale: f64,
    /// Largest length-unit residual over the steps.
    residual: f64,
    /// Largest residual of the other (measure) families over the steps.
    measure_residual: f64,
    /// Length-unit residual after the last step.
    final_residual: f64,
    /// The final state.
    last: State,
}

/// E(t) − E(0) and E_scale for `state` against the initial `x0`, `v0`.
fn energy(plan: &Plan, x0: &State, state: &State) -> (f64, f64) {
    let n = plan.dim;
    let g: f64 = plan.gravity.iter().map(|c| c * c).sum::<f64>().sqrt();
    let (mut now, mut start, mut scale) = (0.0, 0.0, 0.0);
    for (i, &w) in plan.inverse_mass.iter().enumerate() {
        if w == 0.0 {
            continue;
        }
        let m = 1.0 / w;
        let s = plan.gravity_scale[i];
        let (x, x_0) = (state.position(i), x0.position(i));
        let (v, v_0) = (state.velocity(i), x0.velocity(i));
        let f = &plan.force[i * n..(i + 1) * n];
        let mut potential = 0.0;
        let mut excursion: f64 = 0.0;
        let mut force = 0.0;
        for a in 0..n {
            let dx = x[a] - x_0[a];
            potential -= m * s * plan.gravity[a] * dx + f[a] * dx;
            // |x(0)| too: positions round relative to their magnitude.
            excursion = excursion.max(dx.abs() + x_0[a].abs());
            force += f[a] * f[a];
        }
        let kinetic: f64 = 0.5 * m * v.iter().map(|c| c * c).sum::<f64>();
        let kinetic0: f64 = 0.5 * m * v_0.iter().map(|c| c * c).sum::<f64>();
        now += kinetic + potential;
        start += kinetic0;
        scale += m * s.abs() * g * excursion + kinetic0 + kinetic + force.sqrt() * excursion;
    }
    (now - start, scale)
}

fn is_length_unit(kind: &FamilyKind) -> bool {
    matches!(
        kind,
        FamilyKind::Distance | FamilyKind::Tether | FamilyKind::HyperplaneContact { .. }
    )
}

/// Steps `backend` `steps` times from `initial`, asserting finiteness after
/// every step; a step error fails the test (the cases that expect one test
/// it themselves).
fn run(case: &str, backend: &mut dyn Backend, initial: &State, steps: usize) -> Measured {
    try_run(case, backend, initial, steps)
        .unwrap_or_else(|(step, e)| panic!("{case} ({}): step {step}: {e}", backend.name()))
}

/// [`run`], returning the first step error (and its step) instead of
/// failing the test.
fn try_run(
    case: &str,
    backend: &mut dyn Backend,
    initial: &State,
    steps: usize,
) -> Result<Measured, (usize, BackendError)> {
    let plan = backend.plan().clone();
    let mut m = Measured {
        energy_gain: f64::NEG_INFINITY,
        energy_scale: 0.0,
        residual: 0.0,
        measure_residual: 0.0,
        final_residual: 0.0,
        last: initial.clone(),
    };
    for step in 0..steps {
        let step_report = backend.step().map_err(|e| (step, e))?;
        let state = backend.read_state().expect("read_state");
        let bad = state
            .positions
            .iter()
            .chain(&state.velocities)
            .position(|c| !c.is_finite());
        assert!(
            bad.is_none(),
            "{case} ({}): non-finite value at flat index {bad:?} after step {step}",
            backend.name()
        );
        let (gain, scale) = energy(&plan, initial, &state);
        m.energy_gain = m.energy_gain.max(gain);
        m.energy_scale = m.energy_scale.max(scale);
        m.final_residual = 0.0;
        for (f, r) in plan.families.iter().zip(&step_report.residuals) {
            assert!(r.max_violation.is_finite(), "{case}: residual {r:?}");
            if is_length_unit(&f.kind) {
                m.residual = m.residual.max(r.max_violation);
                m.final_residual = m.final_residual.max(r.max_violation);
            } else {
                m.measure_residual = m.measure_residual.max(r.max_violation);
            }
        }
        m.last = state;
    }
    if steps == 0 {
        m.energy_gain = 0.0;
    }
    Ok(m)
}

/// Asserts and reports the energy metric: ΔE ≤ ε·64·E_scale + `released`.
fn check_energy(case: &str, kind: BackendKind, m: &Measured, released: f64, why: &str) {
    let bound = epsilon(kind) * 64.0 * m.energy_scale + released;
    report(
        case,
        kind,
        "ok",
        "energy gain (J)",
        m.energy_gain,
        &format!("{bound:.3e} ({why})"),
    );
    assert!(
        m.energy_gain <= bound,
        "{case} ({}): energy gain {:e} J over bound {bound:e} J",
        kind.name(),
        m.energy_gain
    );
}

/// Asserts and reports a residual metric.
fn check_residual(
    case: &str,
    kind: BackendKind,
    metric: &str,
    measured: f64,
    bound: f64,
    why: &str,
) {
    report(
        case,
        kind,
        "ok",
        metric,
        measured,
        &format!("{bound:.3e} ({why})"),
    );
    assert!(
        measured <= bound,
        "{case} ({}): {metric} {measured:e} over bound {bound:e} ({why})",
        kind.name()
    );
}

/// Compiles `scene` and loads it on `kind`; `None` when the GPU test is
/// skipped.
fn start(case: &str, kind: BackendKind, scene: &Scene) -> Option<(Box<dyn Backend>, State)> {
    let plan = Plan::compile(scene).unwrap_or_else(|e| panic!("{case}: {e}"));
    let initial = State::from_scene(scene);
    load_or_skip(case, kind, plan, &initial)
        .unwrap_or_else(|e| panic!("{case} ({}): {e}", kind.name()))
        .map(|b| (b, initial))
}

/// One test per backend for each case function `fn(BackendKind)`.
macro_rules! on_every_backend {
    ($($case:ident),* $(,)?) => {
        $(
            mod $case {
                #[test]
                fn cpu_f64() {
                    super::$case(hyperpbd::BackendKind::Cpu);
                }
                #[test]
                fn gpu_f32() {
                    super::$case(crate::GPU_F32);
                }
                #[test]
                fn gpu_f64() {
                    super::$case(crate::GPU_F64);
                }
            }
        )*
    };
}

mod chains;
mod degenerate;
mod dimensions;
mod far_offset;
mod implicit;
mod large_steps;
mod on_planes;
