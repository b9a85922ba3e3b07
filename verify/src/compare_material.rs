//! The rounding of one material element's XPBD projection: what
//! `FrameErrorModel` (`compare_frame.rs`) adds for the stvk and
//! neo_hookean families (derivation: docs/materials.md §7, "f32 bound").
//!
//! ```text
//! u = ε/2, γ_m = m u / (1 − m u); ‖·‖ Frobenius; f̄ = ‖|D||R|‖ ≥ ‖F̂‖, r̄ = ‖R‖
//! law      δF̂ ≤ γ_{k+2} f̄              δC ≤ 2 δF̂ ‖F̂‖ + δF̂² + γ_N (‖F̂‖ + δF̂)²   (‖F̂‖ = √tr C)
//!   stvk   δE ≤ ½δC + u‖E‖             δtr ≤ √k δE + γ_k Σ|E_ii|
//!          δΨ ≤ μ(2‖E‖δE + δE² + γ_{k²}‖E‖²) + λ(|tr E| δtr + ½δtr²) + γ_5 Ψ̄
//!          s̄ = 2μ‖E‖ + λ√k|tr E|       δS ≤ 2μ δE + λ√k δtr + γ_4 s̄
//!   neo_h. δC' = δC + γ_{k+1} tr C      (Cholesky backward error, ‖|L||Lᵀ|‖ ≤ tr C)
//!          ρ_J = √(tr C⁻¹)(δF̂ + γ_k ‖|L||U|‖) + γ_k     k = N (elimination, its |L||U|)
//!              = ½ ‖C⁻¹‖ δC' + γ_k                        k < N (J = Π L_jj)
//!          δln J ≤ −ln(1 − ρ_J) + e_log,  e_log = 2⁻²¹ + 6u(|ln J| + 2ρ_J)  (f32: Vulkan's log allowance)
//!                                                 10u(|ln J| + 2ρ_J)       (f64 ln_real)
//!          δC⁻¹ ≤ ‖C⁻¹‖₂² δC' + 2‖C⁻¹‖₂^½ γ_k tr C⁻¹ √(tr C) + γ_k tr C⁻¹
//!          δΨ ≤ ½μ(√k δC + γ_k tr C + u|tr C − k|) + μ δln + λ(|ln J| δln + ½δln²) + γ_5 Ψ̄
//!          s̄ = μ‖I − C⁻¹‖ + λ|ln J|‖C⁻¹‖     (μ(δ_ij − C⁻¹_ij) rounds after the cancellation)
//!          δS ≤ (μ + λ(|ln J| + δln)) δC⁻¹ + λ δln ‖C⁻¹‖ + γ_4 (s̄ + μ δC⁻¹)
//! ∇W       δP̂ ≤ δF̂ s̄ + ‖F̂‖ δS + δF̂ δS + γ_k (‖F̂‖ + δF̂)(s̄ + δS);  p̄ = ‖F̂‖ s̄ + δP̂
//!          δH ≤ V_0 r̄ (δP̂ + γ_{k+3} p̄);  h̄ = V_0 p̄ r̄
//!          δ∇_j W ≤ δH (j ≥ 1),  δ∇_0 W ≤ √k (δH + γ_k h̄)
//!          δW ≤ V_0 (δΨ + γ_2 Ψ̄)         (Ψ̄: the sum of |terms| of Ψ)
//! update   with C = √(2W), G = Σ_j w_j |∇_j W|², A = C + α~λ, the kernel's
//!          x_j += w_j ∇_j C Δλ is exactly
//!            Δx_j = −w_j ∇_j W Φ,   Φ = C²/(G + α~C²) + α~λ · C/(G + α~C²) = q + α~λ ψ
//!            Δλ  = −A q
//!          C̃ ∈ [√(2(W − δW)₊)(1 − u), √(2(W + δW))(1 + u)],  G̃ ∈ Σ w (|∇W| ± δ∇W)₊² (1 ± γ_{N+k+4}),
//!          α~ (1 ± u), λ ± δλ; q rises with C and falls with G, α~; ψ falls with G, α~
//!          and peaks at C = √(G/α~): interval enclosures Φ̃, Δλ̃ (× (1 ± γ_5), the
//!          division, the products w ∇C Δλ), then
//!            δΔx_j ≤ w_j (|∇_j W| max|Φ̃ − Φ| + δ∇_j W max|Φ̃|)
//!          capped by AM–GM (any ∇C̃: w|g|/(w|g|² + α~) ≤ 1/(2√(w α~))):
//!            |Δx̃_j| ≤ √w_j max|Ã| / (2√α~),   |Δλ̃| ≤ max|Ã| / α~
//!          λ' = λ + Δλ = (1 − α~q) λ − q C with α~q ∈ [0, 1]: λ̃' lies in the hull of
//!          λ̃ and −C̃/α~, so over the substep's iterations (λ = 0 at its start)
//!            δλ' ≤ min(δλ + δΔλ, max dist(λ', hull)) + γ_5 max|Ã|/α~ + u|λ'|
//! ```
//! First order in u where a product of two δ's is dropped (the δ² terms
//! kept are the ones of the same order as the rest near rest). The input
//! coordinates are the same in both runs: what the state's own rounding
//! and its propagation cost is the XPBD model's (`compare_frame.rs`).

