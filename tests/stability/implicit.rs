//! The stability cases that make sense on the coupled implicit step
//! (`incremental_potential` with constraint families, collisions, plane
//! friction or an explicit warm start; docs/implicit.md §11–§12), on the
//! CPU golden path and on the GPU (`GpuCoupledBackend`, docs/implicit.md
//! §12): every case the GPU runs is held to the CPU's asserted bounds; on
//! gpu-f64 and lavapipe (`common::exact::f64_identical`) it is
//! bit-identical to the CPU run after every step, and on gpu-f32 every
//! step is checked against a CPU probe restarted from the f32 state with
//! the residual-driven bound of `hyperpbd_verify::compare_coupled` where it is
//! stated (`common::coupled_f32`), gaps > 0, the energy at ε₃₂ and f32's
//! own bound where a case's bound is a rounding one. The Neo-Hookean drop
//! (`implicit_material_drop`) runs on gpu-f64 in lockstep, bit for bit on
//! lavapipe, and asserts gpu-f32's typed refusal, `GpuError::Unsupported`
//! (material families are f64-only on the GPU). Rigid links (compliance 0) are no energy there, so each chain's
//! links are stiff springs instead; everything else is the XPBD case's
//! scene.
//!
//! Not run on this path, and why:
//! - `rigid_cloth_100_iterations`: its subject is XPBD's iteration count
//!   over rigid (α = 0) springs, refused under this solver;
//! - `oriented_near_degenerate`, `oriented_inverted`: their subject is
//!   XPBD's measure projection (Δλ through a vanishing |∇C|); here a
//!   measure family is a Gauss–Newton spring (docs/implicit.md §2), and
//!   inversion is the materials' business (`implicit_material_drop`);
//! - `oriented_zero_rest_refused`: a validation refusal independent of the
//!   solver;
//! - `fast_impact_xpbd`: XPBD's contact projection; the barrier path's
//!   impact is `implicit_material_drop` here and the head-on balls of
//!   tests/implicit/step.rs (and tests/gpu/coupled/);
//! - `nine_dimensions`: the GPU's dimension limit (the CPU step is generic,
//!   `implicit_eight_dimensions` runs it in R^8);
//! - `far_offset_1e3`: `implicit_far_offset_1e5` is the harder one.
//!
//! `implicit_on_hyperplane_is_refused` is a validation refusal: no backend
//! is loaded.
//!
//! Every case that loads a GPU backend runs on one lavapipe thread
//! (`common::gpu::on_one_lavapipe_thread`: a child process with
//! `LP_NUM_THREADS=0` unless the variable is set): the coupled step waits
//! on the host hundreds of times per step, and lavapipe's worker pool
//! adds 35–63 µs to each of its many small dispatches (~1 µs on the
//! submitting thread).
//!
//! Energy: the suite's E (kinetic and gravity) cannot rise unless stored
//! elastic or barrier energy is released (backward Euler with lagged
//! friction dissipates), so a case that starts unstressed and outside
//! every barrier's activation distance is held to the suite's rounding
//! bound with nothing released.

use super::*;
use common::coupled_f32::F32Check;
use common::exact::{bits, f64_identical};
use common::gpu::{on_one_lavapipe_thread, test_name};
use hyperpbd::{Collisions, Convergence, IncrementalPotentialSettings, Solver, WarmStart};

/// The implicit solver: barrier κ, d^, the acceleration criterion
/// `tolerance` (m/s²), 50 Newton iterations.
fn implicit(stiffness: f64, activation: f64, tolerance: f64) -> Solver {
    Solver::IncrementalPotential(IncrementalPotentialSettings {
        barrier_stiffness: stiffness,
        activation_distance: activation,
        convergence: Convergence::MaxAccelerationResidual { tolerance },
        max_iterations: 50,
        cg_iterations: None,
        warm_start: None,
        friction_slip_velocity: None,
    })
}

/// Loads `scene` on the CPU.
fn cpu(case: &str, scene: &Scene) -> (Box<dyn Backend>, State) {
    start(case, BackendKind::Cpu, scene).expect("the CPU always runs")
}

