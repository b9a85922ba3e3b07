//! Matrix-free preconditioned conjugate gradients for the Newton direction
//! H d = b (H = M + h² Σ K_e⁺, b = −∇F), with a diagonal (Jacobi or mass)
//! preconditioner and every dot product on the fixed block tree.
//!
//! ```text
//! frozen coordinates: P⁻¹_c = 0 (fixed particles); b_c, (H p)_c are taken as 0 there
//! d = 0,  r = b,  z = P⁻¹ r,  p = z,  ρ = r·z,  β_0 = ‖b‖ = √(r·r)
//! tol = max(absolute, relative · β_0);   β_0 ≤ tol → Converged (d = 0, 0 iterations)
//! for k = 1 … max_iterations:
//!   q = H p;   κ = p·q
//!   κ not finite → NonFinite;   κ ≤ 0 → NonPositiveCurvature   (d: the last iterate)
//!   a = ρ / κ;   d_c += a p_c;   r_c −= a q_c
//!   ‖r‖ = √(r·r) ≤ tol → Converged
//!   z = P⁻¹ r;   ρ' = r·z;   p_c = z_c + (ρ'/ρ) p_c;   ρ = ρ'
//! → BudgetExhausted (d: the last iterate)
//! every "·" is reduction::tree_dot (per-particle terms, then the block tree)
//! vector updates are elementwise: d_c = d_c + a·p_c (a product, then a sum)
//! ```
//! For SPD H every iterate from d = 0 is a descent direction of the
//! quadratic model (b·d_k > ½ d_kᵀ H d_k > 0), so a budget-exhausted d is
//! still usable, and with the projected curvature H is SPD over the free
//! coordinates: κ ≤ 0 means rounding or a non-finite input, reported as
//! such, never silently continued. In exact arithmetic CG ends within as
//! many iterations as H has distinct eigenvalues (over the free
//! coordinates), and ‖e_k‖_H ≤ 2 ((√κ_H − 1)/(√κ_H + 1))^k ‖e_0‖_H for
//! the preconditioned condition number κ_H.

use super::reduction::tree_dot;

/// Stopping rule and budget.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PcgSettings {
    /// Iterations allowed (≥ 1 for any progress).
    pub max_iterations: u32,
    /// Stop once ‖r‖ ≤ relative · ‖b‖ …
    pub relative_tolerance: f64,
    /// … or ‖r‖ ≤ absolute, whichever is larger.
    pub absolute_tolerance: f64,
}

/// How a solve ended.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum PcgStatus {
    /// ‖r‖ reached the tolerance (possibly at d = 0: b already small).
    Converged,
    /// `max_iterations` ran; the last iterate is returned.
    BudgetExhausted,
    /// pᵀHp ≤ 0: H is not positive definite along p (or rounding says so).
    NonPositiveCurvature {
        /// The offending pᵀHp.
        curvature: f64,
    },
    /// pᵀHp, a residual norm or the step was not finite.
    NonFinite,
}

/// The result of one solve.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PcgReport {
    /// How it ended.
    pub status: PcgStatus,
    /// Products H p evaluated.
    pub iterations: u32,
    /// ‖b‖ (free coordinates).
    pub initial_residual: f64,
    /// ‖b − H d‖ as updated by the recurrence at the end.
    pub final_residual: f64,
}

/// Vectors of the solve, reused between solves.
#[derive(Debug, Default, Clone)]
pub struct PcgWorkspace {
    r: Vec<f64>,
    z: Vec<f64>,
    p: Vec<f64>,
    q: Vec<f64>,
    terms: Vec<f64>,
    scratch: Vec<f64>,
}

impl PcgWorkspace {
    /// Empty workspace; vectors grow on first use.
    pub fn new() -> Self {
        PcgWorkspace::default()
    }
}

/// Solves H d = `rhs` into `solution` (same length; overwritten, starts at
/// 0). `product(p, out)` writes H p into `out`; `inverse_diagonal` is P⁻¹
/// (0 marks a frozen coordinate); `dim` groups coordinates per particle
/// for the reduction terms.
pub fn pcg<F: FnMut(&[f64], &mut [f64])>(
    mut product: F,
    inverse_diagonal: &[f64],
    rhs: &[f64],
    dim: usize,
    settings: PcgSettings,
    solution: &mut [f64],
    ws: &mut PcgWorkspace,
) -> PcgReport {
    let n = rhs.len();
    let PcgWorkspace {
        r,
        z,
        p,
        q,
        terms,
        scratch,
    } = ws;
    for v in [&mut *r, &mut *z, &mut *p, &mut *q] {
        v.clear();
        v.resize(n, 0.0);
    }
    solution[..n].fill(0.0);
    for c in 0..n {
        r[c] = if inverse_diagonal[c] == 0.0 {
            0.0
        } else {
            rhs[c]
        };
        z[c] = inverse_diagonal[c] * r[c];
        p[c] = z[c];
    }
    let initial = tree_dot(r, r, dim, terms, scratch).sqrt();
    let mut rho = tree_dot(r, z, dim, terms, scratch);
    let mut report = PcgReport {
        status: PcgStatus::Converged,
        iterations: 0,
        initial_residual: initial,
        final_residual: initial,
    };
    if !initial.is_finite() || !rho.is_finite() {
        report.status = PcgStatus::NonFinite;
        return report;
    }
    let tolerance = settings
        .absolute_tolerance
        .max(settings.relative_tolerance * initial);
    if initial <= tolerance {
        return report;
    }
    for iteration in 1..=settings.max_iterations {
        product(p, q);
        for c in 0..n {
            if inverse_diagonal[c] == 0.0 {
                q[c] = 0.0;
            }
        }
        report.iterations = iteration;
        let curvature = tree_dot(p, q, dim, terms, scratch);
        if !curvature.is_finite() {
            report.status = PcgStatus::NonFinite;
            return report;
        }
        if curvature <= 0.0 {
            report.status = PcgStatus::NonPositiveCurvature { curvature };
            return report;
        }
        let a = rho / curvature;
        for c in 0..n {
            solution[c] += a * p[c];
            r[c] -= a * q[c];
        }
        let residual = tree_dot(r, r, dim, terms, scratch).sqrt();
        report.final_residual = residual;
        if !residual.is_finite() {
            report.status = PcgStatus::NonFinite;
            return report;
        }
        if residual <= tolerance {
            report.status = PcgStatus::Converged;
            return report;
        }
        for c in 0..n {
            z[c] = inverse_diagonal[c] * r[c];
        }
        let next = tree_dot(r, z, dim, terms, scratch);
        let beta = next / rho;
        for c in 0..n {
            p[c] = z[c] + beta * p[c];
        }
        rho = next;
    }
    report.status = PcgStatus::BudgetExhausted;
    report
}
