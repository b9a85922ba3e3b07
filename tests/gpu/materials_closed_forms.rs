//! The closed-form validations of tests/materials/closed_forms.rs on the
//! GPU, with the same scene builders (`common::materials`):
//!
//! ```text
//! uniaxial stretch   free–free bar under P = 0.1 E, 2D and 3D, both laws,
//!                    300 frames of 10 substeps × 4 iterations
//! patch test         4 × 4 (2D), 3³ (3D), 3⁴ (4D) Kuhn cells, both laws,
//!                    300 frames of 5 substeps × 3 iterations
//! gpu-f64            the settled state equal to the golden path's bit for
//!                    bit (common::exact: lavapipe; elsewhere the closed-form
//!                    check below applies instead)
//! gpu-f32 stretch    the same closed-form tolerance as the CPU: strains
//!                    within 2 %
//! gpu-f32 patch      every frame within the per-frame model
//!                    (common::differential, asserted); the 1e-4 of the
//!                    closed form is NOT reachable in f32 and is printed,
//!                    not asserted (below)
//! ```
//! Why the f32 patch stops short: the patch is soft (E = 1 Pa, 1 kg nodes,
//! h = 0.01 s), so a projection pulls a node δ off the affine map back by
//! about w h² K δ ≈ 4e-5 δ (K ≈ 0.4 N/m per element), while each of its
//! per-element moves (~1e-6 at the map, where every element is stressed)
//! rounds by up to half an ulp of the coordinate (≈ 6e-8); for δ ≲ 1e-3 the
//! roundings win and the f32 state freezes (velocities exactly 0) at
//! δ ≈ 1e-3 (2D) … 8e-3 (4D). A stiffer patch does not help: at E = 1000 Pa (2D stvk, measured)
//! the f32 run follows the golden path (1.011e-3 against 1.010e-3), but the
//! golden path itself then settles 1.0e-3 off the map (XPBD's
//! finite-iteration offset with 3 iterations grows with the stiffness).
//! Each prints `BOUND | name | measured | bound | rationale`.
//!
//! Every test runs on one lavapipe thread (`common::gpu::on_one_lavapipe_thread`:
//! a child process with `LP_NUM_THREADS=0` unless the variable is set):
//! 300 frames × 5 substeps × 3 iterations over the 4D patch's 157 colours
//! are ~700 000 projection dispatches (one per colour) per run, 35–63 µs
//! each on lavapipe's worker pool and ~1 µs on the submitting thread; one
//! test per patch (the 4D one per law) and per uniaxial dimension lets the
//! test threads share them. In CI this binary took 205 s with the pool and
//! one patch test, 87 s on one thread with one test per patch. The patches
//! leave out their all-fixed elements (`common::materials::patch`: the
//! same states bit for bit, 41 % fewer elements in 4D).

use crate::common;

use common::bound::{check_bound, print_bound};
use common::differential::differential;
use common::exact::assert_identical_if_claimed;
use common::gpu::{adapter_or_skip, on_one_lavapipe_thread, test_name};
use common::materials::{check_uniaxial, kind_of, patch, patch_error, uniaxial_bar};
use hyperpbd::core::material::Law;
use hyperpbd::{Backend, CpuBackend, Plan, Scene, State};
use hyperpbd_gpu::{GpuBackend, Precision};

const FRAMES: usize = 300;

/// The state after `FRAMES` frames of `scene` on the golden path.
fn golden(scene: &Scene) -> State {
    let plan = Plan::compile(scene).expect("valid scene");
    let mut cpu = CpuBackend::new(plan, &State::from_scene(scene)).expect("cpu");
    for _ in 0..FRAMES {
        cpu.step().expect("cpu step");
    }
    cpu.read_state().expect("cpu state")
}

/// Runs `scene` on the GPU at both precisions (or only `only`):
/// `check(name, state)` on the f32 state; the f64 state bit for bit the
/// golden one where the adapter promises it, else `check` on it too.
fn on_gpu(
    test: &str,
    name: &str,
    scene: &Scene,
    only: Option<Precision>,
    check: &dyn Fn(&str, &State),
) {
    let plan = Plan::compile(scene).expect("valid scene");
    let start = State::from_scene(scene);
    let mut golden_state = None;
    for precision in [Precision::F64, Precision::F32] {
        if only.is_some_and(|p| p != precision) {
            continue;
        }
        let Some((adapter, summary)) = adapter_or_skip(test, precision) else {
            return;
        };
        let mut gpu = GpuBackend::with_adapter(&adapter, plan.clone(), &start, precision)
            .unwrap_or_else(|e| panic!("{name} {precision}: GPU backend: {e}"));
        for frame in 0..FRAMES {
            gpu.step()
                .unwrap_or_else(|e| panic!("{name} {precision}: GPU step {frame}: {e}"));
        }
        let state = gpu.read_state().expect("gpu state");
        let label = format!("{name} gpu-{precision}");
        if precision == Precision::F64 {
            let golden_state = golden_state.get_or_insert_with(|| golden(scene));
            if assert_identical_if_claimed(&summary, &label, golden_state, &state) {
                common::bound::print_bound(
                    format_args!("{label} settled state vs golden path"),
                    0,
                    "exact",
                    "f64 on llvmpipe: bit-identical",
                );
                continue;
            }
        }
        check(&label, &state);
    }
}

