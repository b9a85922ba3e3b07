//! Helpers of the bending tests (tests/cpu/bending.rs, tests/cpu/bending_quadratic.rs).

const U: f64 = f64::EPSILON / 2.0;

/// The hinge of edge (0,0,0)–(1,0,0), wing A in the x–y plane, wing B at
/// angle `theta` from wing A about the edge (θ = π: flat, θ = 0: shut):
/// |e| = h_A = h_B = 1.
pub fn opened(theta: f64) -> Vec<Vec<f64>> {
    vec![
        vec![0.0, 0.0, 0.0],
        vec![1.0, 0.0, 0.0],
        vec![0.4, 1.0, 0.0],
        vec![0.6, theta.cos(), theta.sin()],
    ]
}

/// Four random points of R^`dim` in [−1, 1)^dim.
pub fn random_hinge(rng: &mut super::Lcg, dim: usize) -> Vec<Vec<f64>> {
    (0..4)
        .map(|_| (0..dim).map(|_| rng.next()).collect())
        .collect()
}

/// Asserts that ∇C = `g` of a 4-particle element at `x` (4 × `dim`, flat)
/// carries no rigid motion: the net force Σ_j ∇_j C (translation) and the
/// first moment Σ_j x_j ∇_j Cᵀ − ∇_j C x_jᵀ (rotation) vanish to
/// 256·u·Σ_j (1 + |x_j|)|∇_j C|, roundoff scale.
pub fn assert_no_rigid_force(dim: usize, x: &[f64], g: &[f64]) {
    let norm = |s: &[f64]| s.iter().map(|v| v * v).sum::<f64>().sqrt();
    let scale: f64 = (0..4)
        .map(|j| (1.0 + norm(&x[j * dim..(j + 1) * dim])) * norm(&g[j * dim..(j + 1) * dim]))
        .sum();
    let bound = 256.0 * U * scale;
    for a in 0..dim {
        let net: f64 = (0..4).map(|j| g[j * dim + a]).sum();
        assert!(
            net.abs() <= bound,
            "dim {dim}: net force {net:e} > {bound:e}"
        );
        for b in 0..dim {
            let moment: f64 = (0..4)
                .map(|j| x[j * dim + a] * g[j * dim + b] - g[j * dim + a] * x[j * dim + b])
                .sum();
            assert!(
                moment.abs() <= bound,
                "dim {dim}: moment {moment:e} > {bound:e}"
            );
        }
    }
}