use hyperpbd_core::material::{
    Law, LawRefusal, MaterialElement, MaterialScratch, deformation_measures, element_energy,
};
use hyperpbd_core::{Family, Precision};

/// γ_m = m u / (1 − m u).
fn gamma(m: f64, u: f64) -> f64 {
    m * u / (1.0 - m * u)
}

fn frobenius(a: &[f64]) -> f64 {
    a.iter().map(|x| x * x).sum::<f64>().sqrt()
}

/// The rounding model of one precision: u and how `ln` errs.
#[derive(Clone, Copy, Debug)]
pub struct Rounding {
    /// u = ε/2.
    pub unit: f64,
    /// f32: the allowance of Vulkan's built-in log (2⁻²¹ absolute on
    /// [0.5, 2], 3 ulp outside), kept for the arithmetic `ln_f32.wgsl`
    /// (1 ulp where f32 rounds correctly; the allowance covers adapters
    /// where it does not); f64: `ln_real` (within 5 ulp, tests/materials/law.rs).
    pub builtin_log: bool,
}

impl Rounding {
    /// The model of `precision`.
    pub fn of(precision: Precision) -> Self {
        Rounding {
            unit: precision.epsilon() / 2.0,
            builtin_log: precision == Precision::F32,
        }
    }

    /// Error of ln at J with relative uncertainty ρ of J.
    fn log_error(self, ln_j: f64, rho: f64) -> f64 {
        let magnitude = ln_j.abs() + 2.0 * rho;
        if self.builtin_log {
            2f64.powi(-21) + 6.0 * self.unit * magnitude
        } else {
            10.0 * self.unit * magnitude
        }
    }
}

/// W, |∇_j W| and their rounding bounds for one element.
#[derive(Clone, Debug)]
pub struct LawRounding {
    /// W (f64, the golden path's).
    pub energy: f64,
    /// δW.
    pub energy_error: f64,
    /// |∇_j W| per vertex.
    pub gradient: Vec<f64>,
    /// δ∇_j W per vertex.
    pub gradient_error: Vec<f64>,
}

/// ‖|L||U|‖ of Gaussian elimination with partial pivoting of the n × n
/// `a` (row-major; the pivot rule of `geometry::determinant`); ∞ at a zero
/// pivot.
fn elimination_magnitude(a: &[f64], n: usize) -> f64 {
    let mut u = a[..n * n].to_vec();
    let mut l = vec![0.0; n * n];
    for col in 0..n {
        let mut pivot_row = col;
        for row in col + 1..n {
            if u[row * n + col].abs() > u[pivot_row * n + col].abs() {
                pivot_row = row;
            }
        }
        let pivot = u[pivot_row * n + col];
        if pivot == 0.0 {
            return f64::INFINITY;
        }
        for c in 0..n {
            u.swap(col * n + c, pivot_row * n + c);
            if c < col {
                l.swap(col * n + c, pivot_row * n + c);
            }
        }
        l[col * n + col] = 1.0;
        for row in col + 1..n {
            let factor = u[row * n + col] / pivot;
            l[row * n + col] = factor;
            u[row * n + col] = 0.0;
            for c in col + 1..n {
                u[row * n + c] -= factor * u[col * n + c];
            }
        }
    }
    let mut sum = 0.0;
    for i in 0..n {
        for j in 0..n {
            let p: f64 = (0..n).map(|m| (l[i * n + m] * u[m * n + j]).abs()).sum();
            sum += p * p;
        }
    }
    sum.sqrt()
}

