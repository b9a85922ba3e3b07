//! Progress lines on stderr and the notices that go into the report.

use crate::point::Point;
use hyperpbd::BackendKind;

/// Progress lines and the notices that go into the report.
#[derive(Debug)]
pub struct Progress {
    pub(crate) enabled: bool,
    pub(crate) unavailable: Vec<(BackendKind, String)>,
    /// Notices (skips, references) in order.
    pub notes: Vec<String>,
}

impl Progress {
    /// Whether `backend` can run here.
    pub fn available(&self, backend: BackendKind) -> bool {
        !self.unavailable.iter().any(|(b, _)| *b == backend)
    }

    /// A notice: printed and kept for the report.
    pub fn note(&mut self, text: &str) {
        if self.enabled {
            eprintln!("notice: {text}");
        }
        self.notes.push(text.to_string());
    }

    /// A progress line (printed only).
    pub fn line(&self, text: &str) {
        if self.enabled {
            eprintln!("{text}");
        }
    }

    /// A finished sweep point.
    pub fn point(&self, p: &Point) {
        self.line(&format!(
            "{:<10} {:>8} s{:<3} i{:<2} {:>10.2} ms/sim-s  error {}",
            p.case.name(),
            p.backend.name(),
            p.substeps,
            p.iterations,
            p.ms_per_sim_second,
            match (p.error, &p.note) {
                (Some(e), _) => format!("{e:.3e}"),
                (None, Some(n)) => n.clone(),
                (None, None) => "-".into(),
            }
        ));
    }
}
