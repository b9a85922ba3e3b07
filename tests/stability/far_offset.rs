//! Far from the origin: the rope bridge at 1e3 and 1e5, and the f32
//! scene origin that keeps it accurate there.

use super::*;

on_every_backend!(far_offset_1e3, far_offset_1e5,);

/// The rope bridge of `scenes::chain2d` (21 particles, rigid links,
/// ground plane, damping) translated by (d, d).
fn offset_bridge(d: f64) -> Scene {
    let mut scene = hyperpbd::scenes::chain2d();
    for p in &mut scene.particles {
        for c in &mut p.position {
            *c += d;
        }
    }
    for o in &mut scene.obstacles {
        let hyperpbd::Obstacle::Hyperplane { normal, offset, .. } = o else {
            unreachable!("chain2d has only hyperplane obstacles");
        };
        // n = (0, 1): the ground moves up by d with the scene.
        *offset += normal[1] * d;
    }
    scene
}

/// Positions relative to (d, d) of `state`.
fn relative(state: &State, d: f64) -> Vec<f64> {
    state.positions.iter().map(|x| x - d).collect()
}

/// The bridge at offset `d` against the CPU run of the same bridge at the
/// world origin, 60 frames; on gpu-f32 also without the scene-origin
/// remedy, to show what it buys.
fn far_offset(case: &str, kind: BackendKind, d: f64) {
    let frames = 60;
    let near = offset_bridge(0.0);
    let mut golden = CpuBackend::new(
        Plan::compile(&near).expect("valid"),
        &State::from_scene(&near),
    )
    .expect("cpu");
    for _ in 0..frames {
        golden.step().expect("golden step");
    }
    let golden = golden.read_state().expect("read");
    let scene = offset_bridge(d);
    let Some((mut backend, initial)) = start(case, kind, &scene) else {
        return;
    };
    let m = run(case, backend.as_mut(), &initial, frames);
    check_energy(case, kind, &m, 0.0, "damped bridge");
    let error = hyperpbd_verify::compare::max_abs_diff(&relative(&m.last, d), &golden.positions);
    // The bridge at the origin in this backend's precision, against the
    // same golden run: what the precision costs without any offset.
    let plan = Plan::compile(&scene).expect("valid");
    let model = hyperpbd_verify::compare::ErrorModel::new(
        &plan,
        match kind {
            GPU_F32 => hyperpbd::Precision::F32,
            _ => hyperpbd::Precision::F64,
        },
    );
    // Coordinates of the bridge relative to its own origin are ≤ 2 m; the
    // offset itself is carried exactly in f64 (ε64 · d per rounding).
    let local_scale = 2.0;
    let bound = model.position_bound(local_scale, frames as u64)
        + hyperpbd_verify::compare::ErrorModel::new(&plan, hyperpbd::Precision::F64)
            .position_bound(d + local_scale, frames as u64);
    check_residual(
        case,
        kind,
        "|x − d − x_golden(origin)| (m)",
        error,
        bound,
        "ErrorModel at the scene's own 2 m scale + f64 model at d",
    );
    check_residual(
        case,
        kind,
        "max |C| (m)",
        m.residual,
        0.01 * 0.1,
        "1% of the 0.1 m link",
    );
    if kind == GPU_F32 {
        let Some((adapter, _)) = adapter_or_skip(case, Precision::F32) else {
            return;
        };
        // The reference: the same bridge at the world origin in f32.
        let mut at_origin = GpuBackend::with_adapter(
            &adapter,
            Plan::compile(&near).expect("valid"),
            &State::from_scene(&near),
            Precision::F32,
        )
        .expect("gpu");
        for _ in 0..frames {
            at_origin.step().expect("f32 step at the origin");
        }
        let origin_error = hyperpbd_verify::compare::max_abs_diff(
            &at_origin.read_state().expect("read").positions,
            &golden.positions,
        );
        report(
            case,
            kind,
            "reference: the bridge at the world origin",
            "|x − x_golden| (m)",
            origin_error,
            "not asserted; what f32 costs with no offset at all",
        );
        // Without the remedy: positions stored in world coordinates.
        let mut raw = GpuBackend::with_options(
            &adapter,
            plan.clone(),
            &initial,
            Precision::F32,
            XpbdOptions::origin(SceneOrigin::zero(plan.dim)),
        )
        .expect("gpu");
        let mut failed = None;
        for f in 0..frames {
            if let Err(e) = raw.step() {
                failed = Some(format!("frame {f}: {e}"));
                break;
            }
        }
        let raw_state = raw.read_state().expect("read");
        let raw_error =
            hyperpbd_verify::compare::max_abs_diff(&relative(&raw_state, d), &golden.positions);
        report(
            case,
            kind,
            "without the scene origin (f32 world coordinates)",
            "|x − d − x_golden(origin)| (m)",
            raw_error,
            &format!(
                "not asserted; ulp({d:e}) = {:.1e} m{}",
                f64::from(ulp32(d as f32)),
                failed.map_or(String::new(), |e| format!("; {e}"))
            ),
        );
    }
}

/// Spacing of f32 values at `x`.
fn ulp32(x: f32) -> f32 {
    f32::from_bits(x.to_bits() + 1) - x
}

fn far_offset_1e3(kind: BackendKind) {
    far_offset("far_offset_1e3", kind, 1e3);
}

fn far_offset_1e5(kind: BackendKind) {
    far_offset("far_offset_1e5", kind, 1e5);
}

/// `write_state` and `read_state` go through the same scene origin: a
/// state written at 1e5 m reads back with the f32 rounding of the *local*
/// coordinates (|x − o| ≤ 2 m: ≤ ulp(2)/2 = 1.2e-7 m), not of 1e5 m
/// (3.9e-3 m).
#[test]
fn f32_state_round_trips_through_the_scene_origin() {
    let Some((adapter, _)) = adapter_or_skip("f32_state_round_trips", Precision::F32) else {
        return;
    };
    let d = 1e5;
    let scene = offset_bridge(d);
    let plan = Plan::compile(&scene).expect("valid");
    let initial = State::from_scene(&scene);
    let mut gpu = GpuBackend::with_adapter(&adapter, plan, &initial, Precision::F32).expect("gpu");
    assert!(!gpu.origin().is_zero(), "a scene at 1e5 gets an origin");
    let mut written = initial.clone();
    for (i, x) in written.positions.iter_mut().enumerate() {
        *x += 1e-3 * (i % 7) as f64;
    }
    gpu.write_state(&written).expect("write");
    let back = gpu.read_state().expect("read");
    let error = hyperpbd_verify::compare::max_abs_diff(&back.positions, &written.positions);
    let bound = f64::from(ulp32(2.0)) / 2.0;
    print_bound(
        "f32 write/read at 1e5",
        format_args!("{error:.3e}"),
        format_args!("{bound:.3e}"),
        "ulp(2 m)/2: local coordinates",
    );
    assert!(error <= bound, "{error:e} > {bound:e}");
}
