//! f32-only paths checked on their own.
//!
//! The scene origin (`gpu/src/origin.rs`): f32 kernels store x − o, with o
//! the box centre rounded to a multiple of q = 2^⌈log₂ edge⌉. A scene moved
//! by a multiple of q (here 1024 m and −65536 m on two axes, coordinates on
//! a 2⁻¹⁰ grid so every shift is exact in f64) must therefore run on the
//! GPU in f32 **bit for bit** as the same scene at the world origin: the
//! same device coordinates, the same hyperplane offsets (rest − n·o), the
//! same roundings; read back, far − shift equals near exactly. Without the
//! shift the far run would round its coordinates at ulp(65536) = 7.8e-3 m.
//! The origin itself is checked against f64 arithmetic: x − o is exact,
//! |x − o| ≤ 1.5 q, o is a multiple of q, axes near 0 stay unshifted. On
//! llvmpipe the far run is also the f32 reference's (`F32Reference` with
//! the same origin) bit for bit.
//! (The f32 ln of the barrier law is checked against libm within the
//! Vulkan allowance by `tests/gpu/barrier/kernels.rs`.)

use super::*;

use common::exact::{assert_f32_reference_step, bits, f32_identical};
use common::gpu::adapter_or_skip;
use hyperpbd::core::builders::ChainSpec;
use hyperpbd::{Backend, F32Reference, Obstacle, Plan, SceneBuilder, State};
use hyperpbd_gpu::{GpuBackend, Precision, SceneOrigin};

const SHIFT: [f64; 3] = [1024.0, 0.0, -65536.0];

/// A 3D bridge of 16 links on a 2⁻¹⁰ grid near the world origin, over a
/// floor and against a wall (axis-aligned normals: n·o exact), friction
/// and damping, moved by `shift`.
fn bridge(shift: [f64; 3]) -> Scene {
    let mut b = SceneBuilder::new(3)
        .dt(1.0 / 64.0)
        .substeps(8)
        .iterations(2)
        .gravity_along(1, 9.8125)
        .damping(0.5);
    let grid = b.chain(&ChainSpec {
        start: vec![-0.5 + shift[0], 0.25 + shift[1], 0.125 + shift[2]],
        direction: vec![1.0, 0.0, 0.0],
        count: 16,
        spacing: 0.0625,
        mass: 0.125,
        compliance: 0.0,
        fix_first: true,
    });
    for i in 1..16 {
        let p = &mut b.scene_mut().particles[grid.first + i];
        p.velocity = Some(vec![0.0, -0.5 + 0.0625 * i as f64, 0.25]);
    }
    let mut scene = b.build().expect("valid");
    scene.obstacles.push(Obstacle::Hyperplane {
        normal: vec![0.0, 1.0, 0.0],
        offset: -0.25 + shift[1],
        friction: 0.375,
        compliance: 0.0,
        motion: Vec::new(),
    });
    scene.obstacles.push(Obstacle::Hyperplane {
        normal: vec![-1.0, 0.0, 0.0],
        offset: -0.625 - shift[0],
        friction: 0.125,
        compliance: 0.0,
        motion: Vec::new(),
    });
    valid(scene)
}

