//! One backend factory: a plan, its initial state and a [`BackendKind`]
//! in, the backend that runs it out.
//!
//! ```text
//! cpu       CpuBackend: the f64 golden path, every plan
//! gpu-f32   SolverPlan::Xpbd                 → GpuBackend
//! gpu-f64   SolverPlan::IncrementalPotential → GpuBarrierBackend
//!           never a fallback: no adapter, a missing SHADER_F64, a scene the
//!           kernels cannot run is a typed error
//! auto      gpu-f32 on a hardware adapter that loads the plan; otherwise
//!           cpu, with a notice on stderr saying why (no adapter, only a
//!           software rasteriser on these same CPU cores, a dimension above
//!           the GPU kernels' limit, the GPU backend failed to load)
//! ```

use std::fmt;
use std::str::FromStr;

use hyperpbd_core::{Backend, BackendError, Plan, Precision, SolverPlan, State};
use hyperpbd_cpu::CpuBackend;
use hyperpbd_gpu::{GpuBackend, GpuBarrierBackend, GpuCoupledBackend};

/// Which backend runs a plan.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum BackendKind {
    /// The f64 CPU golden path.
    Cpu,
    /// The wgpu kernels in this precision (an error when they cannot run).
    Gpu(Precision),
    /// A hardware GPU in f32 when one can run the plan, else the CPU,
    /// saying which and why.
    Auto,
}

impl BackendKind {
    /// Every concrete backend, in report order: cpu-f64, gpu-f32, gpu-f64.
    pub const ALL: [BackendKind; 3] = [
        BackendKind::Cpu,
        BackendKind::Gpu(Precision::F32),
        BackendKind::Gpu(Precision::F64),
    ];

    /// `cpu-f64`, `gpu-f32`, `gpu-f64` or `auto`: the name backends report
    /// and reports print.
    pub fn name(self) -> &'static str {
        match self {
            BackendKind::Cpu => "cpu-f64",
            BackendKind::Gpu(Precision::F32) => "gpu-f32",
            BackendKind::Gpu(Precision::F64) => "gpu-f64",
            BackendKind::Auto => "auto",
        }
    }

    /// The precision the backend computes in (`None` for `auto`, which
    /// decides at load time).
    pub fn precision(self) -> Option<Precision> {
        match self {
            BackendKind::Cpu => Some(Precision::F64),
            BackendKind::Gpu(p) => Some(p),
            BackendKind::Auto => None,
        }
    }
}

impl fmt::Display for BackendKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for BackendKind {
    type Err = String;

    /// [`BackendKind::name`], or the short forms `cpu` and `gpu` (f32).
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "cpu" | "cpu-f64" => Ok(BackendKind::Cpu),
            "gpu" | "gpu-f32" => Ok(BackendKind::Gpu(Precision::F32)),
            "gpu-f64" => Ok(BackendKind::Gpu(Precision::F64)),
            "auto" => Ok(BackendKind::Auto),
            _ => Err(format!(
                "unknown backend {s:?}; backends: cpu, gpu, gpu-f64, auto"
            )),
        }
    }
}

impl serde::Serialize for BackendKind {
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        serializer.serialize_str(self.name())
    }
}

/// Loads `plan` with `state` on the backend `kind` names (see the module
/// docs for what `auto` picks; it says so on stderr).
///
/// # Errors
///
/// What the chosen backend's constructor reports: a state that does not fit
/// the plan, and for the GPU no adapter, a missing feature, a dimension
/// above the kernels' limit, a buffer over the device limit, …
pub fn load(
    plan: Plan,
    state: &State,
    kind: BackendKind,
) -> Result<Box<dyn Backend>, BackendError> {
    let loaded = load_with(plan, state, kind, None)?;
    if let Some(notice) = &loaded.notice {
        eprintln!("notice: {notice}");
    }
    Ok(loaded.backend)
}

/// A backend [`load_with`] loaded, and what `auto` picked and why.
pub struct Loaded {
    /// The backend (every backend can move to another thread).
    pub backend: Box<dyn Backend + Send>,
    /// For `auto`: `backend auto -> …` with the reason, the words [`load`]
    /// prints on stderr; `None` for a named backend.
    pub notice: Option<String>,
}

/// [`load`] for embedders: the CPU backend runs on `threads` threads
/// (`None`: [`crate::default_threads`]), the `auto` notice is returned
/// instead of printed, and the backend is `Send` (a binding steps it with
/// its interpreter lock released).
///
/// # Errors
///
/// As [`load`].
pub fn load_with(
    plan: Plan,
    state: &State,
    kind: BackendKind,
    threads: Option<usize>,
) -> Result<Loaded, BackendError> {
    let named = |backend| Loaded {
        backend,
        notice: None,
    };
    match kind {
        BackendKind::Cpu => Ok(named(cpu(plan, state, threads)?)),
        BackendKind::Gpu(precision) => {
            let (adapter, _) = hyperpbd_gpu::request_adapter(precision)?;
            Ok(named(on_adapter(&adapter, plan, state, precision)?))
        }
        BackendKind::Auto => load_auto(plan, state, threads),
    }
}

