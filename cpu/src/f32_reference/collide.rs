//! One particle-contact iteration in f32, as `shaders/collide.wgsl`
//! computes it (contact_snapshot, then collide): averaged gather-Jacobi,
//! every particle over its own ascending list.
//!
//! ```text
//! y = x                                   (the iterate every pair reads)
//! the pair's c: core's kinds::particle_contact (the golden pair pass's code)
//! particle k, partner m, (i, j) = (min, max):
//!   d = y_j − y_i;  |d| = √(Σ_a d_a²);  C = |d| − (r_i + r_j)
//!   active iff C < 0 and |d| > 0;  n = d · (1/|d|);  s = −C;  c = n s
//!   μ > 0:  Δr = (y_j − p_j) − (y_i − p_i);  t = Δr − (Δr·n) n
//!           c −= t · (1 if |t| ≤ μ s else μ s / |t|)
//!   w_k ≠ 0:  Σ += ∓(w_k / (w_i + w_j)) c     (− for k = i), a_k += 1
//! x_k = y_k + Σ / a_k                      (a_k > 0)
//! ```
//! Both particles of a pair compute its correction with the same
//! operations on the same operands; `ahead[k]` counts k's active pairs
//! with m > k (each pair once: the step's active contacts).
//! Failures as the device reports them: a non-finite |d| names the pair's
//! lower particle, a non-finite new position its particle, and a pair
//! failure anywhere wins.

// Coordinate loops index several arrays at once, as a kernel does.
#![allow(clippy::needless_range_loop)]

use super::Particles;
use hyperpbd_core::kinds::particle_contact::pair_correction;

/// The contact constants as stored: radii and Coulomb μ (f32).
pub struct Contact<'a> {
    pub radius: &'a [f32],
    pub mu: f32,
    pub lists: &'a [Vec<u32>],
}

/// One iteration on `s.x` (`s.p`: the substep start); the failing
/// particle, as the device names it.
pub fn collide(s: &mut Particles, c: &Contact, ahead: &mut [u32]) -> Result<(), usize> {
    let n = s.dim;
    let count = c.radius.len();
    let y = s.x.clone();
    let (p, w, r) = (&s.p, &s.w, c.radius);
    // atomicMin over i (pairs) and count + k (positions).
    let mut failed = usize::MAX;
    let mut sum = vec![0.0f32; n];
    let mut d = vec![0.0f32; n];
    let mut out = vec![0.0f32; n];
    'particles: for k in 0..count {
        let (yk, pk) = (&y[k * n..(k + 1) * n], &p[k * n..(k + 1) * n]);
        let (rk, wk) = (r[k], w[k]);
        sum.fill(0.0);
        let mut touching = 0u32;
        let mut pushing = 0u32;
        for &m in &c.lists[k] {
            let m = m as usize;
            let (ym, pm) = (&y[m * n..(m + 1) * n], &p[m * n..(m + 1) * n]);
            let lower = k < m;
            let mut len2 = 0.0f32;
            for a in 0..n {
                d[a] = if lower { ym[a] - yk[a] } else { yk[a] - ym[a] };
                len2 += d[a] * d[a];
            }
            let dist = len2.sqrt();
            if !dist.is_finite() {
                failed = failed.min(k.min(m));
                continue 'particles;
            }
            // IEEE addition commutes: the WGSL's r_i + r_j in either order.
            let reach = rk + r[m];
            // Δr = (y_j − p_j) − (y_i − p_i), (i, j) = (min, max).
            let slip = |a: usize| {
                if lower {
                    (ym[a] - pm[a]) - (yk[a] - pk[a])
                } else {
                    (yk[a] - pk[a]) - (ym[a] - pm[a])
                }
            };
            if !pair_correction(&mut d, (dist, reach, c.mu), slip, &mut out) {
                continue;
            }
            if lower {
                pushing += 1;
            }
            if wk == 0.0 {
                continue;
            }
            let wm = w[m];
            let share = wk / (wk + wm);
            let sign = if lower { -share } else { share };
            for a in 0..n {
                sum[a] += sign * out[a];
            }
            touching += 1;
        }
        ahead[k] = pushing;
        if touching == 0 {
            continue;
        }
        let active = touching as f32;
        let mut ok = true;
        for a in 0..n {
            let xk = yk[a] + sum[a] / active;
            s.x[k * n + a] = xk;
            ok = ok && xk.is_finite();
        }
        if !ok {
            failed = failed.min(count + k);
        }
    }
    match failed {
        usize::MAX => Ok(()),
        index => Err(index.checked_sub(count).unwrap_or(index)),
    }
}

/// The inputs of `GpuCollide::iterate` (f64, rounded to f32 once as the
/// device stores them; no origin shift).
pub struct Iteration<'a> {
    pub dim: usize,
    pub x: &'a [f64],
    pub p: &'a [f64],
    pub inverse_mass: &'a [f64],
    pub radius: &'a [f64],
    /// Particle k's partners in the order the device reads them.
    pub lists: &'a [Vec<u32>],
    pub friction: f64,
}

/// `iterations` contact iterations on given lists, as `GpuCollide` runs
/// them; the positions read back, or the particle that failed first.
pub fn iterate(input: &Iteration, iterations: u32) -> Result<Vec<f64>, usize> {
    let round = |v: &[f64]| v.iter().map(|&v| v as f32).collect::<Vec<f32>>();
    let mut s = Particles {
        dim: input.dim,
        x: round(input.x),
        v: Vec::new(),
        p: round(input.p),
        force: Vec::new(),
        w: round(input.inverse_mass),
        gravity_scale: Vec::new(),
    };
    let radius = round(input.radius);
    let contact = Contact {
        radius: &radius,
        mu: input.friction as f32,
        lists: input.lists,
    };
    let mut ahead = vec![0u32; radius.len()];
    for _ in 0..iterations {
        collide(&mut s, &contact, &mut ahead)?;
    }
    Ok(s.x.iter().map(|&x| f64::from(x)).collect())
}
