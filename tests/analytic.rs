//! Analytic anchors: the CPU golden path against closed forms.
//!
//! Every assertion states its bound and the rationale for it next to the
//! check, and prints `measured / bound`. Bounds are derived from the
//! algorithm in DESIGN.md ("The golden algorithms") and f64 rounding
//! (u = 2^-53 per correctly rounded operation); none is tuned to what the
//! code happens to produce. Run with `cargo test --release --test analytic
//! -- --nocapture` to see the measured values.

mod support;

use hyperpbd::builders::ChainSpec;
use hyperpbd::{ConstraintFamily, ConstraintKind, Particle, SceneBuilder, State};
use support::{
    U, all_finite, backend, dot, fit_quadratic, max_abs, norm, scale, state, step, sub, unit,
    zero_crossings,
};

const G: f64 = 9.81;

// ---------------------------------------------------------------------------
// 1. Free fall
// ---------------------------------------------------------------------------

/// Free fall against the closed form of semi-implicit Euler.
///
/// ```text
/// per substep h:   v_{k+1} = v_k + h g,   x_{k+1} = x_k + h v_{k+1}
/// closed form:     v_n = v_0 + n h g,     x_n = x_0 + n h v_0 + h² g n(n+1)/2
/// ```
/// The golden path computes this as predict (v += h g; x += h v) followed by
/// velocity reconstruction v = (x − p)/h. Rounding analysis per component
/// (first order in u; X = max |x|, V = max |v| over the run, a = fl(h g)):
///
/// ```text
/// a = hg(1+θ)                          |a − hg| ≤ u|hg|
/// v' = fl(v + a)                       ρ_k ≤ u V
/// x' = fl(x + fl(h v'))                δ_k ≤ u (hV + X)
/// v_new = fl(fl(x' − x)/h)             = v' + δ_k/h + η_k,   η_k ≤ 2uV
/// ```
/// The position rounding δ_k re-enters as a velocity error δ_k/h that is
/// never removed (velocity is reconstructed from positions), so
///
/// ```text
/// |e_v(n)| ≤ n u (|hg| + 4V + X/h)
/// |e_x(n)| ≤ h u (|hg| + 4V + X/h) n(n−1)/2 + n u (h|hg| + 2hV + X)
/// ```
/// i.e. "ulps × step count" for velocity (scaled by X/h) and ulps × n²/2 for
/// position, worst case. Evaluating the closed form in f64 adds at most 4
/// roundings per term. Second-order terms are covered by a 1% margin. Any
/// algorithmic deviation (explicit instead of semi-implicit Euler, a wrong h,
/// a dropped substep) is O(h g) in velocity and O(n h² g) in position —
/// about 10 orders of magnitude above these bounds.
#[test]
fn free_fall_matches_semi_implicit_euler_closed_form() {
    for (dim, substeps, gravity) in [
        (3usize, 7u32, vec![0.3, -G, 1.7]),
        (1, 1, vec![-G]),
        (4, 10, vec![-1.25, 0.5, -G, 2.0]),
        (6, 3, vec![0.0, 0.0, 0.0, 0.0, -G, 0.75]),
    ] {
        let dt = 1.0 / 60.0;
        let steps = 120u32;
        let mut b = SceneBuilder::new(dim)
            .dt(dt)
            .substeps(substeps)
            .iterations(1)
            .gravity(gravity.clone());
        let x0: Vec<f64> = (0..dim).map(|a| 0.1 + 0.37 * a as f64 - 0.5).collect();
        let v0: Vec<f64> = (0..dim).map(|a| 1.25 - 0.9 * a as f64).collect();
        b.particle(Particle::new(x0.clone(), 2.5).with_velocity(v0.clone()));
        // A second particle at rest far from the origin: larger X.
        let x1: Vec<f64> = (0..dim).map(|a| 40.0 + a as f64).collect();
        b.particle(Particle::new(x1.clone(), 0.5));
        let scene = b.build().expect("valid scene");
        let h = scene.dt / f64::from(scene.substeps);
        let mut sim = backend(&scene);

        let mut worst_x_ratio: f64 = 0.0;
        let mut worst_v_ratio: f64 = 0.0;
        let (mut worst_x, mut worst_v) = (0.0f64, 0.0f64);
        let (mut bound_x_end, mut bound_v_end) = (0.0, 0.0);
        for s in 1..=steps {
            step(&mut sim);
            let st = state(&mut sim);
            let n = f64::from(s * substeps);
            for (i, (xs, vs)) in [(&x0, &v0), (&x1, &vec![0.0; dim])].iter().enumerate() {
                for a in 0..dim {
                    let g = gravity[a];
                    // Closed form of the discrete scheme.
                    let x_ref = xs[a] + n * h * vs[a] + h * h * g * (n * (n + 1.0) / 2.0);
                    let v_ref = vs[a] + n * h * g;
                    // Extremes of the trajectory so far (it is a parabola in
                    // k, so sampling every substep is exact enough; 1%
                    // margin below covers the difference).
                    let (mut big_x, mut big_v) = (0.0f64, 0.0f64);
                    for k in 0..=(s * substeps) {
                        let k = f64::from(k);
                        big_x = big_x
                            .max((xs[a] + k * h * vs[a] + h * h * g * (k * (k + 1.0) / 2.0)).abs());
                        big_v = big_v.max((vs[a] + k * h * g).abs());
                    }
                    let hg = (h * g).abs();
                    let bound_v = 1.01
                        * (n * U * (hg + 4.0 * big_v + big_x / h)
                            + 3.0 * U * (vs[a].abs() + (n * h * g).abs()));
                    let bound_x = 1.01
                        * (h * U * (hg + 4.0 * big_v + big_x / h) * n * (n - 1.0) / 2.0
                            + n * U * (h * hg + 2.0 * h * big_v + big_x)
                            + 4.0
                                * U
                                * (xs[a].abs()
                                    + (n * h * vs[a]).abs()
                                    + (h * h * g * n * (n + 1.0) / 2.0).abs()));
                    let ex = (st.position(i)[a] - x_ref).abs();
                    let ev = (st.velocity(i)[a] - v_ref).abs();
                    worst_x = worst_x.max(ex);
                    worst_v = worst_v.max(ev);
                    worst_x_ratio = worst_x_ratio.max(ex / bound_x);
                    worst_v_ratio = worst_v_ratio.max(ev / bound_v);
                    if s == steps {
                        bound_x_end = f64::max(bound_x_end, bound_x);
                        bound_v_end = f64::max(bound_v_end, bound_v);
                    }
                }
            }
        }
        eprintln!(
            "free_fall dim {dim} substeps {substeps}: max position error {worst_x:e} (bound at end {bound_x_end:e}), \
             max velocity error {worst_v:e} (bound at end {bound_v_end:e}); worst measured/bound: x {worst_x_ratio:.3e}, v {worst_v_ratio:.3e}"
        );
        // Bound: the derived first-order rounding bound above, per step and
        // per component (ratio ≤ 1 everywhere).
        assert!(
            worst_x_ratio <= 1.0,
            "free fall dim {dim}: position error exceeds the rounding bound (ratio {worst_x_ratio:e})"
        );
        assert!(
            worst_v_ratio <= 1.0,
            "free fall dim {dim}: velocity error exceeds the rounding bound (ratio {worst_v_ratio:e})"
        );
    }
}

// ---------------------------------------------------------------------------
// 2. Resting contact
// ---------------------------------------------------------------------------