/// (Ψ̄, δΨ, s̄, δS) of the law (module docs).
struct Stress {
    psi_abs: f64,
    psi_error: f64,
    stress: f64,
    stress_error: f64,
}

/// The law bounds of the module docs for one element.
pub fn law_rounding(
    element: MaterialElement<'_>,
    rounding: Rounding,
    scratch: &mut MaterialScratch,
) -> Result<LawRounding, LawRefusal> {
    let (points, dim, rest) = (element.points, element.dim, element.rest);
    let u = rounding.unit;
    let k = element.order();
    let kf = k as f64;
    let mut grad = vec![0.0; points.len()];
    let energy = element_energy(element, &mut grad, scratch)?;
    let m = deformation_measures(points, dim, rest, scratch);
    let mut image = vec![0.0; dim * k];
    let mut magnitude = 0.0;
    for a in 0..dim {
        for j in 0..k {
            let (mut f, mut f_abs) = (0.0, 0.0);
            for i in 0..=j {
                let term = (points[(i + 1) * dim + a] - points[a]) * rest.frame[i * k + j];
                f += term;
                f_abs += term.abs();
            }
            image[a * k + j] = f;
            magnitude += f_abs * f_abs;
        }
    }
    let f_bar = f64::sqrt(magnitude);
    let r_bar = frobenius(rest.frame);
    // ‖F̂‖ = √tr C: what C = F̂ᵀF̂ and P̂ = F̂ S round relative to.
    let f_norm = (0..k)
        .map(|i| m.right_cauchy_green[i * k + i])
        .sum::<f64>()
        .sqrt();
    let d_f = gamma(kf + 2.0, u) * f_bar;
    let d_c = 2.0 * d_f * f_norm + d_f * d_f + gamma(dim as f64, u) * (f_norm + d_f).powi(2);
    let (mu, lambda) = (element.material.lame.mu, element.material.lame.lambda);
    let law = match element.material.law {
        Law::StVenantKirchhoff => {
            let e = &m.green_strain;
            let e_norm = frobenius(e);
            let trace: f64 = (0..k).map(|i| e[i * k + i]).sum();
            let trace_abs: f64 = (0..k).map(|i| e[i * k + i].abs()).sum();
            let d_e = 0.5 * d_c + u * e_norm;
            let d_tr = kf.sqrt() * d_e + gamma(kf, u) * trace_abs;
            let square = e_norm * e_norm;
            let psi_abs = mu * square + 0.5 * lambda * trace * trace;
            let d_square = 2.0 * e_norm * d_e + d_e * d_e + gamma(kf * kf, u) * square;
            let stress = 2.0 * mu * e_norm + lambda * kf.sqrt() * trace.abs();
            Stress {
                psi_abs,
                psi_error: mu * d_square
                    + lambda * (trace.abs() * d_tr + 0.5 * d_tr * d_tr)
                    + gamma(5.0, u) * psi_abs,
                stress,
                stress_error: 2.0 * mu * d_e + lambda * kf.sqrt() * d_tr + gamma(4.0, u) * stress,
            }
        }
        Law::NeoHookean => {
            // Eigenvalues of C⁻¹: 1/λ_i² of the principal stretches.
            let inverse: Vec<f64> = m
                .principal_stretches
                .iter()
                .map(|s| 1.0 / (s * s))
                .collect();
            let inv_norm = frobenius(&inverse);
            // ‖I − C⁻¹‖: the stress's μ term after its cancellation.
            let deviation = inverse
                .iter()
                .map(|c| (1.0 - c) * (1.0 - c))
                .sum::<f64>()
                .sqrt();
            let inv_two = inverse.iter().fold(0.0f64, |a, &b| a.max(b));
            let inv_trace: f64 = inverse.iter().sum();
            let trace: f64 = (0..k).map(|i| m.right_cauchy_green[i * k + i]).sum();
            let d_ct = d_c + gamma(kf + 1.0, u) * trace;
            let rho = if k == dim {
                inv_trace.sqrt() * (d_f + gamma(kf, u) * elimination_magnitude(&image, k))
                    + gamma(kf, u)
            } else {
                0.5 * inv_norm * d_ct + gamma(kf, u)
            };
            let ln_j = m.measure_ratio.ln();
            let d_ln = if rho < 1.0 {
                -(1.0 - rho).ln() + rounding.log_error(ln_j, rho)
            } else {
                f64::INFINITY
            };
            let d_inv = inv_two * inv_two * d_ct
                + 2.0 * inv_two.sqrt() * gamma(kf, u) * inv_trace * trace.sqrt()
                + gamma(kf, u) * inv_trace;
            let psi_abs =
                (0.5 * mu * (trace - kf)).abs() + (mu * ln_j).abs() + 0.5 * lambda * ln_j * ln_j;
            let stress = mu * deviation + lambda * ln_j.abs() * inv_norm;
            Stress {
                psi_abs,
                psi_error: 0.5
                    * mu
                    * (kf.sqrt() * d_c + gamma(kf, u) * trace + u * (trace - kf).abs())
                    + mu * d_ln
                    + lambda * (ln_j.abs() * d_ln + 0.5 * d_ln * d_ln)
                    + gamma(5.0, u) * psi_abs,
                stress,
                stress_error: (mu + lambda * (ln_j.abs() + d_ln)) * d_inv
                    + lambda * d_ln * inv_norm
                    + gamma(4.0, u) * (stress + mu * d_inv),
            }
        }
    };
    let (s_bar, d_s) = (law.stress, law.stress_error);
    let d_p =
        d_f * s_bar + f_norm * d_s + d_f * d_s + gamma(kf, u) * (f_norm + d_f) * (s_bar + d_s);
    let p_bar = f_norm * s_bar + d_p;
    let v0 = rest.measure;
    let d_h = v0 * r_bar * (d_p + gamma(kf + 3.0, u) * p_bar);
    let h_bar = v0 * p_bar * r_bar;
    let gradient: Vec<f64> = grad.chunks_exact(dim).map(frobenius).collect();
    let gradient_error = (0..=k)
        .map(|j| {
            if j == 0 {
                kf.sqrt() * (d_h + gamma(kf, u) * h_bar)
            } else {
                d_h
            }
        })
        .collect();
    Ok(LawRounding {
        energy,
        energy_error: v0 * (law.psi_error + gamma(2.0, u) * law.psi_abs),
        gradient,
        gradient_error,
    })
}

