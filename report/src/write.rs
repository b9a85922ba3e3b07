//! Writing a run: every file of the report into the output directory and,
//! when asked, the README section (see `outputs.rs` for the list).
//!
//! ```text
//! full run       figures (PNG), effects.md + effects.json, accuracy.json,
//!                accuracy.md, README section
//! effects only   effects.md, effects.json and the README's effect lines;
//!                accuracy.md and the other figures are left as they are
//! implicit only  implicit.json; the implicit section spliced into
//!                accuracy.md between its markers (inserted before the
//!                first later section when absent) and the README's
//!                implicit lines; nothing else is touched
//! patch only     patch.json and accuracy_patch.png; the patch section
//!                spliced into accuracy.md like the implicit one (after
//!                it when both are absent); the README is not touched
//! full run       also implicit.json, patch.json and accuracy_patch.png
//!                beside accuracy.json
//! ```

use crate::cases::CaseId;
use crate::config::Config;
use crate::effects_markdown::effects_markdown;
use crate::format::footer;
use crate::implicit_markdown::{IMPLICIT_BEGIN, IMPLICIT_END, implicit_section, readme_implicit};
use crate::markdown::markdown;
use crate::measured::{AccuracyError, Report};
use crate::outputs::{
    CLOTH, EFFECTS_JSON, EFFECTS_MARKDOWN, IMPLICIT_JSON, JSON, MARKDOWN, PARETO, PATCH_JSON,
    PATCH_PNG, SCALING, write_file,
};
use crate::patch_markdown::{PATCH_BEGIN, PATCH_END, patch_section};
use crate::plot;
use crate::readme::{
    readme_effects, readme_section, relative, splice, update_effects, update_implicit,
    update_section,
};
use std::path::Path;

/// Writes OUT/effects.md and OUT/figures/effects.json.
fn write_effects(report: &mut Report, out: &Path) -> Result<(), AccuracyError> {
    let json = serde_json::json!({
        "mode": report.mode,
        "machine": report.machine,
        "effects_n": report.effects_n,
        "effects_balls": report.effects_balls,
        "effects_ball_steps": report.effects_ball_steps,
        "effect_reps": report.effect_reps,
        "effects": report.effects,
        "notices": report.notices,
    });
    let json = serde_json::to_string_pretty(&json)
        .map_err(|e| AccuracyError::Output(format!("cannot serialise the effects: {e}")))?;
    write_file(&out.join(EFFECTS_JSON), (json + "\n").as_bytes())?;
    write_file(
        &out.join(EFFECTS_MARKDOWN),
        effects_markdown(report).as_bytes(),
    )?;
    report.files.push(EFFECTS_JSON.into());
    report.files.push(EFFECTS_MARKDOWN.into());
    Ok(())
}

/// Writes OUT/figures/implicit.json (when the implicit rows ran).
fn write_implicit_json(report: &mut Report, out: &Path) -> Result<(), AccuracyError> {
    let Some(section) = &report.implicit else {
        return Ok(());
    };
    let json = serde_json::json!({
        "mode": report.mode,
        "machine": report.machine,
        "implicit": section,
    });
    let json = serde_json::to_string_pretty(&json)
        .map_err(|e| AccuracyError::Output(format!("cannot serialise the implicit rows: {e}")))?;
    write_file(&out.join(IMPLICIT_JSON), (json + "\n").as_bytes())?;
    report.files.push(IMPLICIT_JSON.into());
    Ok(())
}

/// Writes OUT/figures/patch.json and OUT/figures/accuracy_patch.png (when
/// the patch study ran).
fn write_patch_files(report: &mut Report, out: &Path) -> Result<(), AccuracyError> {
    let Some(section) = &report.patch else {
        return Ok(());
    };
    let json = serde_json::json!({
        "mode": report.mode,
        "machine": report.machine,
        "patch": section,
    });
    let json = serde_json::to_string_pretty(&json)
        .map_err(|e| AccuracyError::Output(format!("cannot serialise the patch study: {e}")))?;
    let figure =
        crate::patch_plot::patch_figure(section, &footer(report)).map_err(AccuracyError::Output)?;
    write_file(&out.join(PATCH_JSON), (json + "\n").as_bytes())?;
    write_file(&out.join(PATCH_PNG), &figure)?;
    report.files.push(PATCH_JSON.into());
    report.files.push(PATCH_PNG.into());
    Ok(())
}

/// Sections of accuracy.md that follow the implicit and patch ones, in
/// order: a section without markers goes before the first of them.
const LATER_SECTIONS: [&str; 4] = [
    "\n## Scaling",
    "\n## What each effect costs",
    "\n## Notices",
    "\n## How it was measured",
];