/// The CPU golden path on `threads` threads (`None`: the default count).
fn cpu(
    plan: Plan,
    state: &State,
    threads: Option<usize>,
) -> Result<Box<dyn Backend + Send>, BackendError> {
    Ok(Box::new(match threads {
        Some(n) => CpuBackend::with_threads(plan, state, n)?,
        None => CpuBackend::new(plan, state)?,
    }))
}

/// Loads `plan` with `state` on a device of `adapter`: the GPU backend of
/// the plan's solver ([`GpuBackend`] for XPBD, [`GpuBarrierBackend`] for the
/// incremental potential).
pub fn load_on_adapter(
    adapter: &wgpu::Adapter,
    plan: Plan,
    state: &State,
    precision: Precision,
) -> Result<Box<dyn Backend>, BackendError> {
    Ok(on_adapter(adapter, plan, state, precision)?)
}

/// [`load_on_adapter`], `Send`.
fn on_adapter(
    adapter: &wgpu::Adapter,
    plan: Plan,
    state: &State,
    precision: Precision,
) -> Result<Box<dyn Backend + Send>, BackendError> {
    Ok(match plan.solver {
        SolverPlan::Xpbd => Box::new(GpuBackend::with_adapter(adapter, plan, state, precision)?),
        SolverPlan::IncrementalPotential(ref ip) if ip.coupled.is_some() => Box::new(
            GpuCoupledBackend::with_adapter(adapter, plan, state, precision)?,
        ),
        SolverPlan::IncrementalPotential(_) => Box::new(GpuBarrierBackend::with_adapter(
            adapter, plan, state, precision,
        )?),
    })
}

/// `auto`: gpu-f32 where a hardware adapter loads the plan, else the CPU;
/// the notice says which and why.
fn load_auto(plan: Plan, state: &State, threads: Option<usize>) -> Result<Loaded, BackendError> {
    let max_dim = hyperpbd_gpu::shader::MAX_GPU_DIM;
    let why = match hyperpbd_gpu::request_adapter(Precision::F32) {
        Err(e) => format!("no GPU adapter ({e})"),
        Ok((_, summary)) if summary.device_type == "Cpu" => format!(
            "the only adapter, {}, is a software rasteriser running on this CPU \
             (pass --backend gpu to use it anyway)",
            summary.name
        ),
        Ok(_) if plan.dim > max_dim => format!(
            "dimension {} is above the GPU kernels' limit of {max_dim}",
            plan.dim
        ),
        Ok((adapter, summary)) => match on_adapter(&adapter, plan.clone(), state, Precision::F32) {
            Ok(backend) => {
                return Ok(Loaded {
                    backend,
                    notice: Some(format!("backend auto -> gpu-f32 on {}", summary.name)),
                });
            }
            Err(e) => format!("the GPU backend failed to load on {}: {e}", summary.name),
        },
    };
    Ok(Loaded {
        backend: cpu(plan, state, threads)?,
        notice: Some(format!(
            "backend auto -> cpu-f64 (the f64 CPU golden path): {why}"
        )),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_parse_back_and_short_forms_are_accepted() {
        for kind in BackendKind::ALL.into_iter().chain([BackendKind::Auto]) {
            assert_eq!(kind.name().parse::<BackendKind>(), Ok(kind));
        }
        assert_eq!("cpu".parse::<BackendKind>(), Ok(BackendKind::Cpu));
        assert_eq!(
            "gpu".parse::<BackendKind>(),
            Ok(BackendKind::Gpu(Precision::F32))
        );
        assert!("tpu".parse::<BackendKind>().is_err());
    }

    #[test]
    fn load_with_runs_the_asked_threads_and_returns_the_auto_notice() {
        let scene = crate::scenes::chain2d();
        let plan = || Plan::compile(&scene).expect("chain2d compiles");
        let state = State::from_scene(&scene);
        let loaded = load_with(plan(), &state, BackendKind::Cpu, Some(2)).expect("cpu loads");
        assert!(loaded.notice.is_none(), "a named backend has no notice");
        let mut backend = loaded.backend;
        assert_eq!(backend.step().expect("chain2d steps").threads, 2);
        // auto always loads something and always says what and why.
        let auto = load_with(plan(), &state, BackendKind::Auto, Some(1)).expect("auto loads");
        let notice = auto.notice.expect("auto says what it picked");
        assert!(
            notice.starts_with(&format!("backend auto -> {}", auto.backend.name())),
            "{notice}"
        );
    }
}
