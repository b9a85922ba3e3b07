//! The rotating drum's energy books (issue 31: "the drum conserves nothing
//! it should not"): the energy the walls put in is the work of their
//! contact forces, W = Σ_frames Σ_o P_o dt (`ContactForces::obstacle_power`,
//! P_o = Σ_substeps Σ_i J_oi · D_o(p_i)/h / dt), against the change of the
//! balls' energy E = Σ_i m_i (½|v_i|² − g·x_i).
//!
//! ```text
//! W = ΔE + D,  D ≥ 0 what friction, inelastic contact and damping dissipate
//!
//! a ball stuck to a wall (static friction holds: x = p + D(p), v = D(p)/h = u_s):
//!   per substep  J = m (u_s − v_pred),  v_pred = u_{s−1} + h g
//!   W_s − ΔE_s = m(u_s − v_pred)·u_s − [½m|u_s|² − ½m|u_{s−1}|² − m g·h u_s]
//!              = ½ m |u_s − u_{s−1}|²            (exactly: the catch of each substep)
//!   turning at ω on a circle of radius ρ: |u_s − u_{s−1}| = ω² ρ h, so over T
//!   D = ½ m ω⁴ ρ² h T  (two-sided: 0 ≤ D ≤ that, plus rounding)
//! the full drum (balls on balls, avalanches): no closed form for D; what must
//!   hold is D ≥ 0, over the run and in every frame (measured values printed)
//! ```
//! Both run on the golden path (contact forces are the CPU's); the GPU
//! runs the same steps bit for bit (tests/gpu/drum_scenes.rs).

use crate::common;

use common::energy;
use hyperpbd::motion::rigid_at;
use hyperpbd::scenes::{DrumSpec, drum, drum_spec};
use hyperpbd::{Backend, CpuBackend, Obstacle, Particle, Plan, Scene, State};

/// What a run measured: the walls' work W, the energy change ΔE, the
/// smallest W − ΔE of one frame, and the deepest any ball's surface was
/// past a wall at a frame's end (m).
struct Books {
    work: f64,
    delta_e: f64,
    worst_frame_d: f64,
    deepest: f64,
}

/// Runs `frames` frames of `scene` on the golden path with contact forces
/// requested, checking the walls after each frame where core's motion
/// has them at the end of its last substep.
fn run(scene: &Scene, frames: u64) -> Books {
    let plan = Plan::compile(scene).expect("valid drum");
    let (dt, h, substeps) = (plan.dt, plan.h, plan.substeps);
    let mut state = State::from_scene(scene);
    let mut b = CpuBackend::with_threads(plan, &state, 1).expect("loads");
    b.request_contact_forces(true).expect("cpu forces");
    let (mut work, e0) = (0.0, energy(scene, &state));
    let (mut worst_frame_d, mut deepest) = (f64::INFINITY, f64::NEG_INFINITY);
    for frame in 0..frames {
        let before = energy(scene, &state);
        let report = b.step().expect("step");
        let forces = report.contact_forces.expect("requested");
        let w: f64 = forces.obstacle_power.iter().sum::<f64>() * dt;
        work += w;
        state = b.read_state().expect("state");
        worst_frame_d = worst_frame_d.min(w - (energy(scene, &state) - before));
        let t = hyperpbd::motion::substep_time(frame, dt, substeps, h);
        for o in &scene.obstacles {
            let Obstacle::Hyperplane {
                normal,
                offset,
                motion,
                ..
            } = o
            else {
                continue;
            };
            let m = rigid_at(motion, scene.dim, t);
            let n = m.rotate(normal);
            let k = offset
                + n.iter()
                    .zip(&m.translation)
                    .map(|(a, b)| a * b)
                    .sum::<f64>();
            for (i, p) in scene.particles.iter().enumerate() {
                let d: f64 = n.iter().zip(state.position(i)).map(|(a, b)| a * b).sum();
                deepest = deepest.max(k + p.radius - d);
            }
        }
    }
    Books {
        work,
        delta_e: energy(scene, &state) - e0,
        worst_frame_d,
        deepest,
    }
}