/// Runs a single particle of radius `r` placed at `x0` against one
/// hyperplane for `steps` steps; returns the largest displacement from `x0`
/// seen after any step.
fn rest_run(
    normal: &[f64],
    offset: f64,
    friction: f64,
    gravity: Vec<f64>,
    x0: &[f64],
    r: f64,
    steps: usize,
) -> f64 {
    let mut b = SceneBuilder::new(x0.len())
        .dt(1.0 / 60.0)
        .substeps(10)
        .iterations(1)
        .gravity(gravity);
    b.particle(Particle::new(x0.to_vec(), 0.7).with_radius(r));
    b.hyperplane(normal.to_vec(), offset, friction);
    let scene = b.build().expect("valid scene");
    let mut sim = backend(&scene);
    let mut worst: f64 = 0.0;
    for _ in 0..steps {
        let report = step(&mut sim);
        assert_eq!(
            report.active_contacts, 1,
            "the resting particle lost contact"
        );
        let st = state(&mut sim);
        assert!(all_finite(&st));
        worst = worst.max(norm(&sub(st.position(0), x0)));
    }
    worst
}

/// A particle resting on a hyperplane stays put for 1000 steps (10⁴
/// substeps), with and without friction.
///
/// Each substep, prediction pushes the particle h²g into the plane and the
/// contact projection puts n·x back to offset + r; nothing is left to move
/// except rounding. Bounds, per case (‖x0‖ the distance scale, N = 10⁴
/// substeps):
///
/// - **axis-aligned normal** (e_y, gravity −e_y), μ = 0 and μ = 0.5: the
///   tangential arithmetic is exact (normal components are exactly 0, so
///   every tangential update adds exactly 0) and the normal coordinate is
///   reset to the rest height each substep with at most two roundings
///   (fl(w·dl), the add): |Δx| ≤ 2u·|rest| + 2u·h²g. Bound 4u‖x0‖.
/// - **tilted normal in R^4** ((1,2,−2,4)/5, gravity −g n), μ = 0.5: static
///   friction cancels the tangential displacement every substep and dynamic
///   friction zeroes the tangential velocity, so each substep leaves at most
///   ~2u‖x‖ of position rounding that is not fed back as velocity: it can
///   only accumulate linearly. Bound 2·N·u‖x0‖ ≈ 2e-12 relative (the
///   issue's "~1e-12 relative").
/// - **tilted normal, μ = 0**: a frictionless particle on a plane is in
///   neutral equilibrium tangentially. The ≤ 2u‖x‖ rounding of the two
///   position updates per substep (predict, projection) is reconstructed
///   into a tangential velocity δ/h that nothing removes, so the drift is
///   bounded by Σ_k (k+1)·2u‖x‖ = u‖x‖N(N+1) — quadratic in N, ≈ 1e-8
///   relative here — plus ½·|g_t|·t² from the rounding of gravity's
///   tangential part (|g_t| ≤ u·g·√N_dim·2). This is the floor of
///   position-based velocity, not a physical effect. Measured: the kicks
///   have the same sign every substep (the state repeats), so the drift is
///   systematic — 2.3e-9 m after 1000 steps, ×4 per doubling of the run.
#[test]
fn resting_particle_on_hyperplane_stays_put() {
    let offset = 0.25;
    let r = 0.1;
    let steps = 1000;
    let substeps_total = (steps * 10) as f64;
    let rest: f64 = offset + r; // the plan computes the same fl(offset + r)
    for mu in [0.0, 0.5] {
        // Axis-aligned plane in R^3.
        let x0 = vec![0.3, rest, -0.2];
        let d = rest_run(
            &[0.0, 1.0, 0.0],
            offset,
            mu,
            vec![0.0, -G, 0.0],
            &x0,
            r,
            steps,
        );
        let bound = 4.0 * U * norm(&x0);
        eprintln!(
            "resting (axis-aligned plane, R^3, mu {mu}): max displacement {d:e} / bound {bound:e} (4u|x0|)"
        );
        assert!(
            d <= bound,
            "resting particle moved {d:e} > {bound:e} on an axis-aligned plane (mu {mu})"
        );

        // Tilted plane in R^4; gravity along −n.
        let n = [0.2, 0.4, -0.4, 0.8]; // (1,2,-2,4)/5, |(1,2,-2,4)| = 5 exactly
        // A generic tangent (every component nonzero): (0.4, 0.2, 0.8, 0)
        // minus its normal part.
        let t = [0.4, 0.2, 0.8, 0.0];
        let t = unit(&sub(&t, &scale(dot(&t, &n), &n)));
        let x0: Vec<f64> = (0..4).map(|a| rest * n[a] + 0.6 * t[a]).collect();
        let gravity = scale(-G, &n);
        let d = rest_run(&[1.0, 2.0, -2.0, 4.0], offset, mu, gravity, &x0, r, steps);
        let x_scale = norm(&x0);
        let (bound, why) = if mu > 0.0 {
            (
                2.0 * substeps_total * U * x_scale,
                "2·N·u|x0|: static friction, linear accumulation",
            )
        } else {
            let time = steps as f64 / 60.0;
            let g_t = 2.0 * U * G * 2.0; // 2u·g·√4
            (
                U * x_scale * substeps_total * (substeps_total + 1.0) + 0.5 * g_t * time * time,
                "u|x0|N(N+1) + g_t t²/2: frictionless, rounding fed back as velocity",
            )
        };
        eprintln!(
            "resting (tilted plane, R^4, mu {mu}): max displacement {d:e} ({:e} relative) / bound {bound:e} ({why})",
            d / x_scale
        );
        assert!(
            d <= bound,
            "resting particle moved {d:e} > {bound:e} on a tilted plane (mu {mu})"
        );
    }
}

// ---------------------------------------------------------------------------
// 3. Pendulum
// ---------------------------------------------------------------------------

/// Runs a rigid pendulum (distance constraint, compliance 0, to a fixed
/// pivot at the origin) of length `length` in R^dim, released from rest at
/// angle `theta0` from the downward vertical (−e_`up`) in the plane spanned
/// by e_`up` and the unit horizontal `swing`; returns the measured period
/// from the zero crossings of the horizontal displacement swing·x.
fn pendulum_period(
    dim: usize,
    up: usize,
    swing: &[f64],
    length: f64,
    theta0: f64,
    seconds: f64,
) -> (f64, usize, f64) {
    let dt = 1.0 / 60.0;
    let mut b = SceneBuilder::new(dim)
        .dt(dt)
        .substeps(20)
        .iterations(1)
        .gravity_along(up, G);
    let pivot = b.particle(Particle::fixed(vec![0.0; dim]));
    let mut bob: Vec<f64> = scale(length * theta0.sin(), swing);
    bob[up] -= length * theta0.cos();
    let bob_index = b.particle(Particle::new(bob, 0.3));
    b.family(ConstraintFamily::new(
        ConstraintKind::Distance,
        0.0,
        vec![vec![pivot, bob_index]],
    ));
    let scene = b.build().expect("valid scene");
    let mut sim = backend(&scene);
    let steps = (seconds / dt).round() as usize;
    let (mut t, mut s) = (vec![0.0], vec![dot(swing, &scene.particles[1].position)]);
    let mut worst_residual: f64 = 0.0;
    for k in 1..=steps {
        let report = step(&mut sim);
        worst_residual = worst_residual.max(report.max_violation());
        let st = state(&mut sim);
        t.push(k as f64 * dt);
        s.push(dot(swing, st.position(1)));
    }
    let crossings = zero_crossings(&t, &s);
    assert!(
        crossings.len() >= 5,
        "pendulum crossed zero only {} times in {seconds} s",
        crossings.len()
    );
    // Consecutive crossings are half a period apart.
    let half_periods = (crossings.len() - 1) as f64;
    let period = 2.0 * (crossings[crossings.len() - 1] - crossings[0]) / half_periods;
    (period, crossings.len(), worst_residual)
}