/// Splices `body` between `markers` into OUT/accuracy.md (created when
/// missing; without the markers, the block goes before the first of
/// [`LATER_SECTIONS`], or at the end).
fn splice_markdown(
    report: &mut Report,
    out: &Path,
    markers: (&str, &str),
    body: &str,
) -> Result<(), AccuracyError> {
    let path = out.join(MARKDOWN);
    let text = match std::fs::read_to_string(&path) {
        Ok(text) => text,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => "# What accuracy costs\n".into(),
        Err(e) => {
            return Err(AccuracyError::Output(format!(
                "cannot read {}: {e}",
                path.display()
            )));
        }
    };
    let text = splice(&text, markers, body, |text, block| {
        match LATER_SECTIONS.iter().find_map(|h| text.find(h)) {
            Some(at) => format!("{}\n{block}\n{}", &text[..at], &text[at..]),
            None => format!("{}\n\n{block}\n", text.trim_end()),
        }
    });
    write_file(&path, text.as_bytes())?;
    report.files.push(MARKDOWN.into());
    Ok(())
}

/// An implicit-only run: implicit.json, the section spliced into
/// OUT/accuracy.md (created when missing) and the README's lines.
fn write_implicit_only(report: &mut Report, config: &Config) -> Result<(), AccuracyError> {
    let out = &config.out;
    report.files.clear();
    write_implicit_json(report, out)?;
    let Some(section) = &report.implicit else {
        return Ok(());
    };
    let body = implicit_section(report, section);
    splice_markdown(report, out, (IMPLICIT_BEGIN, IMPLICIT_END), &body)?;
    let Some(section) = &report.implicit else {
        return Ok(());
    };
    if let Some(readme) = &config.readme {
        let dir = readme.parent().unwrap_or(Path::new("."));
        update_implicit(readme, &readme_implicit(section, &relative(dir, out)))?;
    }
    Ok(())
}

/// Writes every file of the report into `config.out` (and the README);
/// an effects-only run writes only the effect files and README lines.
pub fn write(report: &mut Report, config: &Config) -> Result<(), AccuracyError> {
    let out = &config.out;
    if config.effects_only {
        report.files.clear();
        write_effects(report, out)?;
        if let Some(readme) = &config.readme {
            let dir = readme.parent().unwrap_or(Path::new("."));
            let out_rel = relative(dir, out);
            update_effects(readme, &readme_effects(report, &out_rel))?;
        }
        return Ok(());
    }
    if config.implicit_only {
        return write_implicit_only(report, config);
    }
    if config.patch_only {
        report.files.clear();
        write_patch_files(report, out)?;
        let Some(section) = &report.patch else {
            return Ok(());
        };
        let body = patch_section(report, section, true);
        return splice_markdown(report, out, (PATCH_BEGIN, PATCH_END), &body);
    }
    let foot = footer(report);
    let draw = |e: String| AccuracyError::Output(e);
    report.files.clear();
    if !report.cases.is_empty() {
        write_file(
            &out.join(PARETO),
            &plot::pareto_grid(&report.cases, &foot).map_err(draw)?,
        )?;
        report.files.push(PARETO.into());
        if let Some(cloth) = report.cases.iter().find(|c| c.case == CaseId::Cloth) {
            write_file(
                &out.join(CLOTH),
                &plot::pareto_single(cloth, report.target, &foot).map_err(draw)?,
            )?;
            report.files.push(CLOTH.into());
        }
    }
    if report.scaling.iter().any(|p| p.ms_per_step.is_some()) {
        write_file(
            &out.join(SCALING),
            &plot::scaling(&report.scaling, &report.fits, &foot).map_err(draw)?,
        )?;
        report.files.push(SCALING.into());
    }
    if !report.effects.is_empty() {
        write_effects(report, out)?;
    }
    write_implicit_json(report, out)?;
    write_patch_files(report, out)?;
    report.files.push(JSON.into());
    report.files.push(MARKDOWN.into());
    let json = serde_json::to_string_pretty(&*report)
        .map_err(|e| AccuracyError::Output(format!("cannot serialise the report: {e}")))?;
    write_file(&out.join(JSON), (json + "\n").as_bytes())?;
    write_file(&out.join(MARKDOWN), markdown(report, config).as_bytes())?;
    if let Some(readme) = &config.readme {
        let dir = readme.parent().unwrap_or(Path::new("."));
        let out_rel = relative(dir, out);
        update_section(readme, &readme_section(report, &out_rel))?;
    }
    Ok(())
}
