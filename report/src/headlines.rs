//! The headline answers: "to reach ε on case C, backend B needs T ms per
//! simulated second (S substeps × I iterations)", as sentences, table
//! cells and the terminal summary.

use crate::cases::CaseId;
use crate::format::{ms, plural, sci, sci_short};
use crate::measured::{Headline, Report};
use hyperpbd::BackendKind;
use std::fmt::Write as _;

pub fn config_label(case: CaseId, s: u32, i: u32) -> String {
    if case.uses_iterations() {
        format!("{} × {}", plural(s, "substep"), plural(i, "iteration"))
    } else {
        plural(s, "substep")
    }
}

/// "X ms (config)" or "not reached (best e at X ms)".
pub fn headline_cell(h: &Headline) -> String {
    match (h.reached, h.best) {
        (Some((s, i, t, _)), _) => format!("**{} ms** ({})", ms(t), config_label(h.case, s, i)),
        (None, Some((s, i, t, e))) => format!(
            "not reached (best {} at {} ms, {})",
            sci(e),
            ms(t),
            config_label(h.case, s, i)
        ),
        (None, None) => "no data".into(),
    }
}

pub fn headline_for(report: &Report, case: CaseId, backend: BackendKind) -> Option<&Headline> {
    report
        .headlines
        .iter()
        .find(|h| h.case == case && h.backend == backend)
}

/// The sentence the issue asks for, for one case.
pub fn headline_sentence(report: &Report, case: CaseId) -> Option<String> {
    let parts: Vec<String> = BackendKind::ALL
        .iter()
        .filter_map(|&b| headline_for(report, case, b))
        .map(|h| match h.reached {
            Some((s, i, t, _)) => format!(
                "{} needs **{} ms** per simulated second ({})",
                h.backend.name(),
                ms(t),
                config_label(case, s, i)
            ),
            None => format!(
                "{} does not reach it in the sweep (best {})",
                h.backend.name(),
                h.best.map_or("–".into(), |b| sci(b.3))
            ),
        })
        .collect();
    if parts.is_empty() {
        return None;
    }
    let result = report.cases.iter().find(|c| c.case == case)?;
    Some(format!(
        "To reach {} {} on the {}: {}.",
        sci_short(report.target),
        match case {
            CaseId::Pendulum => "relative period error",
            CaseId::Stretch => "relative axial strain error (vs the closed-form uniaxial stretch)",
            CaseId::Cloth | CaseId::Tesseract | CaseId::Chain2d => {
                "relative position error (max particle distance to the converged reference / extent)"
            }
            _ => "relative position error",
        },
        result.title,
        parts.join(", ")
    ))
}

/// A few lines for the terminal: headline answers and fitted exponents.
pub fn summary(report: &Report) -> String {
    let mut s = String::new();
    for c in &report.cases {
        if let Some(line) = headline_sentence(report, c.case) {
            let _ = writeln!(s, "{}", line.replace("**", ""));
        }
    }
    for f in &report.fits {
        let _ = writeln!(s, "scaling {}: t ∝ P^{:.2}", f.backend.name(), f.exponent);
    }
    s.trim_end().to_string()
}