/// Small-angle pendulum period against 2π√(L/g).
///
/// θ0 = 0.05 rad: the finite-amplitude correction is θ0²/16 ≈ 1.6e-4, and
/// XPBD with h = 1/1200 s (ωh ≈ 2.6e-3) adds a phase error of O((ωh)²) per
/// unit time. Crossings are located by linear interpolation between frames:
/// near a zero crossing the swing coordinate is at an inflection point, so
/// the interpolation error is O(ω³ dt³ · amplitude) — negligible. The bound
/// is the issue's 0.5%, which every one of these effects is well below and
/// which a wrong projection (e.g. a compliance or mass-weighting error that
/// lets the rod stretch, or a missing substep scaling of g) exceeds. The
/// 5-D case runs the generic (dimension > 4) distance path with the swing
/// plane mixing three axes.
#[test]
fn small_angle_pendulum_period() {
    let theta0: f64 = 0.05;
    let length = 0.8;
    let expected = 2.0 * std::f64::consts::PI * (length / G).sqrt();
    let cases: Vec<(usize, usize, Vec<f64>)> = vec![
        (2, 1, vec![1.0, 0.0]),
        (3, 1, vec![1.0, 0.0, -0.5]),
        (5, 4, vec![0.6, -0.3, 0.7, 0.0, 0.0]),
    ];
    let mut periods = Vec::new();
    for (dim, up, swing) in cases {
        let swing = unit(&swing);
        let (period, crossings, residual) =
            pendulum_period(dim, up, &swing, length, theta0, 6.0 * expected);
        let rel = (period - expected).abs() / expected;
        let amplitude_corrected = expected * (1.0 + theta0 * theta0 / 16.0);
        let bound = 5e-3;
        eprintln!(
            "pendulum R^{dim}: period {period:.6} s vs 2π√(L/g) = {expected:.6} s over {crossings} crossings: \
             relative error {rel:e} / bound {bound:e}; vs the amplitude-corrected period T0(1 + θ0²/16): {:e}",
            (period - amplitude_corrected) / amplitude_corrected
        );
        assert!(
            rel <= bound,
            "pendulum period off by {rel:e} (> {bound:e}) in R^{dim}"
        );
        // One rigid constraint against a fixed pivot is projected exactly
        // in one iteration; what is left is the rounding of the difference,
        // the length, Δλ and the coordinate updates, each ≲ u·L: bound 16u·L.
        let rod_bound = 16.0 * U * length;
        eprintln!("pendulum R^{dim}: rod residual {residual:e} / bound {rod_bound:e}");
        assert!(
            residual <= rod_bound,
            "rigid pendulum rod residual {residual:e} > {rod_bound:e} in R^{dim}"
        );
        periods.push((dim, period));
    }
    // The motion is planar in every case, so the dimensions differ only in
    // rounding (different arithmetic order, the generic path for R^5); a
    // stable oscillator keeps those differences growing at most linearly:
    // ~steps·substeps·u ≈ 1e-11 relative. Bound 1e-9.
    let (_, reference) = periods[0];
    for &(dim, period) in &periods[1..] {
        let rel = (period - reference).abs() / reference;
        eprintln!("pendulum R^{dim} vs R^2 period: relative difference {rel:e} / bound 1e-9");
        assert!(
            rel <= 1e-9,
            "pendulum period in R^{dim} differs from R^2 by {rel:e}: the dimension-generic paths disagree"
        );
    }
}

// ---------------------------------------------------------------------------
// 4. Incline: the friction threshold tan θ = μ
// ---------------------------------------------------------------------------

/// An incline in R^dim: gravity along −e_`up`, the plane normal tilted from
/// e_`up` by θ towards the unit horizontal `t`, so the downhill direction is
/// d = cos θ t − sin θ e_up. One particle (radius 0.05) starts at rest on the
/// plane, displaced sideways along `side` (a second tangent). Returns the
/// sample times, positions after every step, d and x0.
struct Incline {
    times: Vec<f64>,
    positions: Vec<Vec<f64>>,
    downhill: Vec<f64>,
    x0: Vec<f64>,
    substeps: usize,
}

fn incline_run(
    dim: usize,
    up: usize,
    t: &[f64],
    side: &[f64],
    theta: f64,
    mu: f64,
    steps: usize,
) -> Incline {
    let dt = 1.0 / 60.0;
    let substeps = 10;
    let t = unit(t);
    let mut e_up = vec![0.0; dim];
    e_up[up] = 1.0;
    let normal: Vec<f64> = (0..dim)
        .map(|a| theta.cos() * e_up[a] + theta.sin() * t[a])
        .collect();
    let downhill: Vec<f64> = (0..dim)
        .map(|a| theta.cos() * t[a] - theta.sin() * e_up[a])
        .collect();
    let (offset, r) = (0.1, 0.05);
    let x0: Vec<f64> = (0..dim)
        .map(|a| (offset + r) * normal[a] + 0.3 * side[a])
        .collect();
    let mut b = SceneBuilder::new(dim)
        .dt(dt)
        .substeps(substeps as u32)
        .iterations(1)
        .gravity_along(up, G);
    b.particle(Particle::new(x0.clone(), 1.3).with_radius(r));
    b.hyperplane(normal.clone(), offset, mu);
    let scene = b.build().expect("valid scene");
    let mut sim = backend(&scene);
    let mut times = Vec::with_capacity(steps);
    let mut positions = Vec::with_capacity(steps);
    for k in 1..=steps {
        let report = step(&mut sim);
        assert_eq!(
            report.active_contacts, 1,
            "the particle left the incline at step {k}"
        );
        let st = state(&mut sim);
        assert!(all_finite(&st), "non-finite state at step {k}");
        times.push(k as f64 * dt);
        positions.push(st.position(0).to_vec());
    }
    Incline {
        times,
        positions,
        downhill,
        x0,
        substeps,
    }
}

