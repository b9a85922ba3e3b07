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
use crate::{Convergence, Refusal};

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

impl PcgReport {
    /// The Newton step's refusal for a CG that broke down at its first
    /// iteration (docs/implicit.md §7 step 7: pᵀHp ≤ 0 or non-finite,
    /// reported as `CurvatureBreakdown` of Newton iteration `iteration`);
    /// `None` otherwise (a later breakdown keeps the iterate so far).
    pub fn breakdown(&self, iteration: u32) -> Option<Refusal> {
        if self.iterations > 1 {
            return None;
        }
        match self.status {
            PcgStatus::NonPositiveCurvature { curvature } => Some(Refusal::CurvatureBreakdown {
                iteration,
                curvature,
            }),
            PcgStatus::NonFinite => Some(Refusal::CurvatureBreakdown {
                iteration,
                curvature: f64::NAN,
            }),
            _ => None,
        }
    }
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
    /// Empty workspace.
    pub fn new() -> Self {
        PcgWorkspace::default()
    }
}

/// The vector half of PCG: where d, r, z, p, q live and how they are
/// updated and reduced. [`pcg_on`] runs the scalar recurrence over it, so
/// the host slices of [`pcg`] and a GPU's buffers share one control flow
/// (every "·" on the block tree, every update elementwise, as in the
/// module docs).
pub trait PcgVectors {
    /// d = 0, r = b on free coordinates (0 where P⁻¹ = 0), z = P⁻¹ r,
    /// p = z; returns (r·r, r·z).
    fn start(&mut self) -> (f64, f64);
    /// q = H p (0 where P⁻¹ = 0); returns p·q.
    fn curvature(&mut self) -> f64;
    /// d += a p, r −= a q, z = P⁻¹ r; returns (r·r, r·z).
    fn advance(&mut self, a: f64) -> (f64, f64);
    /// p = z + β p.
    fn turn(&mut self, beta: f64);
}

/// PCG's decisions at the start, from r·r and ρ = r·z of r = b: the
/// report so far, and the tolerance when the iteration is to run (`None`:
/// the report is final — non-finite, or ‖b‖ already within tolerance).
pub fn pcg_start(rr: f64, rho: f64, settings: PcgSettings) -> (PcgReport, Option<f64>) {
    let initial = rr.sqrt();
    let mut report = PcgReport {
        status: PcgStatus::Converged,
        iterations: 0,
        initial_residual: initial,
        final_residual: initial,
    };
    if !initial.is_finite() || !rho.is_finite() {
        report.status = PcgStatus::NonFinite;
        return (report, None);
    }
    let tolerance = settings
        .absolute_tolerance
        .max(settings.relative_tolerance * initial);
    if initial <= tolerance {
        return (report, None);
    }
    (report, Some(tolerance))
}

/// PCG's scalar recurrence over `vectors` (module docs).
pub fn pcg_on(vectors: &mut impl PcgVectors, settings: PcgSettings) -> PcgReport {
    let (rr, mut rho) = vectors.start();
    let (mut report, tolerance) = pcg_start(rr, rho, settings);
    let Some(tolerance) = tolerance else {
        return report;
    };
    for iteration in 1..=settings.max_iterations {
        let curvature = vectors.curvature();
        report.iterations = iteration;
        if !curvature.is_finite() {
            report.status = PcgStatus::NonFinite;
            return report;
        }
        if curvature <= 0.0 {
            report.status = PcgStatus::NonPositiveCurvature { curvature };
            return report;
        }
        let (rr, next) = vectors.advance(rho / curvature);
        let residual = rr.sqrt();
        report.final_residual = residual;
        if !residual.is_finite() {
            report.status = PcgStatus::NonFinite;
            return report;
        }
        if residual <= tolerance {
            report.status = PcgStatus::Converged;
            return report;
        }
        vectors.turn(next / rho);
        rho = next;
    }
    report.status = PcgStatus::BudgetExhausted;
    report
}

/// [`PcgVectors`] on host slices, the product a callback.
struct HostVectors<'a, F> {
    product: F,
    inverse_diagonal: &'a [f64],
    rhs: &'a [f64],
    dim: usize,
    solution: &'a mut [f64],
    ws: &'a mut PcgWorkspace,
}