/// [lo, hi] of C̃ = √(2W̃).
fn constraint_range(law: &LawRounding, u: f64) -> (f64, f64) {
    let (w, dw) = (law.energy, law.energy_error);
    (
        (2.0 * (w - dw).max(0.0)).sqrt() * (1.0 - u),
        (2.0 * (w + dw).max(0.0)).sqrt() * (1.0 + u),
    )
}

/// max |C̃ − C| of one element (the residual's f32 evaluation).
pub fn constraint_error(law: &LawRounding, u: f64) -> f64 {
    let c = (2.0 * law.energy.max(0.0)).sqrt();
    let (lo, hi) = constraint_range(law, u);
    (hi - c).max(c - lo)
}

/// An interval [lo, hi].
#[derive(Clone, Copy, Debug)]
struct Range(f64, f64);

impl Range {
    fn mul(self, o: Range) -> Range {
        let p = [self.0 * o.0, self.0 * o.1, self.1 * o.0, self.1 * o.1];
        Range(
            p.iter().fold(f64::INFINITY, |a, &b| a.min(b)),
            p.iter().fold(f64::NEG_INFINITY, |a, &b| a.max(b)),
        )
    }
    fn add(self, o: Range) -> Range {
        Range(self.0 + o.0, self.1 + o.1)
    }
    /// The enclosure widened by a relative rounding γ.
    fn widen(self, g: f64) -> Range {
        let r = g * self.0.abs().max(self.1.abs());
        Range(self.0 - r, self.1 + r)
    }
    /// Largest distance from `x` (∞ for a NaN end).
    fn off(self, x: f64) -> f64 {
        let d = (self.1 - x).max(x - self.0);
        if d.is_nan() { f64::INFINITY } else { d }
    }
    fn abs_max(self) -> f64 {
        self.0.abs().max(self.1.abs())
    }
}