/// μ > tan θ: the particle sticks without creep, in R^3 and in R^4 with a
/// downhill direction mixing x_0, x_1 and x_2.
///
/// Per substep the prediction moves the particle by h²g; the contact
/// removes the normal part, and static friction (|Δt| = h²g sin θ ≤
/// μ·h²g cos θ) cancels the whole tangential part, so the particle returns
/// to p up to rounding. Dynamic friction then zeroes the rounding-level
/// tangential velocity, so position rounding (≤ ~2u‖x‖ per substep) is not
/// fed back as velocity and accumulates at most linearly: bound 2·N·u·‖x0‖
/// for N substeps (≈ 1e-12 here). Without static friction the particle
/// would creep by N h² g sin θ ≈ 0.1 m over the same run; with a per-axis
/// instead of a whole-vector test it would slip in R^4 where d mixes axes.
#[test]
fn incline_sticks_when_friction_exceeds_tan_theta() {
    let steps = 1000;
    for (dim, up, t, side, theta_deg, mu) in [
        (
            3usize,
            1usize,
            vec![1.0, 0.0, 0.0],
            vec![0.0, 0.0, 1.0],
            25.0f64,
            0.6,
        ),
        (
            4,
            1,
            vec![35f64.to_radians().cos(), 0.0, 35f64.to_radians().sin(), 0.0],
            vec![
                -35f64.to_radians().sin(),
                0.0,
                35f64.to_radians().cos(),
                0.0,
            ],
            30.0,
            0.8,
        ),
    ] {
        let theta = theta_deg.to_radians();
        assert!(mu > theta.tan(), "test setup: must have μ > tan θ");
        let run = incline_run(dim, up, &t, &side, theta, mu, steps);
        let n = (steps * run.substeps) as f64;
        let worst = run
            .positions
            .iter()
            .map(|x| norm(&sub(x, &run.x0)))
            .fold(0.0, f64::max);
        let bound = 2.0 * n * U * norm(&run.x0);
        eprintln!(
            "incline stick R^{dim} θ {theta_deg}° μ {mu} (tan θ {:.3}): max displacement over {steps} steps {worst:e} / bound {bound:e} (2·N·u·|x0|)",
            theta.tan()
        );
        assert!(
            worst <= bound,
            "particle crept {worst:e} > {bound:e} on a {theta_deg}° incline with μ {mu} > tan θ in R^{dim}"
        );
    }
}

/// μ < tan θ: the particle slides with acceleration g (sin θ − μ cos θ).
///
/// Per substep the tangential velocity gains h g sin θ in prediction and
/// dynamic friction removes μ·(normal impulse)/m = μ h g cos θ of it, so the
/// velocity along d grows exactly at g (sin θ − μ cos θ); positions lag by a
/// constant offset (they use the velocity before friction), which the
/// quadratic fit s = c0 + c1 t + ½ a t² absorbs. Bound: the issue's 2% —
/// larger than anything this scheme does, smaller than the errors it is
/// meant to catch: a per-axis friction clamp in R^4 (d mixes axes) changes
/// the friction deceleration by up to √3, i.e. a by ≳ 10%; dropping static
/// or dynamic friction changes a by μ cos θ/(sin θ − μ cos θ) ≈ 75%.
///
/// The motion must also stay on the plane and along d: the normal and the
/// lateral (tangent, ⟂ d) coordinates only see rounding, bounded like the
/// frictionless resting case by u·‖x‖max·N(N+1).
#[test]
fn incline_slides_with_coulomb_acceleration() {
    let steps = 120;
    for (dim, up, t, side, theta_deg, mu) in [
        (
            3usize,
            1usize,
            vec![1.0, 0.0, 0.0],
            vec![0.0, 0.0, 1.0],
            25.0f64,
            0.2,
        ),
        (
            4,
            1,
            vec![35f64.to_radians().cos(), 0.0, 35f64.to_radians().sin(), 0.0],
            vec![
                -35f64.to_radians().sin(),
                0.0,
                35f64.to_radians().cos(),
                0.0,
            ],
            30.0,
            0.25,
        ),
    ] {
        let theta = theta_deg.to_radians();
        assert!(mu < theta.tan(), "test setup: must have μ < tan θ");
        let run = incline_run(dim, up, &t, &side, theta, mu, steps);
        let s: Vec<f64> = run
            .positions
            .iter()
            .map(|x| dot(&run.downhill, &sub(x, &run.x0)))
            .collect();
        let (_, _, a_fit) = fit_quadratic(&run.times, &s);
        let expected = G * (theta.sin() - mu * theta.cos());
        let rel = (a_fit - expected).abs() / expected;
        let bound = 0.02;
        eprintln!(
            "incline slide R^{dim} θ {theta_deg}° μ {mu}: fitted acceleration {a_fit:.9} vs g(sin θ − μ cos θ) = {expected:.9}: relative error {rel:e} / bound {bound:e}"
        );
        assert!(
            rel <= bound,
            "sliding acceleration {a_fit} differs from {expected} by {rel:e} (> {bound:e}) in R^{dim}"
        );
        // Tighter: by the per-substep analysis above the sampled positions
        // lie exactly on a parabola of curvature a, so the fit recovers a up
        // to rounding: velocity-reconstruction error ≲ N·u·|x|/h ≈ 1e-9 m/s
        // over T = 2 s against a·T ≈ 5 m/s, i.e. ~1e-10 relative. Bound
        // 1e-6 (10⁴ margin) still catches a friction impulse off by 1e-5 of
        // itself (e.g. λ taken from a different substep or iteration).
        let tight = 1e-6;
        eprintln!("incline slide R^{dim}: relative error {rel:e} / tight bound {tight:e}");
        assert!(
            rel <= tight,
            "sliding acceleration {a_fit} differs from the exact discrete value {expected} by {rel:e} (> {tight:e}) in R^{dim}"
        );
        // Off-slope motion: normal and lateral parts of the displacement.
        let n_sub = (steps * run.substeps) as f64;
        let x_max = run.positions.iter().map(|x| norm(x)).fold(0.0, f64::max);
        let off_bound = U * x_max * n_sub * (n_sub + 1.0);
        let mut off: f64 = 0.0;
        for x in &run.positions {
            let dx = sub(x, &run.x0);
            let along = scale(dot(&run.downhill, &dx), &run.downhill);
            off = off.max(norm(&sub(&dx, &along)));
        }
        eprintln!(
            "incline slide R^{dim}: off-slope (normal + lateral) displacement {off:e} / bound {off_bound:e} (u·|x|max·N(N+1))"
        );
        assert!(
            off <= off_bound,
            "sliding particle left the downhill line by {off:e} (> {off_bound:e}) in R^{dim}"
        );
    }
}

// ---------------------------------------------------------------------------
// 5. Damping decay
// ---------------------------------------------------------------------------

/// Velocities of a free particle (no gravity) under damping `rate` after
/// every step, with the positions; times k·dt.
fn damping_run(
    dt: f64,
    substeps: u32,
    steps: usize,
    rate: f64,
    x0: &[f64],
    v0: &[f64],
) -> Vec<(f64, Vec<f64>, Vec<f64>)> {
    let mut b = SceneBuilder::new(x0.len())
        .dt(dt)
        .substeps(substeps)
        .iterations(1)
        .damping(rate);
    b.particle(Particle::new(x0.to_vec(), 0.4).with_velocity(v0.to_vec()));
    let scene = b.build().expect("valid scene");
    let mut sim = backend(&scene);
    (1..=steps)
        .map(|k| {
            step(&mut sim);
            let st = state(&mut sim);
            (
                k as f64 * dt,
                st.velocity(0).to_vec(),
                st.position(0).to_vec(),
            )
        })
        .collect()
}

