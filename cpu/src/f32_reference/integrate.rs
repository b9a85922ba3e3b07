//! Per-particle kernels in f32, as `shaders/integrate.wgsl` and
//! `shaders/friction.wgsl` compute them.
//!
//! ```text
//! predict   p = x;  for dynamic i: v += h (s g + w f);  x += h v
//! velocity  for dynamic i: v = (x − p) / h
//! damping   for dynamic i: v *= factor          (factor = exp(−rate h))
//! friction  for a contact with λ > 0:  v_n = n·v;  v_t = v − v_n n
//!           v −= v_t · min(μ w λ / h, |v_t|) / |v_t|
//! ```
//! Each returns the first particle that became non-finite.

// Coordinate loops index several arrays at once, as a kernel does.
#![allow(clippy::needless_range_loop)]

use super::Particles;
use hyperpbd_core::kinds::contact_friction::{clamp_tangential, dot_from_zero};

/// The prediction's reals: h, g, and which terms the plan has.
pub struct Predict<'a> {
    pub h: f32,
    pub gravity: Option<&'a [f32]>,
    pub force: bool,
}

pub fn predict(s: &mut Particles, terms: &Predict) -> Result<(), usize> {
    let n = s.dim;
    s.p.copy_from_slice(&s.x);
    let mut failed = None;
    for i in 0..s.w.len() {
        let w = s.w[i];
        if w == 0.0 {
            continue;
        }
        let mut ok = true;
        for a in 0..n {
            let mut acc = 0.0f32;
            if let Some(g) = terms.gravity {
                acc += s.gravity_scale[i] * g[a];
            }
            if terms.force {
                acc += w * s.force[i * n + a];
            }
            let vk = s.v[i * n + a] + terms.h * acc;
            let xk = s.x[i * n + a] + terms.h * vk;
            s.v[i * n + a] = vk;
            s.x[i * n + a] = xk;
            ok = ok && vk.is_finite() && xk.is_finite();
        }
        if !ok && failed.is_none() {
            failed = Some(i);
        }
    }
    failed.map_or(Ok(()), Err)
}

pub fn velocity(s: &mut Particles, h: f32) -> Result<(), usize> {
    let n = s.dim;
    let mut failed = None;
    for i in 0..s.w.len() {
        if s.w[i] == 0.0 {
            continue;
        }
        let mut ok = true;
        for a in 0..n {
            let vk = (s.x[i * n + a] - s.p[i * n + a]) / h;
            s.v[i * n + a] = vk;
            ok = ok && vk.is_finite();
        }
        if !ok && failed.is_none() {
            failed = Some(i);
        }
    }
    failed.map_or(Ok(()), Err)
}

pub fn damping(s: &mut Particles, factor: f32) {
    let n = s.dim;
    for i in 0..s.w.len() {
        if s.w[i] == 0.0 {
            continue;
        }
        for a in 0..n {
            s.v[i * n + a] *= factor;
        }
    }
}

/// Dynamic friction of one hyperplane family: `particles[e]` is the
/// particle of slot e, `lambda[e]` its multiplier.
pub struct Friction<'a> {
    pub normal: &'a [f32],
    pub mu: f32,
    pub h: f32,
    pub particles: &'a [u32],
    pub lambda: &'a [f32],
}

pub fn friction(s: &mut Particles, f: &Friction) -> Result<(), usize> {
    let n = s.dim;
    let normal = f.normal;
    let mut failed = None;
    for (&i, &l) in f.particles.iter().zip(f.lambda) {
        let i = i as usize;
        if l <= 0.0 {
            continue;
        }
        let v = &mut s.v[i * n..(i + 1) * n];
        let vn = dot_from_zero(normal, v);
        let limit = f.mu * s.w[i] * l / f.h;
        if clamp_tangential(normal, limit, vn, v) && !v.iter().all(|c| c.is_finite()) {
            failed = Some(failed.map_or(i, |f: usize| f.min(i)));
        }
    }
    failed.map_or(Ok(()), Err)
}