/// q = C²/(G + α~C²) (0 at C = 0).
fn q(c: f64, g: f64, alpha: f64) -> f64 {
    if c == 0.0 {
        0.0
    } else {
        c * c / (g + alpha * c * c)
    }
}

/// ψ = C/(G + α~C²) (0 at C = 0).
fn psi(c: f64, g: f64, alpha: f64) -> f64 {
    if c == 0.0 {
        0.0
    } else {
        c / (g + alpha * c * c)
    }
}

/// Bounds on one projection's differences: per vertex |δΔx_j|, and |δΔλ|.
#[derive(Clone, Debug)]
pub struct ProjectionError {
    /// |Δx̃_j − Δx_j| per vertex.
    pub position: Vec<f64>,
    /// |Δλ̃ − Δλ|.
    pub multiplier: f64,
    /// |λ̃' − λ'| after the update (λ's error carried to the next iteration).
    pub multiplier_after: f64,
    /// The golden path's Δλ.
    pub step: f64,
}

/// The update bounds of the module docs for an element with law bounds
/// `law`, inverse masses `w` (per vertex), multiplier λ ± δλ and α~.
pub fn projection_error(
    law: &LawRounding,
    dim: usize,
    w: &[f64],
    lambda: (f64, f64),
    alpha: f64,
    u: f64,
) -> ProjectionError {
    let (l, dl) = lambda;
    let c = (2.0 * law.energy.max(0.0)).sqrt();
    let g: f64 = w.iter().zip(&law.gradient).map(|(w, g)| w * g * g).sum();
    // The golden path's update (no response where ∇C = 0).
    let (phi, step) = if c == 0.0 || g == 0.0 {
        (0.0, 0.0)
    } else {
        let a = c + alpha * l;
        (a * psi(c, g, alpha), -a * q(c, g, alpha))
    };
    let (c_lo, c_hi) = constraint_range(law, u);
    let m = gamma(dim as f64 + w.len() as f64 + 3.0, u);
    let (mut g_lo, mut g_hi) = (0.0, 0.0);
    for ((w, g), dg) in w.iter().zip(&law.gradient).zip(&law.gradient_error) {
        g_lo += w * (g - dg).max(0.0).powi(2);
        g_hi += w * (g + dg).powi(2);
    }
    let (g_lo, g_hi) = (g_lo * (1.0 - m), g_hi * (1.0 + m));
    let (a_lo, a_hi) = (alpha * (1.0 - u), alpha * (1.0 + u));
    let q_range = Range(q(c_lo, g_hi, a_hi), q(c_hi, g_lo, a_lo));
    let peak = (g_lo / a_lo).sqrt();
    let psi_hi = if (c_lo..=c_hi).contains(&peak) {
        if g_lo == 0.0 {
            f64::INFINITY
        } else {
            1.0 / (2.0 * (g_lo * a_lo).sqrt())
        }
    } else {
        psi(c_lo, g_lo, a_lo).max(psi(c_hi, g_lo, a_lo))
    };
    let psi_range = Range(psi(c_lo, g_hi, a_hi).min(psi(c_hi, g_hi, a_hi)), psi_hi);
    let alpha_lambda = Range(a_lo, a_hi).mul(Range(l - dl, l + dl));
    // −C̃ − α~λ̃: the product and the difference round (u each).
    let a_range = Range(c_lo, c_hi).add(alpha_lambda);
    let a_round = gamma(2.0, u) * (alpha_lambda.abs_max() + a_range.abs_max());
    let a_range = Range(a_range.0 - a_round, a_range.1 + a_round);
    let a_max = a_range.abs_max();
    let phi_range = q_range
        .add(alpha_lambda.mul(psi_range))
        .widen(gamma(5.0, u));
    let mut step_range = Range(-a_range.1, -a_range.0)
        .mul(q_range)
        .widen(gamma(5.0, u));
    if g_lo == 0.0 {
        // ∇C̃ may round to 0: the device then leaves λ as it is (Δλ̃ = 0).
        step_range = Range(step_range.0.min(0.0), step_range.1.max(0.0));
    }
    let position = w
        .iter()
        .zip(&law.gradient)
        .zip(&law.gradient_error)
        .map(|((&w, &g), &dg)| {
            let interval = w * (g * phi_range.off(phi) + dg * phi_range.abs_max());
            let cap =
                w * g * phi.abs() + w.sqrt() * a_max * (1.0 + gamma(5.0, u)) / (2.0 * a_lo.sqrt());
            if interval.is_nan() {
                cap
            } else {
                interval.min(cap)
            }
        })
        .collect();
    let cap = step.abs() + a_max / a_lo;
    let multiplier = step_range.off(step).min(cap);
    // λ̃' = λ̃ + Δλ̃ = (1 − α~q̃) λ̃ − q̃ C̃ with α~q̃ ∈ [0, 1]: a convex
    // combination of λ̃ and −C̃/α~, so errors in λ do not pile up.
    let after = l + step;
    let hull = Range((l - dl).min(-c_hi / a_lo), (l + dl).max(-c_lo / a_hi));
    let rounding = gamma(5.0, u) * a_max / a_lo + u * after.abs();
    let multiplier_after = (dl + multiplier).min(hull.off(after)) + rounding;
    ProjectionError {
        position,
        multiplier,
        multiplier_after,
        step,
    }
}