/// |v(t)| = v0·exp(−r t), independent of the time step.
///
/// Per substep the golden path does x' = x + h v, v = (x' − x)/h, then
/// v *= fl(exp(−r h)). Rounding per component (X = max |x|, V = |v0|,
/// n substeps, t = n h):
///
/// ```text
/// position add δ ≤ u(h|v| + X)  → velocity error δ/h ≤ u(|v| + X/h)
/// reconstruction (subtract, divide) ≤ 2u|v|;  multiply ≤ u|v|
/// factor: libm exp < 1 ulp (2u relative) + argument rounding (r h u)
/// errors made earlier are damped, never amplified (factor < 1), so
/// |e_v(n)| ≤ u [n (X/h + 6V) + 4 r t V + 4V]   (+ reference exp, 1%)
/// ```
/// Two settings that share sample times (dt 1/60 with 1 substep, dt 1/24
/// with 7 substeps) must both meet it. A non-invariant scheme such as
/// v *= (1 − r h) is off by n (r h)²/2 ≈ 3.5% here, and a per-step factor
/// applied per substep by a factor of 7 in the exponent — both 10⁹× the bound.
#[test]
fn damping_decays_exponentially_and_timestep_invariantly() {
    let rate = 1.3;
    let x0 = [0.2, -0.1, 0.05];
    let v0 = [1.5, -0.5, 2.0];
    let settings = [(1.0 / 60.0, 1u32, 150usize), (1.0 / 24.0, 7, 60)];
    let mut runs = Vec::new();
    for &(dt, substeps, steps) in &settings {
        let run = damping_run(dt, substeps, steps, rate, &x0, &v0);
        let h = dt / f64::from(substeps);
        let x_max = run
            .iter()
            .map(|(_, _, x)| max_abs(x))
            .fold(max_abs(&x0), f64::max);
        let mut worst_ratio: f64 = 0.0;
        let mut worst: f64 = 0.0;
        let mut last_bound = 0.0;
        for (k, (t, v, _)) in run.iter().enumerate() {
            let n = ((k + 1) as u32 * substeps) as f64;
            let decay = (-rate * t).exp();
            for a in 0..3 {
                let big_v = v0[a].abs();
                let bound = 1.01
                    * U
                    * (n * (x_max / h + 6.0 * big_v) + 4.0 * rate * t * big_v + 4.0 * big_v);
                let err = (v[a] - v0[a] * decay).abs();
                worst = worst.max(err);
                worst_ratio = worst_ratio.max(err / bound);
                last_bound = f64::max(last_bound, bound);
            }
        }
        let (t_end, v_end, _) = run.last().expect("steps > 0");
        eprintln!(
            "damping dt {dt:.5} substeps {substeps}: |v({t_end:.2})| = {:.12} vs v0·exp(−r t) = {:.12}; \
             max component error {worst:e} (bound at end {last_bound:e}); worst measured/bound {worst_ratio:.3e}",
            norm(v_end),
            norm(&v0) * (-rate * t_end).exp()
        );
        assert!(
            worst_ratio <= 1.0,
            "damped velocity deviates from v0·exp(−r t) beyond the rounding bound (ratio {worst_ratio:e}) at dt {dt}, substeps {substeps}"
        );
        runs.push(run);
    }
    // Same physical times, two settings: each meets its own bound, so they
    // agree within the sum; print the measured difference for the record.
    let mut diff: f64 = 0.0;
    for m in 1..=30 {
        let (ta, va, _) = &runs[0][5 * m - 1];
        let (tb, vb, _) = &runs[1][2 * m - 1];
        assert!((ta - tb).abs() < 1e-12, "sample times must coincide");
        diff = diff.max(max_abs(&sub(va, vb)));
    }
    eprintln!(
        "damping: max |v_A(t) − v_B(t)| at common times {diff:e} (each setting is within its own rounding bound above)"
    );
}

// ---------------------------------------------------------------------------
// 6. Hanging chain: compliant equilibrium
// ---------------------------------------------------------------------------

/// Per-link (stretch_k − α T_k) / (α T_0) after settling, and the largest
/// position change over the final second.
fn hanging_chain_error(iterations: u32, alpha: f64, count: usize, mass: f64) -> (Vec<f64>, f64) {
    let dt = 1.0 / 60.0;
    let link = 0.1;
    let mut b = SceneBuilder::new(3)
        .dt(dt)
        .substeps(10)
        .iterations(iterations)
        .gravity_along(1, G)
        .damping(3.0);
    b.chain(&ChainSpec {
        start: vec![0.2, 1.5, -0.1],
        direction: vec![0.0, -1.0, 0.0],
        count: count + 1,
        spacing: link,
        mass,
        compliance: alpha,
        fix_first: true,
    });
    let scene = b.build().expect("valid scene");
    let rest: Vec<f64> = (0..count)
        .map(|k| {
            norm(&sub(
                &scene.particles[k + 1].position,
                &scene.particles[k].position,
            ))
        })
        .collect();
    let mut sim = backend(&scene);
    let (settle_steps, final_window) = (600, 60);
    let mut before = State::from_scene(&scene);
    for k in 0..settle_steps {
        if k == settle_steps - final_window {
            before = state(&mut sim);
        }
        step(&mut sim);
    }
    let st = state(&mut sim);
    assert!(all_finite(&st));
    let drift = max_abs(&sub(&st.positions, &before.positions));
    let top = alpha * mass * G * count as f64;
    let errors = (0..count)
        .map(|k| {
            let stretch = norm(&sub(st.position(k + 1), st.position(k))) - rest[k];
            // Tension in link k: the weight of the count − k particles below.
            let tension = mass * G * (count - k) as f64;
            (stretch - alpha * tension) / top
        })
        .collect();
    (errors, drift)
}

/// The exact fixed point of K Gauss–Seidel sweeps per substep for the
/// vertical chain (see the test below): predicted (s − s*) / (α T_0) per
/// link.
fn hanging_chain_prediction(
    k: u32,
    alpha_tilde: f64,
    w: f64,
    h: f64,
    count: usize,
    mass: f64,
) -> Vec<f64> {
    use nalgebra::{DMatrix, DVector};
    // A = J W Jᵀ + α~ I for links (k, k+1), particle 0 fixed.
    let mut a = DMatrix::<f64>::zeros(count, count);
    for i in 0..count {
        a[(i, i)] = if i == 0 { w } else { 2.0 * w } + alpha_tilde;
        if i + 1 < count {
            a[(i, i + 1)] = -w;
            a[(i + 1, i)] = -w;
        }
    }
    // One sweep with b = 0 in the plan's color order (even links, then odd)
    // is the linear map G; build it column by column.
    let order: Vec<usize> = (0..count).step_by(2).chain((1..count).step_by(2)).collect();
    let mut g = DMatrix::<f64>::zeros(count, count);
    for j in 0..count {
        let mut l = DVector::<f64>::zeros(count);
        l[j] = 1.0;
        for &i in &order {
            let r = -(a.row(i) * &l)[(0, 0)];
            l[i] += r / a[(i, i)];
        }
        g.set_column(j, &l);
    }
    let gk = g.pow(k);
    let identity = DMatrix::<f64>::identity(count, count);
    let inv = (identity - &gk)
        .try_inverse()
        .unwrap_or_else(|| panic!("I − G^K singular"));
    let a_inv = a
        .clone()
        .try_inverse()
        .unwrap_or_else(|| panic!("A singular"));
    // s* = α T (stretches), d = C(x_pred) − C(p) = h² g on the top link.
    let alpha = alpha_tilde * h * h;
    let s_star = DVector::from_fn(count, |i, _| alpha * mass * G * (count - i) as f64);
    let mut d = DVector::<f64>::zeros(count);
    d[0] = h * h * G;
    let s = &a * inv * a_inv * (&s_star + &d) - &d;
    let top = s_star[0];
    (s - s_star).iter().map(|e| e / top).collect()
}