/// Asserts that `kind` refuses `scene` with `GpuError::Unsupported` naming
/// `why` (nothing to assert when the GPU test is skipped).
fn refused_on(case: &str, kind: BackendKind, scene: &Scene, why: &str) {
    let plan = Plan::compile(scene).unwrap_or_else(|e| panic!("{case}: {e}"));
    match load_or_skip(case, kind, plan, &State::from_scene(scene)) {
        Ok(None) => {}
        Ok(Some(_)) => panic!(
            "{case} ({}): loaded, expected a refusal ({why})",
            kind.name()
        ),
        Err(error) => {
            assert!(
                matches!(&error, BackendError::Gpu(GpuError::Unsupported { what })
                    if what.contains("coupled implicit step") && what.contains(why)),
                "{case} ({}): {error:?}",
                kind.name()
            );
            report(
                case,
                kind,
                "refused: GpuError::Unsupported",
                "-",
                0.0,
                &format!("{error}"),
            );
        }
    }
}

/// Folds one step's measurement into the run's (maxima over the steps,
/// the last step's final residual and state).
fn fold(run: Option<Measured>, step: Measured) -> Measured {
    match run {
        None => step,
        Some(before) => Measured {
            energy_gain: step.energy_gain.max(before.energy_gain),
            energy_scale: step.energy_scale.max(before.energy_scale),
            residual: step.residual.max(before.residual),
            measure_residual: step.measure_residual.max(before.measure_residual),
            ..step
        },
    }
}

/// The largest link violation at `state`: |ℓ − rest| of a distance
/// element, max(0, ℓ − rest) of a tether (cpu/src/residual.rs, the same
/// arithmetic), measured on each run's own state; it reproduces the CPU's
/// reported value bit for bit (asserted on every CPU step), and
/// tests/gpu/coupled/ holds `GpuCoupledBackend`'s reported residuals to
/// the CPU's.
fn link_residual(plan: &Plan, state: &State) -> f64 {
    let n = plan.dim;
    let x = &state.positions;
    let mut worst: f64 = 0.0;
    for family in &plan.families {
        let tether = family.kind == FamilyKind::Tether;
        if !tether && family.kind != FamilyKind::Distance {
            continue;
        }
        for (ends, &rest) in family.elements.chunks_exact(2).zip(&family.rest) {
            let (i, j) = (ends[0] as usize, ends[1] as usize);
            let mut d2 = 0.0;
            for a in 0..n {
                let e = x[j * n + a] - x[i * n + a];
                d2 += e * e;
            }
            let c = d2.sqrt() - rest;
            worst = worst.max(if tether { c.max(0.0) } else { c.abs() });
        }
    }
    worst
}

/// Runs `scene` `steps` steps on the CPU and, in lockstep, on gpu-f64 and
/// gpu-f32 (each unless its GPU test is skipped); on lavapipe asserts that
/// every gpu-f64 state is the CPU's bit for bit, and checks every gpu-f32
/// step with `common::coupled_f32::F32Check` (a CPU probe restarted from
/// the f32 state: the residual-driven bound where it is stated, gaps > 0,
/// finite values). The measurements, CPU first; each case then holds
/// every backend to its own bounds (energy at the backend's ε).
fn on_cpu_and_gpu(case: &str, scene: &Scene, steps: usize) -> Vec<(BackendKind, Measured)> {
    lockstep(case, scene, steps, false, true)
}

