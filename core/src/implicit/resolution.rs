//! The rounding floor of F's change over a full Newton step Δ
//! (docs/implicit.md §7 step 11): below it a line search cannot tell a
//! decrease from rounding, so a step that finds no decrease ends at the
//! floor instead of failing. One formula for every backend: the GPU's
//! host reads its buffers back and calls the same functions.
//!
//! ```text
//! resolution = (N + 4) ε/2 (inertia + h² work + 2h² energy) + 2h² force
//! inertia = Σ_i m_i Σ_a |Δ_ia| (|x_ia − x~_ia| + |Δ_ia|)      free particles, index order
//! work    = Σ_i Σ_a |load_ia Δ_ia|
//! energy  = Σ_i |E_i| + Σ_e |E_e|                            particle terms, then elements
//! force   = Σ_i |b'| δd (particles) + Σ_e (|∂E/∂C| δC or |b'| δd)
//! spring:  |∂E/∂C| δC = (c/α) γ (c + |rest|),  c = √(2Eα)     (C = value − rest cancels)
//! ball:    |b'(d)| γ (ℓ + r_i + r_j),  ℓ = |x_j − x_i|,  γ = (N + 4) ε
//! ```
//! ε is f64's on the golden path; the `_at` forms take the ε of the
//! precision the values were computed in (the GPU's f32 step: ε₃₂, its
//! per-particle force terms computed by the kernel with its own ε) and add
//! the second-order terms δC²/(2α), ½ b'' δd², which f32 needs where δ
//! exceeds C (an unstretched stiff link) and f64 does not.

use crate::barrier::BarrierLaw;

/// The four sums of [`change_resolution`].
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ResolutionSums {
    /// Σ m Σ|Δ|(|x − x~| + |Δ|).
    pub inertia: f64,
    /// Σ |load·Δ| (per coordinate).
    pub work: f64,
    /// Σ |E| of the particle terms.
    pub energy: f64,
    /// Σ |b'| δd of the particle terms.
    pub force: f64,
}

/// The particle sums over the free particles in index order; `terms`
/// holds per particle `stride` values with the particle's energy at
/// `stride − 2` and its force rounding at `stride − 1`.
#[allow(clippy::too_many_arguments)]
pub fn particle_sums(
    dim: usize,
    mass: &[f64],
    x: &[f64],
    prediction: &[f64],
    load: &[f64],
    direction: &[f64],
    terms: &[f64],
    stride: usize,
) -> ResolutionSums {
    let mut sums = ResolutionSums::default();
    for i in 0..mass.len() {
        if mass[i] == 0.0 {
            continue;
        }
        let mut own = 0.0;
        for a in 0..dim {
            let k = i * dim + a;
            let s = direction[k].abs();
            own += s * ((x[k] - prediction[k]).abs() + s);
            sums.work += (load[k] * direction[k]).abs();
        }
        sums.inertia += mass[i] * own;
        sums.energy += terms[i * stride + stride - 2].abs();
        sums.force += terms[i * stride + stride - 1];
    }
    sums
}

/// A spring's |∂E/∂C| δC from its energy E = C²/(2α) (f64).
pub fn spring_rounding(energy: f64, compliance: f64, rest: f64, dim: usize) -> f64 {
    let gamma = (dim as f64 + 4.0) * f64::EPSILON;
    let c = (2.0 * energy * compliance).sqrt();
    c / compliance * gamma * (c + rest.abs())
}

/// A spring's energy rounding for values computed at machine epsilon
/// `epsilon` (the GPU's f32 step: `f32::EPSILON`): [`spring_rounding`]'s
/// first-order term plus the second-order δC²/(2α). In f32 δC (relative
/// to ℓ + rest) can exceed C itself — an unstretched stiff link has C = 0
/// and a first-order term of 0, while its computed energy is up to
/// δC²/(2α) — so the f32 floor needs it; in f64 it is below ε² relative
/// and the golden floor leaves it out.
pub fn spring_rounding_at(
    energy: f64,
    compliance: f64,
    rest: f64,
    dim: usize,
    epsilon: f64,
) -> f64 {
    let gamma = (dim as f64 + 4.0) * epsilon;
    let c = (2.0 * energy * compliance).sqrt();
    let delta = gamma * (c + rest.abs());
    c / compliance * delta + delta * delta / (2.0 * compliance)
}

/// A ball pair's |b'(d)| δd at `points` = (x_i, x_j) (f64).
pub fn ball_rounding(law: &BarrierLaw, points: &[f64], radii: (f64, f64), dim: usize) -> f64 {
    let gamma = (dim as f64 + 4.0) * f64::EPSILON;
    let mut length = 0.0;
    for a in 0..dim {
        let d = points[dim + a] - points[a];
        length += d * d;
    }
    let slope = law.evaluate(length.sqrt() - radii.0 - radii.1).1;
    slope.abs() * gamma * (length.sqrt() + radii.0 + radii.1)
}

/// A ball pair's energy rounding at machine epsilon `epsilon`:
/// [`ball_rounding`]'s |b'| δd plus the second-order ½ b''(d) δd² (see
/// [`spring_rounding_at`]; b'' is largest near contact).
pub fn ball_rounding_at(
    law: &BarrierLaw,
    points: &[f64],
    radii: (f64, f64),
    dim: usize,
    epsilon: f64,
) -> f64 {
    let gamma = (dim as f64 + 4.0) * epsilon;
    let mut length = 0.0;
    for a in 0..dim {
        let d = points[dim + a] - points[a];
        length += d * d;
    }
    let (_, slope, curvature) = law.evaluate(length.sqrt() - radii.0 - radii.1);
    let delta = gamma * (length.sqrt() + radii.0 + radii.1);
    slope.abs() * delta + 0.5 * curvature * delta * delta
}

/// The floor itself, from the particle sums and the elements' Σ|E_e| and
/// Σ force rounding (element order), for f64 values.
pub fn change_resolution(
    dim: usize,
    h: f64,
    particles: ResolutionSums,
    element_energy: f64,
    element_force: f64,
) -> f64 {
    change_resolution_at(
        dim,
        h,
        particles,
        element_energy,
        element_force,
        f64::EPSILON,
    )
}

/// [`change_resolution`] for values computed at machine epsilon
/// `epsilon` (the GPU's f32 step passes `f32::EPSILON`; its particle
/// force terms already carry the kernel's own ε). With `f64::EPSILON` it
/// is [`change_resolution`] bit for bit (same operations, same order).
pub fn change_resolution_at(
    dim: usize,
    h: f64,
    particles: ResolutionSums,
    element_energy: f64,
    element_force: f64,
    epsilon: f64,
) -> f64 {
    let h2 = h * h;
    (dim as f64 + 4.0)
        * 0.5
        * epsilon
        * (particles.inertia + h2 * particles.work + 2.0 * h2 * (particles.energy + element_energy))
        + 2.0 * h2 * (particles.force + element_force)
}