/// A vertical chain (fixed top, N = 8 particles of mass m, links of
/// compliance α) with damping settles at XPBD's compliant equilibrium
/// stretch_k = α·T_k, T_k = m g (N − k); the error against it shrinks as
/// the iteration count grows, and matches the exact fixed point of K
/// Gauss–Seidel sweeps per substep.
///
/// The chain is collinear and vertical, so each substep's projection is
/// exactly linear: Gauss–Seidel on (J W Jᵀ + α~ I) λ = −C(x_pred), a
/// tridiagonal matrix A with diagonal 2w + α~ (w + α~ for the top link) and
/// off-diagonals −w, swept in the plan's color order (even links, then odd).
/// At the static fixed point the final multipliers must balance gravity
/// (λ_K = λ_g, with s* = −α~ λ_g = α T), and K sweeps from λ = 0 give
/// λ_K = (I − G^K) A⁻¹ b, so the fixed point's stretches s satisfy
///
/// ```text
/// s + d = A (I − G^K)⁻¹ A⁻¹ (s* + d)       d = h²g e_0 (prediction on link 0)
/// s − s* = −A (I − G^K)⁻¹ G^K λ_g
/// ‖G‖∞ ≤ β = 2w/(2w + α~)                  (diagonally dominant, red-black order)
/// ‖s − s*‖∞ / s*_max ≤ (4w + α~)/α~ · β^K/(1 − β^K)
/// ```
/// Here w = 10, α~ = α/h² = 9, β ≈ 0.69: the norm bound is informative only
/// at K = 16 (≈ 1.4e-2). Three checks per K:
///
/// 1. measured error ≤ the norm bound (and errors decrease strictly with K);
/// 2. measured error vector = the exact fixed point above (computed here
///    with nalgebra) to rounding: the stretch is a difference of
///    coordinates of size X ≤ 1.5 m, each a few ulps off, and the fixed
///    point of a map contracting at least by e^{−r h} per substep (damping)
///    amplifies per-substep rounding by at most 1/(1 − e^{−r h}) ≈ 200:
///    bound 4u·X·200 / (α T_0) ≈ 7e-10 relative;
/// 3. settled: ten seconds with damping 3/s leave the transient at e^{-30};
///    position change over the final second ≤ 1e-3 of the top link's
///    equilibrium stretch.
#[test]
fn hanging_chain_converges_to_compliant_equilibrium() {
    let (count, mass) = (8usize, 0.1);
    let h: f64 = 1.0 / 600.0;
    let alpha = 2.5e-5;
    let w = 1.0 / mass;
    let alpha_tilde = alpha / (h * h);
    let beta = 2.0 * w / (2.0 * w + alpha_tilde);
    let top = alpha * mass * G * count as f64;
    let x_max = 1.5;
    let fixed_point_bound = 4.0 * U * x_max / (1.0 - (-3.0 * h).exp()) / top;
    let settle_bound = 1e-3 * top;
    let mut errors = Vec::new();
    for k in [1u32, 4, 16] {
        let (per_link, drift) = hanging_chain_error(k, alpha, count, mass);
        let err = max_abs(&per_link);
        let bk = beta.powi(k as i32);
        let bound = (4.0 * w + alpha_tilde) / alpha_tilde * bk / (1.0 - bk);
        let predicted = hanging_chain_prediction(k, alpha_tilde, w, h, count, mass);
        let mismatch = max_abs(&sub(&per_link, &predicted));
        eprintln!(
            "hanging chain, {k:2} iterations: max |stretch − αT|/αT_0 = {err:e} / norm bound {bound:e} \
             ((4w+α~)/α~·β^K/(1−β^K), β = {beta:.4}); exact K-sweep fixed point predicts {:e}, \
             measured − predicted {mismatch:e} / bound {fixed_point_bound:e}; settle drift {drift:e} / {settle_bound:e}",
            max_abs(&predicted)
        );
        assert!(
            drift <= settle_bound,
            "chain not settled after 10 s ({k} iterations): moved {drift:e} in the last second"
        );
        assert!(
            err <= bound,
            "chain equilibrium error {err:e} exceeds the Gauss–Seidel bound {bound:e} at {k} iterations"
        );
        assert!(
            mismatch <= fixed_point_bound,
            "chain equilibrium at {k} iterations differs from the exact fixed point of {k} Gauss–Seidel \
             sweeps by {mismatch:e} (> {fixed_point_bound:e}): the projection is not the documented XPBD update"
        );
        errors.push((k, err));
    }
    for pair in errors.windows(2) {
        let ((k0, e0), (k1, e1)) = (pair[0], pair[1]);
        // More sweeps per substep bring the fixed point closer to the
        // converged equilibrium (G^K shrinks).
        assert!(
            e1 < e0,
            "equilibrium error did not decrease from {k0} to {k1} iterations: {e0:e} -> {e1:e}"
        );
    }
}

// ---------------------------------------------------------------------------
// 7. Built-in scenes in R^2 … R^5, the empty scene, one particle
// ---------------------------------------------------------------------------

/// Masses (0 for fixed particles).
fn masses(scene: &hyperpbd::Scene) -> Vec<f64> {
    scene
        .particles
        .iter()
        .map(|p| if p.fixed { 0.0 } else { p.mass.unwrap_or(0.0) })
        .collect()
}

/// Kinetic + gravitational potential energy, gravity g along −e_`up`.
fn energy(masses: &[f64], st: &State, up: usize) -> f64 {
    (0..st.len())
        .map(|i| masses[i] * (0.5 * dot(st.velocity(i), st.velocity(i)) + G * st.position(i)[up]))
        .sum()
}

/// What a scene run measured.
struct SceneRun {
    /// Largest violation per family over all steps.
    worst: Vec<(String, f64)>,
    /// Largest energy seen after any step, and the initial energy.
    e_max: f64,
    e0: f64,
    /// Lowest value of (n·x − offset − r) over particles and steps for the
    /// first hyperplane (the contact gap; negative = penetration).
    min_gap: f64,
    last: State,
}

/// Runs `frames` steps, checking finiteness after every step.
fn run_scene(name: &str, scene: &hyperpbd::Scene, frames: usize, up: usize) -> SceneRun {
    let m = masses(scene);
    let mut sim = backend(scene);
    let e0 = energy(&m, &State::from_scene(scene), up);
    let mut worst: Vec<(String, f64)> = Vec::new();
    let mut e_max = e0;
    let mut min_gap = f64::INFINITY;
    let plane = scene.obstacles.first().and_then(|o| {
        let hyperpbd::Obstacle::Hyperplane { normal, offset, .. } = o else {
            return None;
        };
        Some((unit(normal), *offset))
    });
    for f in 0..frames {
        let report = step(&mut sim);
        let st = state(&mut sim);
        assert!(all_finite(&st), "{name}: non-finite state after step {f}");
        if worst.is_empty() {
            worst = report
                .residuals
                .iter()
                .map(|r| (r.label.clone(), 0.0))
                .collect();
        }
        for (w, r) in worst.iter_mut().zip(&report.residuals) {
            assert!(
                r.max_violation.is_finite(),
                "{name}: non-finite residual {r:?}"
            );
            w.1 = w.1.max(r.max_violation);
        }
        e_max = e_max.max(energy(&m, &st, up));
        if let Some((n, offset)) = &plane {
            for (i, particle) in scene.particles.iter().enumerate() {
                if m[i] > 0.0 {
                    let gap = dot(n, st.position(i)) - offset - particle.radius;
                    min_gap = min_gap.min(gap);
                }
            }
        }
    }
    SceneRun {
        worst,
        e_max,
        e0,
        min_gap,
        last: state(&mut sim),
    }
}