/// [`on_cpu_and_gpu`]; with `f32_may_stall`, a gpu-f32 step refused as
/// `NoDescent` ends the f32 run (asserted: the state rolled back byte for
/// byte, reported) instead of failing: a contact squeezed to within f32's
/// certified rounding of its plane admits no certified motion
/// (docs/implicit.md §12). Without `with_f32`, gpu-f32's typed refusal
/// (a material family) is asserted instead of an f32 run.
fn lockstep(
    case: &str,
    scene: &Scene,
    steps: usize,
    f32_may_stall: bool,
    with_f32: bool,
) -> Vec<(BackendKind, Measured)> {
    let plan = Plan::compile(scene).unwrap_or_else(|e| panic!("{case}: {e}"));
    let (mut golden, initial) = cpu(case, scene);
    let mut gpu = adapter_or_skip(case, Precision::F64).map(|(adapter, summary)| {
        let backend = hyperpbd::load_on_adapter(&adapter, plan.clone(), &initial, Precision::F64)
            .unwrap_or_else(|e| panic!("{case} (gpu-f64): {e}"));
        (backend, f64_identical(&summary))
    });
    if !with_f32 {
        refused_on(case, GPU_F32, scene, "the material family");
    }
    let f32_adapter = with_f32
        .then(|| adapter_or_skip(case, Precision::F32))
        .flatten();
    let mut single = f32_adapter.map(|(adapter, _)| {
        let backend = hyperpbd::load_on_adapter(&adapter, plan.clone(), &initial, Precision::F32)
            .unwrap_or_else(|e| panic!("{case} (gpu-f32): {e}"));
        (backend, F32Check::new(&plan, &initial))
    });
    let (mut on_cpu, mut on_gpu, mut on_f32) = (None, None, None);
    let mut worst = 0.0f64;
    let mut stalled = None;
    for step in 0..steps {
        let a = run(case, golden.as_mut(), &initial, 1);
        assert_eq!(
            a.final_residual.to_bits(),
            link_residual(&plan, &a.last).to_bits(),
            "{case}: step {step}: link_residual is not the CPU's residual"
        );
        if let Some((backend, exact)) = gpu.as_mut() {
            let mut b = run(case, backend.as_mut(), &initial, 1);
            b.residual = link_residual(&plan, &b.last);
            b.final_residual = b.residual;
            let dx = hyperpbd_verify::compare::max_abs_diff(&a.last.positions, &b.last.positions);
            worst = worst.max(dx);
            assert!(
                !*exact || bits(&a.last) == bits(&b.last),
                "{case}: step {step}: the gpu-f64 state differs from the golden path \
                 (max |dx| = {dx:e}, max |dv| = {:e})",
                hyperpbd_verify::compare::max_abs_diff(&a.last.velocities, &b.last.velocities)
            );
            on_gpu = Some(fold(on_gpu, b));
        }
        if let Some((backend, check)) = single.as_mut().filter(|_| stalled.is_none()) {
            let before = backend.read_state().expect("gpu-f32 state");
            match try_run(case, backend.as_mut(), &initial, 1) {
                Ok(mut c) => {
                    c.residual = link_residual(&plan, &c.last);
                    c.final_residual = c.residual;
                    check.step(case, &before, &c.last);
                    on_f32 = Some(fold(on_f32, c));
                }
                Err((_, e)) if f32_may_stall && e.to_string().contains("no decrease") => {
                    let after = backend.read_state().expect("gpu-f32 state");
                    assert!(
                        bits(&before) == bits(&after),
                        "{case}: gpu-f32 step {step} refused without rolling back"
                    );
                    stalled = Some((step, e.to_string()));
                }
                Err((_, e)) => panic!("{case} (gpu-f32): step {step}: {e}"),
            }
        }
        on_cpu = Some(fold(on_cpu, a));
    }
    let mut out = vec![(
        BackendKind::Cpu,
        on_cpu.unwrap_or_else(|| run(case, golden.as_mut(), &initial, 0)),
    )];
    if let Some((mut backend, exact)) = gpu {
        let rule = if exact {
            "0: lavapipe, bit-identical to cpu-f64 after every step"
        } else {
            "not asserted: this adapter may contract a·b + c; the case's bounds apply"
        };
        report(case, GPU_F64, "ok", "max |x_gpu − x_cpu| (m)", worst, rule);
        let measured = on_gpu.unwrap_or_else(|| run(case, backend.as_mut(), &initial, 0));
        out.push((GPU_F64, measured));
    }
    if let Some((mut backend, check)) = single {
        report_f32(case, &check);
        if let Some((step, why)) = &stalled {
            report(
                case,
                GPU_F32,
                &format!("refused at step {step} of {steps} (typed, rolled back)"),
                "steps run",
                *step as f64,
                why,
            );
        }
        let measured = on_f32.unwrap_or_else(|| run(case, backend.as_mut(), &initial, 0));
        out.push((GPU_F32, measured));
    }
    out
}