/// The vertices of element `slot` of `family` at `x` into `points`; their
/// particle indices.
fn gather<'a>(
    family: &'a Family,
    slot: usize,
    x: &[f64],
    dim: usize,
    points: &mut [f64],
) -> &'a [u32] {
    let arity = family.arity;
    let ids = &family.elements[slot * arity..(slot + 1) * arity];
    for (j, &i) in ids.iter().enumerate() {
        let i = i as usize;
        points[j * dim..(j + 1) * dim].copy_from_slice(&x[i * dim..(i + 1) * dim]);
    }
    ids
}

/// Per particle, the summed |δΔx| of projecting colour `color` of material
/// family `family` at positions `x` with multipliers `lambda` ± `lambda_error`
/// (updated in place to the errors after the projection); `inverse_mass`
/// per particle, α~ = compliance / h².
#[allow(clippy::too_many_arguments)]
pub fn color_error(
    family: &Family,
    color: usize,
    x: &[f64],
    dim: usize,
    inverse_mass: &[f64],
    lambda: &[f64],
    lambda_error: &mut [f64],
    alpha: f64,
    rounding: Rounding,
    out: &mut [f64],
) {
    let mut scratch = MaterialScratch::new();
    let mut points = vec![0.0; family.arity * dim];
    for slot in family.color(color) {
        let ids = gather(family, slot, x, dim, &mut points);
        let Some(element) = family.kind.material_element(slot, &points, dim) else {
            continue;
        };
        let w: Vec<f64> = ids.iter().map(|&i| inverse_mass[i as usize]).collect();
        let Ok(law) = law_rounding(element, rounding, &mut scratch) else {
            // The golden path refused this element: the frame fails before
            // any comparison, so no bound is needed; say so loudly.
            out.iter_mut().for_each(|e| *e = f64::INFINITY);
            return;
        };
        let l = lambda[slot];
        let p = projection_error(&law, dim, &w, (l, lambda_error[slot]), alpha, rounding.unit);
        lambda_error[slot] = p.multiplier_after;
        for (&i, (e, &w)) in ids.iter().zip(p.position.iter().zip(&w)) {
            if w > 0.0 {
                out[i as usize] += e;
            }
        }
    }
}

/// (max_e C_e in f64, max_e δC_e) of material family `family` at `x`: the
/// residual the golden path would report there and how far the device's
/// evaluation of it may be off.
pub fn residual_error(family: &Family, x: &[f64], dim: usize, rounding: Rounding) -> (f64, f64) {
    let mut scratch = MaterialScratch::new();
    let mut points = vec![0.0; family.arity * dim];
    let (mut worst, mut error) = (0.0f64, 0.0f64);
    for slot in 0..family.len() {
        gather(family, slot, x, dim, &mut points);
        let Some(element) = family.kind.material_element(slot, &points, dim) else {
            continue;
        };
        match law_rounding(element, rounding, &mut scratch) {
            Ok(law) => {
                worst = worst.max((2.0 * law.energy.max(0.0)).sqrt());
                error = error.max(constraint_error(&law, rounding.unit));
            }
            Err(_) => return (f64::INFINITY, f64::INFINITY),
        }
    }
    (worst, error)
}