/// Energy bound shared by the scene checks: XPBD projection and the
/// friction/damping responses only remove energy; the discrete energy
/// (reconstructed velocity, end-of-substep position) may exceed the initial
/// one by at most the O(h) lag M·g·h·v_max, with v_max = √(2 g H) for a fall
/// height H.
fn energy_bound(masses: &[f64], h: f64, fall_height: f64) -> f64 {
    let total: f64 = masses.iter().sum();
    total * G * h * (2.0 * G * fall_height).sqrt()
}

/// Position gap tolerance for "nothing falls through": the contact family
/// is projected last in every iteration, so a particle ends each step on
/// the admissible side up to the rounding of n·x (a few u·|x|): 8u·|x|max.
fn gap_bound(st: &State) -> f64 {
    8.0 * U * max_abs(&st.positions).max(1.0)
}

/// R^2: `scenes::chain2d()` (a rope bridge: 21 particles, both ends fixed
/// 2 m apart, 20 rigid links, 2 iterations, damping 1/s) for 5 s. Checks:
/// finite; link residual ≤ 5% of the link length (a sanity bound — a
/// visibly stretched rope; two Gauss–Seidel sweeps per substep on 20 rigid
/// links leave far less); energy never above E0 + M g h v_max with v_max
/// from the largest possible drop (2 m: the ends' height above the ground);
/// no particle below the ground.
#[test]
fn scene_chain2d_runs_with_bounded_residual() {
    let scene = hyperpbd::scenes::chain2d();
    let h = scene.dt / f64::from(scene.substeps);
    let run = run_scene("chain2d", &scene, 300, 1);
    let link = 0.1; // the links are chords of the authored parabola: ≥ 0.1
    let (label, stretch) = &run.worst[0];
    let bound = 0.05 * link;
    eprintln!("chain2d: {label} max residual {stretch:e} m / bound {bound:e} (5% of 0.1 m)");
    assert!(
        *stretch <= bound,
        "chain2d links stretched by {stretch:e} > {bound:e}"
    );
    let e_bound = energy_bound(&masses(&scene), h, 2.0);
    eprintln!(
        "chain2d: energy max − E0 = {:e} J / bound {e_bound:e} J (M g h v_max)",
        run.e_max - run.e0
    );
    assert!(
        run.e_max - run.e0 <= e_bound,
        "chain2d gained energy: {} > E0 {} + {e_bound}",
        run.e_max,
        run.e0
    );
    let gap = gap_bound(&run.last);
    eprintln!(
        "chain2d: min contact gap {:e} / bound −{gap:e}",
        run.min_gap
    );
    assert!(
        run.min_gap >= -gap,
        "chain2d went through the ground: gap {}",
        run.min_gap
    );
}

/// R^3: `scenes::cloth(16)` dropped on the ground for 2 s. Checks: finite;
/// edge residual ≤ 5% of the spacing (sanity bound as for the chain; one
/// iteration leaves ~1%); energy never above E0 + M g h v_max (friction and
/// damping dissipate); every particle ends on or above the plane at its
/// radius (gap ≥ −8u|x|) and the cloth has landed (every particle touching
/// within 1e-9 m at the end: it fell 0.5–0.7 m in 2 s).
#[test]
fn scene_cloth_runs_with_bounded_residual() {
    let n = 16;
    let scene = hyperpbd::scenes::cloth(n);
    let h = scene.dt / f64::from(scene.substeps);
    let run = run_scene("cloth", &scene, 120, 1);
    let spacing = 1.0 / (n - 1) as f64;
    let (label, stretch) = &run.worst[0];
    let bound = 0.05 * spacing;
    eprintln!("cloth: {label} max residual {stretch:e} m / bound {bound:e} (5% of the spacing)");
    assert!(
        *stretch <= bound,
        "cloth edges stretched by {stretch:e} > {bound:e}"
    );
    let e_bound = energy_bound(&masses(&scene), h, 0.7);
    eprintln!(
        "cloth: energy max − E0 = {:e} J / bound {e_bound:e} J (M g h v_max)",
        run.e_max - run.e0
    );
    assert!(run.e_max - run.e0 <= e_bound, "cloth gained energy");
    let gap = gap_bound(&run.last);
    eprintln!("cloth: min contact gap {:e} / bound −{gap:e}", run.min_gap);
    assert!(
        run.min_gap >= -gap,
        "cloth went through the ground: gap {}",
        run.min_gap
    );
    let highest_gap = (0..run.last.len())
        .map(|i| run.last.position(i)[1] - scene.particles[i].radius)
        .fold(0.0, f64::max);
    eprintln!("cloth: largest gap at the end {highest_gap:e} / bound 1e-9 (landed flat)");
    assert!(
        highest_gap <= 1e-9,
        "cloth has not landed after 2 s: gap {highest_gap}"
    );
}

/// R^4: `scenes::tesseract()` (soft Kuhn block, 384 oriented 4-simplices,
/// compliance 1e-6) dropped on x_3 = 0 for 2 s. Checks: finite; every
/// oriented measure within half its rest value |V_rest| = s⁴/4! (no element
/// inverted or halved: an inversion needs |C| ≥ |V_rest|); energy never
/// above E0 + M g h v_max; nothing falls through the plane.
#[test]
fn scene_tesseract_keeps_volumes_and_stays_above_the_plane() {
    let scene = hyperpbd::scenes::tesseract();
    let h = scene.dt / f64::from(scene.substeps);
    let run = run_scene("tesseract", &scene, 120, 3);
    let spacing: f64 = 0.5;
    let v_rest = spacing.powi(4) / 24.0;
    let (label, dv) = &run.worst[0];
    let bound = 0.5 * v_rest;
    eprintln!(
        "tesseract: {label} max |V − V_rest| {dv:e} ({:.1}% of |V_rest| = {v_rest:e}) / bound {bound:e} (half the rest measure)",
        100.0 * dv / v_rest
    );
    assert!(
        *dv <= bound,
        "tesseract elements lost {dv:e} > {bound:e} of volume"
    );
    let e_bound = energy_bound(&masses(&scene), h, 1.3);
    eprintln!(
        "tesseract: energy max − E0 = {:e} J / bound {e_bound:e} J (M g h v_max)",
        run.e_max - run.e0
    );
    assert!(run.e_max - run.e0 <= e_bound, "tesseract gained energy");
    let (contact_label, contact) = run
        .worst
        .iter()
        .find(|(label, _)| label.starts_with("obstacles"))
        .expect("the tesseract has a ground plane");
    let gap = gap_bound(&run.last);
    eprintln!(
        "tesseract: {contact_label} max penetration {contact:e}, min gap {:e} / bound −{gap:e}",
        run.min_gap
    );
    assert!(
        run.min_gap >= -gap,
        "tesseract went through the plane: gap {}",
        run.min_gap
    );
    assert!(
        *contact <= gap,
        "tesseract contact residual {contact:e} > {gap:e}"
    );
}