/// The `STABLE` line of a gpu-f32 run's per-step check.
fn report_f32(case: &str, check: &F32Check) {
    let (value, metric) = match check.unbounded {
        Some(_) => (check.largest, "max |x_gpu − x_cpu| per step (m)"),
        None => (check.worst.0, "per step |x_gpu − x_cpu| / residual bound"),
    };
    report(case, GPU_F32, "ok", metric, value, &check.describe());
}

/// `mass_ratio_chain` on this path: 10 links of 0.1 m from a fixed point,
/// 1 kg particles and a 1e6 kg weight at the end, links of compliance
/// 1e-12 m/N (the weight's 9.8e6 N stretches the top link by 9.8e-6 m),
/// one minimisation per 1/60 s, 2 s, hanging and released horizontally.
/// Newton moves the weight and the light links together: no tethers.
#[test]
fn implicit_mass_ratio_chain() {
    if !on_one_lavapipe_thread(&test_name(module_path!(), "implicit_mass_ratio_chain")) {
        return;
    }
    for (case, direction) in [
        ("implicit_mass_ratio_chain (hanging)", vec![0.0, -1.0]),
        ("implicit_mass_ratio_chain (swinging)", vec![1.0, 0.0]),
    ] {
        let mut b = SceneBuilder::new(2).dt(1.0 / 60.0).gravity_along(1, 9.81);
        let grid = b.chain(&ChainSpec {
            start: vec![0.0, 0.0],
            direction,
            count: 11,
            spacing: 0.1,
            mass: 1.0,
            compliance: 1e-12,
            fix_first: true,
        });
        b.scene_mut().particles[grid.first + 10].mass = Some(1e6);
        b.scene_mut().solver = implicit(1e3, 1e-3, 1e-2);
        let scene = b.build().expect("valid");
        for (kind, m) in on_cpu_and_gpu(case, &scene, 120) {
            check_energy(
                case,
                kind,
                &m,
                0.0,
                "dissipative: starts at rest, unstretched",
            );
            check_residual(
                case,
                kind,
                "max |C| (m)",
                m.residual,
                1e-3,
                "1% of the 0.1 m link, no tethers (XPBD: 3.5 m)",
            );
        }
    }
}

/// `swinging_chain` of large_steps.rs on this path: a 10-link chain (0.1
/// kg, links of compliance 1e-8 m/N) released horizontally above a ground
/// plane with μ = 0.3, one minimisation per step of `dt`.
fn swinging_chain(dt: f64, offset: f64) -> Scene {
    let mut b = SceneBuilder::new(3).dt(dt).gravity_along(1, 9.81);
    b.chain(&ChainSpec {
        start: vec![offset, 0.5 + offset, offset],
        direction: vec![1.0, 0.0, 0.2],
        count: 11,
        spacing: 0.1,
        mass: 0.1,
        compliance: 1e-8,
        fix_first: true,
    });
    b.hyperplane(vec![0.0, 1.0, 0.0], offset, 0.3);
    b.scene_mut().solver = implicit(1e3, 1e-3, 1e-2);
    b.build().expect("valid")
}

/// Runs the swinging `scene` `steps` steps on the CPU and gpu-f64 and
/// checks the suite's energy (dissipative: it starts at rest, unstretched,
/// above d^) and links within 1 % of their 0.1 m on each.
fn chain_case(case: &str, scene: &Scene, steps: usize) -> Vec<(BackendKind, Measured)> {
    chain_case_with(case, scene, steps, false)
}

/// [`chain_case`] with [`lockstep`]'s `f32_may_stall`.
fn chain_case_with(
    case: &str,
    scene: &Scene,
    steps: usize,
    f32_may_stall: bool,
) -> Vec<(BackendKind, Measured)> {
    let runs = lockstep(case, scene, steps, f32_may_stall, true);
    for (kind, m) in &runs {
        check_energy(case, *kind, m, 0.0, "dissipative: starts at rest");
        check_residual(
            case,
            *kind,
            "max |C| (m)",
            m.residual,
            1e-3,
            "1% of the 0.1 m link",
        );
    }
    runs
}

mod large_and_odd_steps;