#[test]
fn f32_far_scene_runs_bit_for_bit_as_at_the_origin() {
    let Some((adapter, summary)) = adapter_or_skip(
        "f32_far_scene_runs_bit_for_bit_as_at_the_origin",
        Precision::F32,
    ) else {
        return;
    };
    let (near, far) = (bridge([0.0; 3]), bridge(SHIFT));
    let origin = SceneOrigin::for_state(3, &State::from_scene(&far).positions, Precision::F32);
    assert_eq!(
        origin.as_slice(),
        &SHIFT,
        "the far scene's origin is the shift"
    );
    assert!(
        SceneOrigin::for_state(3, &State::from_scene(&near).positions, Precision::F32).is_zero()
    );
    let load = |scene: &Scene| {
        let plan = Plan::compile(scene).expect("valid");
        GpuBackend::with_adapter(&adapter, plan, &State::from_scene(scene), Precision::F32)
            .expect("gpu")
    };
    let (mut a, mut b) = (load(&near), load(&far));
    // The f32 reference with the same origin (llvmpipe: bit for bit).
    let mut reference = f32_identical(&summary).then(|| {
        let plan = Plan::compile(&far).expect("valid");
        F32Reference::new(plan, &State::from_scene(&far), origin.as_slice()).expect("reference")
    });
    let mut active = 0;
    for frame in 1..=40 {
        let (ra, rb) = (a.step().expect("near"), b.step().expect("far"));
        if let Some(r) = reference.as_mut() {
            let far_state = b.read_state().expect("far");
            assert_f32_reference_step("far bridge", frame, r, &rb, &far_state);
        }
        assert_eq!(ra.active_contacts, rb.active_contacts, "frame {frame}");
        active = active.max(ra.active_contacts);
        let near_state = a.read_state().expect("near");
        let mut moved_back = b.read_state().expect("far");
        for p in moved_back.positions.chunks_exact_mut(3) {
            for (x, s) in p.iter_mut().zip(SHIFT) {
                *x -= s; // exact: both on the f32 grid of the device, |x| < 2^11
            }
        }
        assert!(
            bits(&near_state) == bits(&moved_back),
            "frame {frame}: the f32 run at {SHIFT:?} differs from the run at the origin by {:e} m",
            hyperpbd_verify::compare::max_abs_diff(&near_state.positions, &moved_back.positions)
        );
    }
    assert!(active > 0, "the bridge never touched its planes");
    println!(
        "ORIGIN | f32 bridge at {SHIFT:?} | 40 frames bit-identical to the origin run | {active} contacts"
    );
}

/// The origin against f64 arithmetic, on boxes of many sizes and places.
#[test]
fn origin_shift_is_exact_and_bounded() {
    let mut rng = Lcg(5);
    for case in 0..400 {
        let dim = 1 + case % 4;
        let centre: Vec<f64> = (0..dim)
            .map(|a| 10f64.powf(6.0 * rng.next()) * if a % 2 == 0 { 1.0 } else { -1.0 })
            .collect();
        let size = 10f64.powf(2.0 * rng.next());
        let positions: Vec<f64> = (0..7 * dim)
            .map(|k| centre[k % dim] + size * rng.next())
            .collect();
        let origin = SceneOrigin::box_centre(dim, &positions);
        let o = origin.as_slice();
        let (low, high): (Vec<f64>, Vec<f64>) = (0..dim)
            .map(|a| {
                positions
                    .iter()
                    .skip(a)
                    .step_by(dim)
                    .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &x| {
                        (l.min(x), h.max(x))
                    })
            })
            .unzip();
        let edge = (0..dim).map(|a| high[a] - low[a]).fold(0.0, f64::max);
        let q = if edge > 0.0 {
            2f64.powi(edge.log2().ceil() as i32)
        } else {
            1.0
        };
        let local = origin.to_local(&positions);
        let mut back = local.clone();
        origin.to_world(&mut back);
        assert_eq!(back, positions, "case {case}: x − o + o is exact");
        for a in 0..dim {
            let c = 0.5 * low[a] + 0.5 * high[a];
            if c.abs() >= 4.0 * q {
                assert_eq!(o[a] % q, 0.0, "case {case}: o is a multiple of q = {q}");
                assert!(o[a] != 0.0, "case {case}: axis {a} at {c} is shifted");
            } else {
                assert_eq!(o[a], 0.0, "case {case}: axis {a} at {c} < 4q stays");
            }
        }
        for (k, x) in local.iter().enumerate() {
            let a = k % dim;
            if o[a] != 0.0 {
                assert!(
                    x.abs() <= 1.5 * q,
                    "case {case}: |x − o| = {x} > 1.5 q = {}",
                    1.5 * q
                );
            }
        }
    }
}