/// The soft tesseract should behave like a soft solid for longer than the
/// 2 s above: over 5 s it must not gain energy (bound E0 + M g h v_max, as
/// above) and the landed block must keep its shape (its largest distance
/// from the x_3 axis stays within 2× the authored 0.5·√3 m).
///
/// A regression guard: with volume constraints only (no shear stiffness)
/// the block flowed like a liquid — extent 0.87 m → ~10 m within 2 s, slivers
/// whose tiny |∇V| made −C/Σw|∇C|² inject energy (≈ 196 J at 8 s from
/// E0 = 31.8 J). `soft_block` now adds the simplices' edges as a distance
/// family (`BlockSpec::edge_compliance`), and the tesseract uses it.
#[test]
fn scene_tesseract_keeps_its_shape_and_energy_for_5s() {
    let scene = hyperpbd::scenes::tesseract();
    let h = scene.dt / f64::from(scene.substeps);
    let m = masses(&scene);
    let e0 = energy(&m, &State::from_scene(&scene), 3);
    let e_bound = energy_bound(&m, h, 1.3);
    let extent_bound = 2.0 * 0.5 * 3f64.sqrt();
    let mut sim = backend(&scene);
    for f in 0..300 {
        step(&mut sim);
        let st = state(&mut sim);
        assert!(
            all_finite(&st),
            "tesseract: non-finite state after step {f}"
        );
        let e = energy(&m, &st, 3);
        let extent = (0..st.len())
            .map(|i| norm(&st.position(i)[..3]))
            .fold(0.0, f64::max);
        if f % 60 == 59 {
            eprintln!(
                "tesseract t = {:.0} s: energy − E0 = {:e} J / bound {e_bound:e}; extent {extent:.3} m / bound {extent_bound:.3} m",
                (f + 1) as f64 / 60.0,
                e - e0
            );
        }
        assert!(
            extent <= extent_bound,
            "tesseract lost its shape at step {f}: extent {extent} m > {extent_bound} m"
        );
        assert!(
            e - e0 <= e_bound,
            "tesseract gained energy at step {f}: {e} J > E0 {e0} J + {e_bound} J"
        );
    }
}

/// R^5: `scenes::incline5d()` — four particles on a 20° incline with
/// μ = 0.2 slide down x_0 at g (sin θ − μ cos θ): 2% bound (issue) and the
/// 1e-6 exact-discrete bound of `incline_slides_with_coulomb_acceleration`.
/// Coordinates x_2…x_4 are exactly unchanged (bound 0): normal and gravity
/// have zero components there, so every update adds exactly zero.
#[test]
fn scene_incline5d_slides_at_the_coulomb_rate() {
    let scene = hyperpbd::scenes::incline5d();
    let theta: f64 = 20f64.to_radians();
    let mu = 0.2;
    let downhill = [theta.cos(), -theta.sin(), 0.0, 0.0, 0.0];
    let expected = G * (theta.sin() - mu * theta.cos());
    let mut sim = backend(&scene);
    let count = scene.particles.len();
    let mut times = Vec::new();
    let mut s: Vec<Vec<f64>> = vec![Vec::new(); count];
    for k in 1..=120 {
        let report = step(&mut sim);
        assert_eq!(report.active_contacts, count, "a particle left the incline");
        let st = state(&mut sim);
        assert!(all_finite(&st));
        times.push(k as f64 * scene.dt);
        for (i, si) in s.iter_mut().enumerate() {
            si.push(dot(
                &downhill,
                &sub(st.position(i), &scene.particles[i].position),
            ));
            assert_eq!(
                &st.position(i)[2..],
                &scene.particles[i].position[2..],
                "incline5d particle {i} moved off its x_2..x_4 coordinates"
            );
        }
    }
    for (i, si) in s.iter().enumerate() {
        let (_, _, a) = fit_quadratic(&times, si);
        let rel = (a - expected).abs() / expected;
        eprintln!(
            "incline5d particle {i}: acceleration {a:.9} vs g(sin θ − μ cos θ) = {expected:.9}: relative error {rel:e} / bound 2e-2 (tight 1e-6)"
        );
        assert!(
            rel <= 0.02,
            "incline5d particle {i}: acceleration off by {rel:e}"
        );
        assert!(
            rel <= 1e-6,
            "incline5d particle {i}: acceleration off by {rel:e} (exact discrete value)"
        );
    }
}

/// The empty scene, in several dimensions and with every optional stage
/// authored, steps fine and reports nothing; a single fixed particle never
/// moves (no kernels run: bit-exact).
#[test]
fn empty_scene_steps() {
    for dim in [1usize, 2, 3, 4, 5] {
        let mut b = SceneBuilder::new(dim)
            .substeps(3)
            .iterations(2)
            .gravity_along(dim - 1, G)
            .damping(0.5);
        let mut normal = vec![0.0; dim];
        normal[dim - 1] = 1.0;
        b.hyperplane(normal, 0.0, 0.3);
        let scene = b.build().expect("valid scene");
        let mut sim = backend(&scene);
        for _ in 0..10 {
            let report = step(&mut sim);
            assert!(
                report.residuals.is_empty(),
                "empty scene reported residuals"
            );
            assert_eq!(report.active_contacts, 0);
            assert_eq!(report.max_violation(), 0.0);
        }
        let st = state(&mut sim);
        assert!(st.is_empty() && st.dim == dim);
        eprintln!("empty scene R^{dim}: 10 steps, no residuals, empty state");

        // One fixed particle: nothing may change, bit for bit.
        let mut b = SceneBuilder::new(dim).gravity_along(dim - 1, G);
        let x0: Vec<f64> = (0..dim).map(|a| 0.1 * a as f64 - 0.3).collect();
        b.particle(Particle::fixed(x0.clone()));
        let scene = b.build().expect("valid scene");
        let mut sim = backend(&scene);
        for _ in 0..10 {
            step(&mut sim);
        }
        let st = state(&mut sim);
        assert_eq!(st.position(0), &x0[..], "a fixed particle moved");
        assert_eq!(
            st.velocity(0),
            &vec![0.0; dim][..],
            "a fixed particle gained velocity"
        );
    }
}

/// One dynamic particle in R^1 … R^5 falls onto a hyperplane (normal along
/// the last axis), and comes to rest on it: after 2 s the gap to
/// offset + r is ≤ 8u|x| (contact projected last), and the residual
/// velocity is only reconstruction rounding, ≤ 8u|x|/h.
#[test]
fn one_particle_scene_lands_and_rests() {
    for dim in [1usize, 2, 3, 4, 5] {
        let (offset, r) = (-0.2, 0.05);
        let mut b = SceneBuilder::new(dim)
            .dt(1.0 / 60.0)
            .substeps(4)
            .gravity_along(dim - 1, G);
        let mut x0 = vec![0.25; dim];
        x0[dim - 1] = 0.6;
        b.particle(Particle::new(x0, 0.5).with_radius(r));
        let mut normal = vec![0.0; dim];
        normal[dim - 1] = 1.0;
        b.hyperplane(normal, offset, 0.5);
        let scene = b.build().expect("valid scene");
        let h = scene.dt / f64::from(scene.substeps);
        let mut sim = backend(&scene);
        let mut report = step(&mut sim);
        for _ in 1..120 {
            report = step(&mut sim);
        }
        let st = state(&mut sim);
        assert!(all_finite(&st));
        let height = st.position(0)[dim - 1];
        let gap = (height - (offset + r)).abs();
        let x_max = max_abs(&st.positions);
        let v = max_abs(st.velocity(0));
        eprintln!(
            "one particle R^{dim}: gap {gap:e} / bound {:e}; |v| {v:e} / bound {:e}; active contacts {}",
            8.0 * U * x_max,
            8.0 * U * x_max / h,
            report.active_contacts
        );
        assert_eq!(
            report.active_contacts, 1,
            "the particle is not resting on the plane"
        );
        assert!(
            gap <= 8.0 * U * x_max,
            "one particle R^{dim}: not at rest height (gap {gap:e})"
        );
        assert!(
            v <= 8.0 * U * x_max / h,
            "one particle R^{dim}: still moving ({v:e})"
        );
    }
}
