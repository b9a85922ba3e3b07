//! Which machine and which adapters produced a report.
//!
//! Every figure and table carries this line: the CPU model (first
//! `model name` of `/proc/cpuinfo`), the number of hardware threads the
//! process may use (`std::thread::available_parallelism`, what `nproc`
//! prints), the load average before and after (other work on the machine
//! makes timings noisy), and the GPU adapter of each precision.

use hyperpbd::gpu::{Precision, request_adapter};
use serde::Serialize;

/// The machine a report was measured on.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Machine {
    /// CPU model, or `unknown CPU`.
    pub cpu_model: String,
    /// Hardware threads available to this process (`nproc`).
    pub nproc: usize,
    /// 1-minute load average when the run started (`/proc/loadavg`).
    pub load_start: Option<f64>,
    /// 1-minute load average when the run ended.
    pub load_end: Option<f64>,
    /// The f32 adapter, or why there is none.
    pub gpu_f32: Result<String, String>,
    /// The f64 adapter (needs SHADER_F64), or why there is none.
    pub gpu_f64: Result<String, String>,
    /// True when an adapter is a CPU (software) device such as lavapipe.
    pub software_adapter: bool,
    /// hyperpbd version.
    pub version: String,
}

/// First `model name` line of `/proc/cpuinfo`.
pub fn cpu_model() -> String {
    std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|text| {
            text.lines()
                .find(|l| l.starts_with("model name"))
                .and_then(|l| l.split_once(':'))
                .map(|(_, v)| v.trim().to_string())
        })
        .unwrap_or_else(|| "unknown CPU".to_string())
}

/// The 1-minute load average, where `/proc/loadavg` exists.
pub fn load_average() -> Option<f64> {
    std::fs::read_to_string("/proc/loadavg")
        .ok()?
        .split_whitespace()
        .next()?
        .parse()
        .ok()
}

impl Machine {
    /// Probes the CPU and both GPU precisions.
    pub fn probe() -> Machine {
        let mut software = false;
        let mut adapter = |precision: Precision| match request_adapter(precision) {
            Ok((_, s)) => {
                software |= s.device_type == "Cpu";
                Ok(format!(
                    "{} [{}, {}] {}",
                    s.name, s.backend, s.device_type, s.driver_info
                )
                .trim()
                .to_string())
            }
            Err(e) => Err(e.to_string()),
        };
        let gpu_f32 = adapter(Precision::F32);
        let gpu_f64 = adapter(Precision::F64);
        Machine {
            cpu_model: cpu_model(),
            nproc: std::thread::available_parallelism().map_or(1, |n| n.get()),
            load_start: load_average(),
            load_end: None,
            gpu_f32,
            gpu_f64,
            software_adapter: software,
            version: env!("CARGO_PKG_VERSION").to_string(),
        }
    }

    /// The adapter that ran the GPU points: the f32 one (the f64 one is
    /// named too when it differs).
    pub fn adapter_line(&self) -> String {
        match (&self.gpu_f32, &self.gpu_f64) {
            (Ok(a), Ok(b)) if a == b => a.clone(),
            (Ok(a), Ok(b)) => format!("f32: {a}; f64: {b}"),
            (Ok(a), Err(_)) => format!("{a} (no f64 adapter)"),
            (Err(_), Ok(b)) => format!("f64: {b}"),
            (Err(e), Err(_)) => format!("no GPU adapter ({e})"),
        }
    }

    /// One line for figure footers: CPU, nproc, adapter.
    pub fn footer(&self) -> String {
        format!(
            "CPU: {} (nproc {}); GPU adapter: {}",
            self.cpu_model,
            self.nproc,
            self.adapter_line()
        )
    }
}
