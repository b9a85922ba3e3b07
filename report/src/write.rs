//! Writing a run: every file of the report into the output directory and,
//! when asked, the README section (see `outputs.rs` for the list).
//!
//! ```text
//! full run       figures (PNG), effects.md + effects.json, accuracy.json,
//!                accuracy.md, README section
//! effects only   effects.md, effects.json and the README's effect lines;
//!                accuracy.md and the other figures are left as they are
//! ```

use crate::cases::CaseId;
use crate::config::Config;
use crate::effects_markdown::effects_markdown;
use crate::format::footer;
use crate::markdown::markdown;
use crate::measured::{AccuracyError, Report};
use crate::outputs::{
    CLOTH, EFFECTS_JSON, EFFECTS_MARKDOWN, JSON, MARKDOWN, PARETO, SCALING, write_file,
};
use crate::plot;
use crate::readme::{readme_effects, readme_section, relative, update_effects, update_section};
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
