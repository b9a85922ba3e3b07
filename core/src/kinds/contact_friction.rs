//! Coulomb friction of an XPBD contact with unit normal n, one code for
//! both precisions: the golden path runs it in f64, the f32 reference in
//! f32 (`project.wgsl`'s static friction, `friction.wgsl` and
//! `motion.wgsl`'s dynamic friction, in this order).
//!
//! ```text
//! static   (in the projection, after the normal correction)
//!   Δ = x − p;  d_n = Σ_a Δ_a n_a;  t = Δ − d_n n;  |t| ≤ bound (= μ w λ) ⇒ x −= t
//! dynamic  (a velocity response; u the velocity relative to the obstacle)
//!   u_n = n·u (the caller's);  u_t = u − u_n n;  |u_t| = √(Σ_a u_t,a²)
//!   |u_t| > 0 ⇒ v −= u_t · min(limit, |u_t|) / |u_t|     (limit = μ w λ / h)
//! ```
//! The caller passes u_n: the golden path forms it with `Iterator::sum`
//! (which starts from −0.0), the f32 reference and the WGSL with a loop
//! from +0.0. The two differ only in the sign of an all-zero sum, and that
//! stays a named divergence (docs/bounds.md, "One numeric code").

// Coordinate loops index several arrays at once, as a kernel does.
#![allow(clippy::needless_range_loop)]

use super::ProjectionReal;

/// Static friction of an active contact: the tangential part of x − `p`
/// is cancelled whole if its length is at most `bound` (module docs).
#[inline(always)]
pub fn static_friction<R: ProjectionReal>(normal: &[R], bound: R, p: &[R], x: &mut [R]) {
    let n = x.len();
    let mut dn = R::constant(0.0);
    for a in 0..n {
        dn += (x[a] - p[a]) * normal[a];
    }
    let mut t2 = R::constant(0.0);
    for a in 0..n {
        let t = (x[a] - p[a]) - dn * normal[a];
        t2 += t * t;
    }
    if t2.sqrt() <= bound {
        for a in 0..n {
            let t = (x[a] - p[a]) - dn * normal[a];
            x[a] -= t;
        }
    }
}

/// Dynamic friction on a velocity `v` against a resting obstacle (u = v,
/// `vn` = n·v): v −= v_t · min(limit, |v_t|) / |v_t|. False (and `v`
/// untouched) when |v_t| = 0.
#[inline(always)]
pub fn clamp_tangential<R: ProjectionReal>(normal: &[R], limit: R, vn: R, v: &mut [R]) -> bool {
    clamp_with(normal, limit, vn, |v, a| v[a], v)
}

/// Dynamic friction on `v` against a moving obstacle: `relative` is u, the
/// velocity relative to it, `un` = n·u; v −= u_t · min(limit, |u_t|) /
/// |u_t|. False (and `v` untouched) when |u_t| = 0.
#[inline(always)]
pub fn clamp_relative<R: ProjectionReal>(
    normal: &[R],
    limit: R,
    (un, relative): (R, &[R]),
    v: &mut [R],
) -> bool {
    clamp_with(normal, limit, un, |_, a| relative[a], v)
}

/// The clamp of the module docs with u_a = `u(v, a)` (read before v_a is
/// written, so u may be v itself).
#[inline(always)]
fn clamp_with<R: ProjectionReal>(
    normal: &[R],
    limit: R,
    un: R,
    u: impl Fn(&[R], usize) -> R,
    v: &mut [R],
) -> bool {
    let mut t2 = R::constant(0.0);
    for a in 0..v.len() {
        let t = u(v, a) - un * normal[a];
        t2 += t * t;
    }
    let ut = t2.sqrt();
    if ut == R::constant(0.0) {
        return false;
    }
    let scale = limit.min(ut) / ut;
    for a in 0..v.len() {
        let t = u(v, a) - un * normal[a];
        v[a] -= t * scale;
    }
    true
}

/// n·u summed from +0.0 in axis order (the f32 reference's and the
/// WGSL's; the golden path's `Iterator::sum` starts from −0.0).
#[inline(always)]
pub fn dot_from_zero<R: ProjectionReal>(normal: &[R], u: &[R]) -> R {
    crate::geometry::sum_of_products(0..u.len(), |a| (normal[a], u[a]))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sticking_and_sliding_in_both_precisions() {
        let normal = [0.0, 1.0];
        let mut x = [0.3, 1.0];
        static_friction(&normal, 0.5, &[0.0, 0.0], &mut x);
        assert_eq!(x, [0.0, 1.0]);
        let mut v = [2.0f32, -1.0];
        assert!(clamp_tangential(&[0.0, 1.0], 0.5, -1.0, &mut v));
        assert_eq!(v, [1.5, -1.0]);
        let mut v = [2.0, 0.0];
        assert!(clamp_relative(&normal, 5.0, (0.0, &[1.0, 0.0]), &mut v));
        assert_eq!(v, [1.0, 0.0]);
        assert!(!clamp_tangential(&normal, 1.0, 3.0, &mut [0.0, 3.0]));
    }
}
