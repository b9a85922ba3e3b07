//! The correction of one particle–particle contact (two balls), one code
//! for both precisions: the golden path's pair pass (`cpu/src/collide.rs`)
//! runs it in f64, the f32 reference (`collide.wgsl`'s order) in f32.
//!
//! ```text
//! d = x_j − x_i, |d| given;  C = |d| − (r_i + r_j);  active iff C < 0 and |d| > 0
//! n = d · (1/|d|);  s = −C;  c = n s
//! μ > 0:  Δr = (x_j − p_j) − (x_i − p_i);  Δr_n = Σ_a Δr_a n_a;  t = Δr − Δr_n n
//!         c −= t · (1 if |t| ≤ μ s else μ s / |t|)
//! ```

// Coordinate loops index several arrays at once, as a kernel does.
#![allow(clippy::needless_range_loop)]

use super::ProjectionReal;

/// c of the pair with separation `d` (normalised in place when active),
/// length `len` and radii sum `reach`, friction `mu` and relative
/// displacement Δr (`slip(a)`, read per axis), into `out`; false (and
/// `out` untouched) when the pair is not active.
#[inline(always)]
pub fn pair_correction<R: ProjectionReal>(
    d: &mut [R],
    (len, reach, mu): (R, R, R),
    slip: impl Fn(usize) -> R,
    out: &mut [R],
) -> bool {
    let zero = R::constant(0.0);
    let c = len - reach;
    if !(c < zero && len > zero) {
        return false;
    }
    let n = d.len();
    let s = -c;
    let inv = R::constant(1.0) / len;
    for a in 0..n {
        d[a] *= inv;
    }
    for a in 0..n {
        out[a] = d[a] * s;
    }
    if mu > zero {
        let mut dn = zero;
        for a in 0..n {
            dn += slip(a) * d[a];
        }
        let mut t2 = zero;
        for a in 0..n {
            let t = slip(a) - dn * d[a];
            t2 += t * t;
        }
        let t_norm = t2.sqrt();
        let bound = mu * s;
        let scale = if t_norm <= bound {
            R::constant(1.0)
        } else {
            bound / t_norm
        };
        for a in 0..n {
            let t = slip(a) - dn * d[a];
            out[a] -= t * scale;
        }
    }
    true
}