/// The uniaxial stretch of the bar in `dim` dimensions for both laws on
/// the GPU (`test` is the calling test's name).
fn uniaxial_on_the_gpu(test: &str, dim: usize) {
    if !on_one_lavapipe_thread(&test_name(module_path!(), test)) {
        return;
    }
    for law in [Law::StVenantKirchhoff, Law::NeoHookean] {
        on_gpu(
            test,
            &format!("uniaxial {law} {dim}D"),
            &uniaxial_bar(law, dim),
            None,
            &|label, state| check_uniaxial(label, law, dim, state),
        );
    }
}

#[test]
fn uniaxial_stretch_2d_on_the_gpu_matches_the_closed_form() {
    uniaxial_on_the_gpu("uniaxial_stretch_2d_on_the_gpu_matches_the_closed_form", 2);
}

#[test]
fn uniaxial_stretch_3d_on_the_gpu_matches_the_closed_form() {
    uniaxial_on_the_gpu("uniaxial_stretch_3d_on_the_gpu_matches_the_closed_form", 3);
}

/// The patch test of `cells` for each of `laws` on the GPU (`test` is the
/// calling test's name).
fn patch_on_the_gpu(test: &str, cells: &[usize], laws: &[Law]) {
    if !on_one_lavapipe_thread(&test_name(module_path!(), test)) {
        return;
    }
    for &law in laws {
        let (scene, interior) = patch(kind_of(law), cells);
        let name = format!("patch test {law} {}D", cells.len());
        // f64: the golden path's settled state bit for bit (or, off
        // lavapipe, the closed-form tolerance).
        on_gpu(
            test,
            &name,
            &scene,
            Some(Precision::F64),
            &|label, state| {
                check_bound(
                    &format!("{label} interior error / element size"),
                    patch_error(state, &interior),
                    1e-4,
                    "issue 15: interior nodes back on the affine map to 1e-4 of the element size",
                )
            },
        );
        // f32: every frame within the per-frame model (asserted); the
        // closed form is not reachable (module docs), so its error is
        // printed beside the 1e-4 the golden path meets, unasserted.
        let Some((adapter, summary)) = adapter_or_skip(test, Precision::F32) else {
            return;
        };
        let state = differential(
            &adapter,
            &summary,
            &name,
            &scene,
            FRAMES as u64,
            Precision::F32,
        );
        print_bound(
            format_args!("{name} gpu-f32 interior error / element size"),
            format_args!("{:e}", patch_error(&state, &interior)),
            "1e-4 NOT MET, not asserted",
            "f32 stagnation: the pull back w h² K δ ≈ 4e-5 δ per projection loses to half-ulp roundings of the moves for δ ≲ 1e-3",
        );
    }
}

#[test]
fn patch_test_2d_on_the_gpu_returns_to_the_affine_map() {
    patch_on_the_gpu(
        "patch_test_2d_on_the_gpu_returns_to_the_affine_map",
        &[4, 4],
        &[Law::StVenantKirchhoff, Law::NeoHookean],
    );
}

#[test]
fn patch_test_3d_on_the_gpu_returns_to_the_affine_map() {
    patch_on_the_gpu(
        "patch_test_3d_on_the_gpu_returns_to_the_affine_map",
        &[3, 3, 3],
        &[Law::StVenantKirchhoff, Law::NeoHookean],
    );
}

#[test]
fn patch_test_4d_stvk_on_the_gpu_returns_to_the_affine_map() {
    patch_on_the_gpu(
        "patch_test_4d_stvk_on_the_gpu_returns_to_the_affine_map",
        &[3, 3, 3, 3],
        &[Law::StVenantKirchhoff],
    );
}

#[test]
fn patch_test_4d_neo_hookean_on_the_gpu_returns_to_the_affine_map() {
    patch_on_the_gpu(
        "patch_test_4d_neo_hookean_on_the_gpu_returns_to_the_affine_map",
        &[3, 3, 3, 3],
        &[Law::NeoHookean],
    );
}
