//! The effects rows (controls compile away, collisions and the barrier
//! solver measured with controls, effects-only runs) and the scaling fit,
//! frontier and sampling helpers of the report.

use super::*;

#[test]
fn effect_controls_compile_away_and_effects_add_kernels() {
    let Some((report, _)) = report(&common::gpu::test_name(
        module_path!(),
        "effect_controls_compile_away_and_effects_add_kernels",
    )) else {
        return; // run in the child with LP_NUM_THREADS=0
    };
    let rows: Vec<_> = report
        .effects
        .iter()
        .filter(|r| r.group == effects::CLOTH)
        .cloned()
        .collect();
    assert_eq!(rows.len(), 9);
    // The ladder adds kernels row by row (from gravity only to + damping).
    for pair in rows[1..6].windows(2) {
        assert!(
            pair[1].kernel_calls > pair[0].kernel_calls,
            "{} -> {}",
            pair[0].label,
            pair[1].label
        );
    }
    for control in rows.iter().filter(|r| r.control_of.is_some()) {
        assert_eq!(control.same_schedule, Some(true), "{}", control.label);
        assert_eq!(control.group, effects::CLOTH);
        let twin = rows
            .iter()
            .find(|r| Some(&r.label) == control.control_of.as_ref())
            .expect("twin row");
        assert_eq!(twin.kernel_calls, control.kernel_calls);
        assert_eq!(twin.stages, control.stages);
    }
    assert_eq!(
        rows[6].same_plan,
        Some(true),
        "damping with rate 0 must compile to the very same plan"
    );
    for row in &rows {
        assert!(
            row.ms
                .iter()
                .any(|(b, t)| *b == BackendKind::Cpu && t.is_some_and(|t| t > 0.0)),
            "{}",
            row.label
        );
    }
}

fn ball_row<'a>(report: &'a Report, starts: &str) -> &'a EffectRow {
    report
        .effects
        .iter()
        .find(|r| r.group == effects::BALLS && r.label.starts_with(starts))
        .unwrap_or_else(|| panic!("no ball row {starts:?}"))
}

/// Collisions add exactly Broadphase + Collide; the scene without the
/// `collisions` key compiles to the collision plan minus those parts (=
/// the balls row); the barrier row runs the Minimise stage and is compared
/// as a different solver; explicit "xpbd" is the same plan as omitting it.
#[test]
fn collision_and_barrier_rows_are_measured_with_controls() {
    let Some((report, _)) = report(&common::gpu::test_name(
        module_path!(),
        "collision_and_barrier_rows_are_measured_with_controls",
    )) else {
        return; // run in the child with LP_NUM_THREADS=0
    };
    let balls: Vec<&EffectRow> = report
        .effects
        .iter()
        .filter(|r| r.group == effects::BALLS)
        .collect();
    assert_eq!(balls.len(), 6);
    let base = ball_row(report, "12 balls on a frictionless floor");
    let contact = ball_row(report, "+ collisions (μ = 0)");
    let friction = ball_row(report, "+ ball–ball friction");
    let removed = ball_row(report, "control: \"+ collisions\"");
    let barrier = ball_row(report, "barrier solver");
    let explicit = ball_row(report, "control: balls row with \"solver\"");
    assert!(!base.stages.contains("broadphase"), "{}", base.stages);
    assert_eq!(contact.stages, "predict → broadphase → project → velocity");
    // 10 substeps × (one Broadphase + one Collide per iteration, 4 iterations).
    assert_eq!(contact.kernel_calls, base.kernel_calls + 10 * (1 + 4));
    assert_eq!(friction.kernel_calls, contact.kernel_calls);
    assert_eq!(removed.control_of.as_ref(), Some(&contact.label));
    assert_eq!(removed.same_plan, Some(true), "{}", removed.label);
    assert_eq!(removed.same_schedule, Some(true), "{}", removed.label);
    assert_eq!(
        (removed.stages.as_str(), removed.kernel_calls),
        (base.stages.as_str(), base.kernel_calls)
    );
    assert_eq!(explicit.control_of.as_ref(), Some(&base.label));
    assert_eq!(explicit.same_plan, Some(true), "{}", explicit.label);
    assert_eq!(barrier.stages, "minimise");
    assert_eq!(barrier.kernel_calls, 1);
    assert_eq!(barrier.versus.as_ref(), Some(&base.label));
    assert!(barrier.control_of.is_none() && barrier.same_plan.is_none());
    for row in &balls {
        for (backend, t) in &row.ms {
            let ran = *backend == BackendKind::Cpu || gpu_ran(report);
            assert!(
                !ran || t.is_some_and(|t| t > 0.0),
                "{} on {}: {t:?}",
                row.label,
                backend.name()
            );
        }
    }
}

