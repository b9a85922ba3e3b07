//! Prescribed motion as the f32 device runs it (`hyperpbd_core::motion`,
//! `cpu/src/motion.rs` for the math): the host's f64 values of each
//! substep rounded to f32 once, in device coordinates (origin o), and the
//! moving plane's contact, friction and residual in f32 in the order of
//! `shaders/project.wgsl`, `friction.wgsl` and `residual.wgsl`.
//!
//! ```text
//! stored per substep:   n(t1), s(t1) − n(t1)·o, Ā, c + Ā o   (→ f32)
//!                       pins: x(t1) − o, (x(t1) − x(t0)) / h (→ f32)
//! contact   C = n·x − rest − s;  q = (Ā p + c) + p  (static friction)
//! friction  rel = v − (Ā p + c) / h
//! residual  max(−(n·x − rest − s), 0)
//! ```
//! With o = 0 (every f64 scene, and f32 scenes near the world origin) the
//! values are the golden path's, unchanged.

// Coordinate loops index several arrays at once, as a kernel does.
#![allow(clippy::needless_range_loop)]

use hyperpbd_core::motion::{SubstepMotion, local_plane, local_position};

use super::Particles;
use hyperpbd_core::kinds::contact_friction::{clamp_relative, dot_from_zero, static_friction};
use hyperpbd_core::kinds::hyperplane_contact::contact_update;

/// A moving plane of one substep, in f32 device coordinates.
#[derive(Debug, Clone, Default)]
pub struct Plane32 {
    pub normal: Vec<f32>,
    pub shift: f32,
    /// Ā, row-major (`None`: no rotation, D = c).
    pub matrix: Option<Vec<f32>>,
    pub offset: Vec<f32>,
}

/// One substep's prescribed values in f32.
#[derive(Debug, Clone, Default)]
pub struct Motion32 {
    pub planes: Vec<Plane32>,
    pub pin_positions: Vec<f32>,
    pub pin_velocities: Vec<f32>,
}

/// `now` rounded to f32 in coordinates relative to `origin` (empty: none).
pub fn round(now: &SubstepMotion, origin: &[f64], dim: usize) -> Motion32 {
    let planes = now
        .planes
        .iter()
        .map(|plane| {
            let (shift, offset) = local_plane(plane, origin);
            Plane32 {
                normal: plane.normal.iter().map(|&v| v as f32).collect(),
                shift: shift as f32,
                matrix: plane
                    .carry
                    .matrix
                    .as_ref()
                    .map(|m| m.iter().map(|&v| v as f32).collect()),
                offset: offset.iter().map(|&v| v as f32).collect(),
            }
        })
        .collect();
    let pin_positions = now
        .pin_positions
        .iter()
        .enumerate()
        .map(|(k, &x)| local_position(x, origin.get(k % dim)) as f32)
        .collect();
    Motion32 {
        planes,
        pin_positions,
        pin_velocities: now.pin_velocities.iter().map(|&v| v as f32).collect(),
    }
}

/// D(p) = Σ_b Ā_ab p_b + c_a (or c_a).
fn carry(plane: &Plane32, p: &[f32], out: &mut [f32]) {
    let n = p.len();
    match &plane.matrix {
        None => out.copy_from_slice(&plane.offset),
        Some(m) => {
            for a in 0..n {
                let mut s = 0.0f32;
                for b in 0..n {
                    s += m[a * n + b] * p[b];
                }
                out[a] = s + plane.offset[a];
            }
        }
    }
}

/// What a moving plane's projection reads.
pub struct Contact<'a> {
    pub plane: &'a Plane32,
    pub mu: f32,
    pub elements: &'a [u32],
    pub rest: &'a [f32],
    pub alpha_tilde: f32,
}

impl<'a> Contact<'a> {
    /// The moving plane `plane` of a family with `elements` as stored.
    pub(super) fn of(plane: &'a Plane32, elements: &'a [u32], stored: &'a super::Stored) -> Self {
        Contact {
            plane,
            mu: stored.mu,
            elements,
            rest: &stored.rest,
            alpha_tilde: stored.alpha_tilde,
        }
    }
}

pub fn contact(s: &mut Particles, c: &Contact, lambda: &mut [f32]) -> Result<(), usize> {
    let n = s.dim;
    let normal = &c.plane.normal[..];
    let mut q = vec![0.0f32; n];
    let mut failed = None;
    for e in 0..c.elements.len() {
        let i = c.elements[e] as usize;
        let w = s.w[i];
        let (x, p) = (&mut s.x[i * n..(i + 1) * n], &s.p[i * n..(i + 1) * n]);
        let nx = dot_from_zero(normal, x);
        let cval = nx - c.rest[e] - c.plane.shift;
        let Some(l_new) = contact_update(cval, (lambda[e], w, c.alpha_tilde), normal, x) else {
            failed = failed.or(Some(e));
            continue;
        };
        lambda[e] = l_new;
        if c.mu > 0.0 && l_new > 0.0 {
            carry(c.plane, p, &mut q);
            for a in 0..n {
                q[a] += p[a];
            }
            static_friction(normal, c.mu * w * l_new, &q, x);
        }
    }
    failed.map_or(Ok(()), Err)
}

/// Dynamic friction of a moving plane (slot e is particle `elements[e]`).
pub fn friction(s: &mut Particles, c: &Contact, h: f32, lambda: &[f32]) -> Result<(), usize> {
    let n = s.dim;
    let normal = &c.plane.normal[..];
    let mut rel = vec![0.0f32; n];
    let mut failed = None;
    for (&i, &l) in c.elements.iter().zip(lambda) {
        let i = i as usize;
        if l <= 0.0 {
            continue;
        }
        carry(c.plane, &s.p[i * n..(i + 1) * n], &mut rel);
        let v = &mut s.v[i * n..(i + 1) * n];
        for a in 0..n {
            rel[a] = v[a] - rel[a] / h;
        }
        let vn = dot_from_zero(normal, &rel);
        let limit = c.mu * s.w[i] * l / h;
        if clamp_relative(normal, limit, (vn, &rel), v) && !v.iter().all(|c| c.is_finite()) {
            failed = Some(failed.map_or(i, |f: usize| f.min(i)));
        }
    }
    failed.map_or(Ok(()), Err)
}

/// Places the pins (`pins[k]` the particle of pin k).
pub fn place(s: &mut Particles, pins: &[usize], now: &Motion32) {
    let n = s.dim;
    for (k, &i) in pins.iter().enumerate() {
        s.x[i * n..(i + 1) * n].copy_from_slice(&now.pin_positions[k * n..(k + 1) * n]);
        s.v[i * n..(i + 1) * n].copy_from_slice(&now.pin_velocities[k * n..(k + 1) * n]);
    }
}

/// max(−(n·x − rest − s), 0) over the elements.
pub fn residual(c: &Contact, n: usize, x: &[f32]) -> f32 {
    let mut worst = 0.0f32;
    for (e, &i) in c.elements.iter().enumerate() {
        let i = i as usize;
        let nx = dot_from_zero(&c.plane.normal, &x[i * n..(i + 1) * n]);
        worst = worst.max((-(nx - c.rest[e] - c.plane.shift)).max(0.0));
    }
    worst
}