/// The built-in drum's geometry turning at 0.5 rad/s with μ_w = 1.
fn spec(dim: usize) -> DrumSpec {
    DrumSpec {
        rate: 0.5,
        wall_friction: 1.0,
        ..drum_spec(dim)
    }
}

#[test]
fn a_ball_carried_by_the_drum_gains_the_walls_work() {
    for dim in [3, 4] {
        let s = spec(dim);
        let mut scene = drum(&s);
        // One ball resting on the middle of the bottom wall, moving with it:
        // x = (0, −R + r), v = ω J x = (ω (R − r), 0).
        let rho = s.radius - s.ball;
        let mut x = vec![0.0; dim];
        x[1] = -rho;
        let mut v = vec![0.0; dim];
        v[0] = s.rate * rho;
        scene.particles = vec![
            Particle::new(x, s.mass)
                .with_radius(s.ball)
                .with_velocity(v),
        ];
        scene.collisions = None;
        // 1 s: the wall tilts by 0.5 rad, below atan μ = π/4: it holds.
        let frames = 60;
        let books = run(&scene, frames);
        let plan = Plan::compile(&scene).unwrap();
        let t = frames as f64 * plan.dt;
        let d = books.work - books.delta_e;
        let derived = 0.5 * s.mass * s.rate.powi(4) * rho * rho * plan.h * t;
        // The leading order of ½ m |u_s − u_{s−1}|² (chords, not tangents:
        // relative O((ωh)²)); the first substep catches from the tangent,
        // a quarter of the others' (1/600 of the sum); rounding: W and E of
        // size m g R ≈ 0.05 J over 600 substeps, ~1e-16 J each, ≪ 1e-12.
        let bound = 0.01 * derived + 1e-12;
        println!(
            "{dim}D carried ball: W {:.9e} J, ΔE {:.9e} J, D = W − ΔE {d:.4e} J; derived ½mω⁴ρ²hT {derived:.4e}; |D − derived| {:.2e} / bound {bound:.2e}; deepest {:.2e} m",
            books.work,
            books.delta_e,
            (d - derived).abs(),
            books.deepest
        );
        // The wall lifted the ball: ΔE is the potential m g ρ (1 − cos ωT).
        let lift = s.mass * 9.81 * rho * (1.0 - (s.rate * t).cos());
        assert!(
            (books.delta_e - lift).abs() <= 1e-3 * lift,
            "{dim}D: ΔE {} vs lift {lift}",
            books.delta_e
        );
        assert!(
            (d - derived).abs() <= bound,
            "{dim}D: D = {d:e}, derived {derived:e}"
        );
        assert!(books.deepest <= 1e-12, "{dim}D: {}", books.deepest);
    }
}

#[test]
fn the_drum_dissipates_what_its_walls_put_in_and_keeps_its_balls() {
    for name in ["drum3d", "drum4d"] {
        let scene = hyperpbd::scenes::by_name(name).expect("built-in");
        let books = run(&scene, 180);
        let d = books.work - books.delta_e;
        let radius = scene.particles.iter().map(|p| p.radius).fold(0.0, f64::max);
        // Bounds: D ≥ 0 over the run and in every frame (no energy from
        // nowhere); every ball's surface within 1e-3 r of the walls where
        // they are at the frame's end (the wall projection is exact; only
        // a ball pushed by its neighbours after it could go past).
        println!(
            "{name}: 3 s: W {:.6e} J, ΔE {:.6e} J, D = W − ΔE {d:.6e} J ({:.1} % of W) / bound ≥ 0; smallest frame D {:.3e} J / bound ≥ 0; deepest past a wall {:.3e} m ({:.2e} r) / bound 1e-3 r",
            books.work,
            books.delta_e,
            100.0 * d / books.work,
            books.worst_frame_d,
            books.deepest,
            books.deepest / radius
        );
        assert!(books.work > 0.0, "{name}: the walls put no energy in");
        assert!(d >= 0.0, "{name}: D = {d:e}");
        assert!(
            books.worst_frame_d >= 0.0,
            "{name}: {}",
            books.worst_frame_d
        );
        assert!(books.deepest <= 1e-3 * radius, "{name}: {}", books.deepest);
    }
}