/// The comparisons the controls rest on can fail: a plan differing in one
/// radius is not "the collision plan minus Broadphase and Collide", and
/// the barrier plan is not the XPBD plan.
#[test]
fn control_comparisons_discriminate() {
    let base = granular_effects::balls(2, 3);
    let plan = |s: &Scene| Plan::compile(s).expect("compiles");
    let mut contact = base.clone();
    contact.collisions = Some(Collisions {
        friction: 0.0,
        margin: granular_effects::MARGIN,
    });
    let stripped = granular_effects::without_collisions(&plan(&contact));
    assert_eq!(stripped, plan(&base));
    assert!(
        plan(&contact)
            .substep_kernels
            .iter()
            .any(|k| matches!(k, Kernel::Broadphase))
    );
    let mut other = base.clone();
    other.particles[0].radius *= 0.5;
    assert_ne!(stripped, plan(&other));
    // Omitted vs explicit "xpbd", through the JSON a user writes.
    let json = base.to_json_string();
    assert!(!json.contains("\"solver\""), "xpbd is the omitted default");
    let mut value: serde_json::Value = serde_json::from_str(&json).expect("json");
    value["solver"] = serde_json::json!({ "type": "xpbd" });
    let explicit = Scene::from_json_str(&value.to_string()).expect("explicit xpbd parses");
    assert_eq!(plan(&explicit), plan(&base));
    let barrier = plan(&granular_effects::barrier(&base));
    assert_ne!(barrier, plan(&base));
    assert_eq!(barrier.substep_kernels, vec![Kernel::Minimise]);
}

