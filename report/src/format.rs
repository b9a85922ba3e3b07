//! Number formats and the sentences every file of the report shares.
//!
//! ```text
//! ms(x)     three significant digits: 123, 12.3, 1.23, 0.123
//! sci(x)    1.23e-4;  sci_short(1e-3) = 1e-3
//! –         any value that is missing or not finite
//! ```

use crate::measured::Report;
use hyperpbd::BackendKind;
use std::fmt::Write as _;

/// ms with three significant digits.
pub fn ms(x: f64) -> String {
    if !x.is_finite() {
        "–".into()
    } else if x >= 100.0 {
        format!("{x:.0}")
    } else if x >= 10.0 {
        format!("{x:.1}")
    } else if x >= 1.0 {
        format!("{x:.2}")
    } else {
        format!("{x:.3}")
    }
}

/// An error value: `1.23e-4`.
pub fn sci(x: f64) -> String {
    if x.is_finite() {
        format!("{x:.2e}")
    } else {
        "–".into()
    }
}

pub fn sci_short(x: f64) -> String {
    let e = x.log10();
    if (e - e.round()).abs() < 1e-9 {
        format!("1e{}", e.round() as i32)
    } else {
        sci(x)
    }
}

pub fn plural(n: u32, word: &str) -> String {
    if n == 1 {
        format!("1 {word}")
    } else {
        format!("{n} {word}s")
    }
}

/// A markdown table cell: `|` escaped.
pub fn cell(text: &str) -> String {
    text.replace('|', "\\|")
}

/// A point's error cell: the error (with its note in brackets), the note
/// alone, or "–".
pub fn error_cell(error: Option<f64>, note: Option<&str>) -> String {
    match (error, note) {
        (Some(e), Some(n)) => format!("{} ({})", sci(e), cell(n)),
        (Some(e), None) => sci(e),
        (None, Some(n)) => cell(n),
        (None, None) => "–".into(),
    }
}

pub fn ms_signed(x: f64) -> String {
    if x >= 0.0 {
        format!("+{}", ms(x))
    } else {
        format!("−{}", ms(-x))
    }
}

/// A load average with two decimals, `–` when unknown.
pub fn load_average(load: Option<f64>) -> String {
    load.map_or("–".into(), |l| format!("{l:.2}"))
}

/// How a section of the page was measured: "took W s, load average a → b;
/// (the machine)" (the load before and after it).
pub fn section_timing(
    wall_seconds: f64,
    load: (Option<f64>, Option<f64>),
    report: &Report,
) -> String {
    format!(
        "took {wall_seconds:.1} s, load average {} → {}; {}",
        load_average(load.0),
        load_average(load.1),
        report.machine.footer()
    )
}

pub fn noise_note(report: &Report) -> String {
    let mut s = format!(
        "Timings are wall-clock and noisy: every timing is the **median of {} repetition{}** \
         (min–max beside it), measured while other work shared the machine (load average above). \
         Only `step()` calls are timed; read-backs for the error measures are not.",
        report.reps,
        if report.reps == 1 { "" } else { "s" }
    );
    if report.machine.software_adapter {
        s.push_str(
            " The GPU adapter here is a **software** Vulkan driver running on the same CPU cores, \
             so gpu-f32/gpu-f64 times measure the kernels' work on those cores plus the \
             driver's dispatch overhead — not what a hardware GPU would do.",
        );
    }
    s
}

pub fn footer(report: &Report) -> Vec<String> {
    vec![
        report.machine.footer(),
        format!(
            "hyperpbd {} accuracy ({} mode); median of {} rep{}; load average {} → {}",
            report.machine.version,
            report.mode,
            report.reps,
            if report.reps == 1 { "" } else { "s" },
            load_average(report.machine.load_start),
            load_average(report.machine.load_end),
        ),
    ]
}

/// A markdown table head: the fixed `columns` and their `rule`, then one
/// column per backend titled `title(backend)` with `backend_rule`.
pub fn table_head(
    s: &mut String,
    (columns, rule): (&str, &str),
    backends: &[BackendKind],
    title: impl Fn(BackendKind) -> String,
    backend_rule: &str,
) {
    s.push_str(columns);
    for &b in backends {
        let _ = write!(s, " {} |", title(b));
    }
    s.push('\n');
    s.push_str(rule);
    for _ in backends {
        s.push_str(backend_rule);
    }
    s.push('\n');
}