impl<F: FnMut(&[f64], &mut [f64])> PcgVectors for HostVectors<'_, F> {
    fn start(&mut self) -> (f64, f64) {
        let n = self.rhs.len();
        let ws = &mut *self.ws;
        for v in [&mut ws.r, &mut ws.z, &mut ws.p, &mut ws.q] {
            v.clear();
            v.resize(n, 0.0);
        }
        self.solution[..n].fill(0.0);
        for c in 0..n {
            ws.r[c] = if self.inverse_diagonal[c] == 0.0 {
                0.0
            } else {
                self.rhs[c]
            };
            ws.z[c] = self.inverse_diagonal[c] * ws.r[c];
            ws.p[c] = ws.z[c];
        }
        (
            tree_dot(&ws.r, &ws.r, self.dim, &mut ws.terms, &mut ws.scratch),
            tree_dot(&ws.r, &ws.z, self.dim, &mut ws.terms, &mut ws.scratch),
        )
    }

    fn curvature(&mut self) -> f64 {
        let ws = &mut *self.ws;
        (self.product)(&ws.p, &mut ws.q);
        for c in 0..ws.q.len() {
            if self.inverse_diagonal[c] == 0.0 {
                ws.q[c] = 0.0;
            }
        }
        tree_dot(&ws.p, &ws.q, self.dim, &mut ws.terms, &mut ws.scratch)
    }

    fn advance(&mut self, a: f64) -> (f64, f64) {
        let ws = &mut *self.ws;
        for c in 0..ws.r.len() {
            self.solution[c] += a * ws.p[c];
            ws.r[c] -= a * ws.q[c];
        }
        for c in 0..ws.r.len() {
            ws.z[c] = self.inverse_diagonal[c] * ws.r[c];
        }
        (
            tree_dot(&ws.r, &ws.r, self.dim, &mut ws.terms, &mut ws.scratch),
            tree_dot(&ws.r, &ws.z, self.dim, &mut ws.terms, &mut ws.scratch),
        )
    }

    fn turn(&mut self, beta: f64) {
        let ws = &mut *self.ws;
        for c in 0..ws.p.len() {
            ws.p[c] = ws.z[c] + beta * ws.p[c];
        }
    }
}

/// Solves H d = `rhs` from d = 0 by PCG with the diagonal preconditioner
/// `inverse_diagonal` (0 freezes a coordinate) over host slices;
/// `product(p, out)` writes H p. `dim` is the per-particle width of the
/// dot products' terms. The iterate is left in `solution`.
pub fn pcg<F: FnMut(&[f64], &mut [f64])>(
    product: F,
    inverse_diagonal: &[f64],
    rhs: &[f64],
    dim: usize,
    settings: PcgSettings,
    solution: &mut [f64],
    ws: &mut PcgWorkspace,
) -> PcgReport {
    let mut vectors = HostVectors {
        product,
        inverse_diagonal,
        rhs,
        dim,
        solution,
        ws,
    };
    pcg_on(&mut vectors, settings)
}

/// The Newton step's CG stop ‖r‖₂ ≤ f · r_k · s (docs/implicit.md §7 step
/// 7, §11): the forcing f = min(¼, √(r_k/r_0)) relative to the Newton
/// residual r_k **in the authored criterion's units**, s converting them
/// to the ‖·‖₂ of gradient units: 1 for the packed gradient, min_i m_i h²
/// over the free particles (`mass` 0: fixed) for the acceleration residual
/// (a particle's acceleration error is |r_i|/(m_i h²) ≤ ‖r‖₂/(m_min h²)).
/// A tolerance relative to ‖g‖₂ instead lets the heaviest particles set
/// it: on the 1:10⁶ chain the light beads' directions were then useless
/// and Newton stalled at its budget (`tests/implicit/step.rs`).
pub fn newton_cg_tolerance(
    criterion: Convergence,
    residual: f64,
    first: f64,
    mass: &[f64],
    h: f64,
) -> f64 {
    let forcing = (residual / first).sqrt().min(0.25);
    let scale = match criterion {
        Convergence::PackedGradient { .. } => 1.0,
        Convergence::MaxAccelerationResidual { .. } => {
            let lightest = mass
                .iter()
                .copied()
                .filter(|&m| m > 0.0)
                .fold(f64::INFINITY, f64::min);
            lightest * h * h
        }
    };
    forcing * residual * scale
}
