//! Barrier-path line searches that must reject the first trial.
//!
//! One particle in R^1 falls at 10 m/s towards the plane x ≥ 0 from
//! x0 = 0.05 (d^ = 0.02, no barrier at x0). The first Newton step is the
//! full inertial step Δ = h v; the certified filter cuts it to
//! t = η d0 / |Δ| = 0.27, which lands at d = 0.005, deep inside d^:
//!
//! ```text
//! ΔF(t) = m s (x0 − x~ + s/2) + h² b(d(x0 + s)),  s = t Δ      (F_i(y) − F_i(x))
//! Armijo: accept iff ΔF ≤ c t g·Δ,  c = 1e-4
//! rises    κ = 1e6:           ΔF > 0             (rejected by any decrease test)
//! shallow  κ tuned:           ΔF = ½ c t g·Δ     (rejected by Armijo only, by half
//!                                                 its margin: far above rounding)
//! enough   κ tuned:           ΔF = 50 c t g·Δ    (accepted at d = 0.005 inside d^,
//!                                                 where a 100× stricter c rejects)
//! ```
//! Both facts are computed below with the golden law (`BarrierLaw`) before
//! the scenes run, so the scenes are known to exercise the rejection and
//! the halving. GPU against CPU frame by frame (`barrier_frames`): in f64
//! the same Newton iterations and statuses per substep (a GPU that accepts
//! the first trial takes a different path to the minimiser), and in both
//! precisions the per-frame `BarrierErrorModel`.

use super::*;

use super::scene_fields::barrier_frames;
use common::bound::print_bound;
use common::gpu::adapter_or_skip;
use hyperpbd::barrier::{BarrierLaw, FILTER_SAFETY};
use hyperpbd::gpu::Precision;
use hyperpbd::{Convergence, IncrementalPotentialSettings, Obstacle, Particle, Solver};
use hyperpbd_cpu::incremental_potential::ARMIJO;

const X0: f64 = 0.05;
const V0: f64 = -10.0;
const H: f64 = 1.0 / 60.0;
const DHAT: f64 = 0.02;

/// (ΔF of the first filtered trial, its Armijo amount c t g·Δ) for κ.
fn first_trial(kappa: f64) -> (f64, f64) {
    let prediction = X0 + H * V0;
    let g = X0 - prediction; // m = 1, no barrier at x0 (d0 > d^)
    let delta = -g;
    let t = (FILTER_SAFETY * X0 / -delta).min(1.0);
    let s = t * delta;
    let law = BarrierLaw {
        stiffness: kappa,
        activation_distance: DHAT,
    };
    let change = s * ((X0 - prediction) + 0.5 * s) + H * H * law.evaluate(X0 + s).0;
    (change, ARMIJO * t * g * delta)
}

/// κ for which the first trial decreases F by `fraction` × the Armijo
/// amount (ΔF is affine in κ).
fn kappa_for(fraction: f64) -> f64 {
    let (inertia, armijo) = first_trial(0.0);
    let (unit, _) = first_trial(1.0);
    (fraction * armijo - inertia) / (unit - inertia)
}

fn drop(kappa: f64, tolerance: f64) -> Scene {
    let mut scene = Scene::new(1, H, 1, 1);
    scene
        .particles
        .push(Particle::new(vec![X0], 1.0).with_velocity(vec![V0]));
    scene.obstacles.push(Obstacle::Hyperplane {
        normal: vec![1.0],
        offset: 0.0,
        friction: 0.0,
        compliance: 0.0,
        motion: Vec::new(),
    });
    scene.solver = Solver::IncrementalPotential(IncrementalPotentialSettings {
        barrier_stiffness: kappa,
        activation_distance: DHAT,
        convergence: Convergence::MaxAccelerationResidual { tolerance },
        max_iterations: 100,
        cg_iterations: None,
        warm_start: None,
        friction_slip_velocity: None,
    });
    valid(scene)
}

#[test]
fn the_scenes_need_a_rejection() {
    let (rise, _) = first_trial(1e6);
    assert!(rise > 0.0, "κ = 1e6: ΔF = {rise:e} should be > 0");
    let kappa = kappa_for(0.5);
    let (change, armijo) = first_trial(kappa);
    assert!(
        armijo < change && change < 0.0,
        "κ = {kappa:e}: ΔF = {change:e} should lie in ({armijo:e}, 0)"
    );
    assert!((change - 0.5 * armijo).abs() < 1e-3 * armijo.abs());
    let kappa = kappa_for(50.0);
    let (change, armijo) = first_trial(kappa);
    assert!(
        change < armijo && change > 100.0 * armijo,
        "κ = {kappa:e}: ΔF = {change:e} should lie in (100 × {armijo:e}, {armijo:e})"
    );
}

#[test]
fn rejected_trials_are_rejected_on_the_gpu_too() {
    for precision in [Precision::F32, Precision::F64] {
        let Some((adapter, _)) =
            adapter_or_skip("rejected_trials_are_rejected_on_the_gpu_too", precision)
        else {
            return;
        };
        let tolerance = match precision {
            Precision::F32 => 1.0,
            Precision::F64 => 1e-6,
        };
        for (name, kappa) in [
            ("rises", 1e6),
            ("shallow", kappa_for(0.5)),
            ("enough", kappa_for(50.0)),
        ] {
            let worst = barrier_frames(&adapter, name, &drop(kappa, tolerance), 20, precision);
            print_bound(
                format_args!("line search {name} (κ = {kappa:.6e}) {precision}: 20 frames"),
                format_args!("{worst:.3e}"),
                "1",
                "largest measured / bound of BarrierErrorModel; f64: same iterations and statuses",
            );
        }
    }
}
