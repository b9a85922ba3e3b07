//! Free fall against the closed form of semi-implicit Euler.

use super::*;

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