/// `--only-effects` writes effects.md, effects.json and the README's
/// effect lines, and leaves accuracy.md and the rest of the README alone.
#[test]
fn effects_only_run_leaves_the_rest_of_the_report_alone() {
    let dir = out_dir().with_extension("effects-only");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("temp dir");
    let accuracy = dir.join("accuracy.md");
    std::fs::write(&accuracy, "full report, untouched\n").expect("sentinel");
    let readme = dir.join("README.md");
    let before = format!(
        "# P\n\n{README_BEGIN}\nheadline kept\n{EFFECTS_BEGIN}\nold effect lines\n{EFFECTS_END}\nfooter kept\n{README_END}\n\n## After\n"
    );
    std::fs::write(&readme, &before).expect("readme");
    let mut config = Config::quick(&dir);
    config.readme = Some(readme.clone());
    config.progress = false;
    config.effects_only = true;
    config.backends = vec![BackendKind::Cpu];
    config.effects_n = 4;
    config.effects_balls = (2, 2);
    config.effects_ball_steps = 2;
    config.time_target = 0.001;
    let report = run(&config).unwrap_or_else(|e| panic!("effects-only run failed: {e}"));
    assert!(report.cases.is_empty() && report.scaling.is_empty());
    assert_eq!(report.effects.len(), 15);
    assert_eq!(
        std::fs::read_to_string(&accuracy).expect("accuracy.md"),
        "full report, untouched\n"
    );
    assert!(!dir.join("figures/accuracy.json").exists());
    assert!(dir.join("effects.md").is_file() && dir.join("figures/effects.json").is_file());
    let after = std::fs::read_to_string(&readme).expect("readme");
    assert!(!after.contains("old effect lines"), "{after}");
    assert!(after.contains("- Particle–particle collisions"), "{after}");
    assert!(after.contains("(a different solver, not an added effect)"));
    let outside = |t: &str| {
        let a = t.find(EFFECTS_BEGIN).expect("begin");
        let b = t.find(EFFECTS_END).expect("end");
        format!("{}{}", &t[..a], &t[b..])
    };
    assert_eq!(outside(&after), outside(&before));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn scaling_is_measured_and_fitted() {
    let Some((report, _)) = report(&common::gpu::test_name(
        module_path!(),
        "scaling_is_measured_and_fitted",
    )) else {
        return; // run in the child with LP_NUM_THREADS=0
    };
    let cpu: Vec<_> = report
        .scaling
        .iter()
        .filter(|p| p.backend == BackendKind::Cpu)
        .collect();
    assert_eq!(cpu.len(), 2);
    assert!(cpu.iter().all(|p| p.ms_per_step.is_some_and(|t| t > 0.0)));
    let fit = report
        .fits
        .iter()
        .find(|f| f.backend == BackendKind::Cpu)
        .expect("cpu fit");
    // The fit is the least-squares power law of exactly the measured
    // points (the fit itself is checked on exact data below). Its value
    // depends on the machine's load, so no range is asserted here: a timed
    // test would fail under load without any bug.
    let xy: Vec<(f64, f64)> = cpu
        .iter()
        .map(|p| (p.particles as f64, p.ms_per_step.expect("measured")))
        .collect();
    let (exponent, prefactor) = fit_power_law(&xy).expect("two sizes fit");
    assert_eq!(fit.points, 2);
    assert_eq!(fit.exponent.to_bits(), exponent.to_bits());
    assert_eq!(fit.prefactor_ms.to_bits(), prefactor.to_bits());
    assert!(fit.exponent.is_finite() && fit.prefactor_ms > 0.0);
}

#[test]
fn power_law_fit_recovers_exact_exponent() {
    let xy: Vec<(f64, f64)> = [1e3, 4e3, 1.6e4, 6.4e4]
        .iter()
        .map(|&x: &f64| (x, 0.02 * x.powf(0.85)))
        .collect();
    let (b, a) = fit_power_law(&xy).expect("fit");
    assert!(
        (b - 0.85).abs() < 1e-12 && (a - 0.02).abs() < 1e-12,
        "b {b}, a {a}"
    );
    assert!(fit_power_law(&[(1.0, 1.0)]).is_none());
}

#[test]
fn zero_crossings_of_a_sampled_sine_are_exact_to_interpolation_order() {
    let (omega, dt) = (3.0, 1.0 / 60.0);
    let y: Vec<f64> = (0..400)
        .map(|k| (omega * k as f64 * dt + 0.3).sin())
        .collect();
    let crossings = zero_crossings(&y, dt);
    assert!(crossings.len() >= 6);
    for (j, c) in crossings.iter().enumerate() {
        let exact = ((j + 1) as f64 * std::f64::consts::PI - 0.3) / omega;
        // Cubic interpolation: error O((ω dt)^4 dt) ≈ 1e-8 s here.
        assert!((c - exact).abs() < 1e-7, "crossing {j}: {c} vs {exact}");
    }
}

#[test]
fn frontier_keeps_only_undominated_points() {
    let Some((report, _)) = report(&common::gpu::test_name(
        module_path!(),
        "frontier_keeps_only_undominated_points",
    )) else {
        return; // run in the child with LP_NUM_THREADS=0
    };
    let template = report.cases[0].points[0].clone();
    let mk = |t: f64, e: f64| Point {
        ms_per_sim_second: t,
        error: Some(e),
        backend: BackendKind::Cpu,
        ..template.clone()
    };
    let pts = vec![
        mk(1.0, 1e-1),
        mk(2.0, 2e-1),
        mk(3.0, 1e-2),
        mk(3.0, 5e-3),
        mk(10.0, 1e-2),
        mk(20.0, 1e-4),
    ];
    assert_eq!(frontier(&pts, BackendKind::Cpu), vec![0, 3, 5]);
    // A frozen point is never on a frontier, however small its error.
    let mut frozen = pts.clone();
    frozen.push(Point {
        frozen: true,
        ..mk(2.5, 1e-9)
    });
    assert_eq!(frontier(&frozen, BackendKind::Cpu), vec![0, 3, 5]);
    assert!(frontier(&pts, BackendKind::Gpu(Precision::F64)).is_empty());
}
