//! Prescribed motion as the f32 device runs it (`hyperpbd_core::motion`,
//! `cpu/src/motion.rs` for the math): the host's f64 values of each
//! substep rounded to f32 once, in device coordinates (origin o), and the
//! moving plane's contact, friction and residual in f32 in the order of
//! `shaders/project.wgsl`, `friction.wgsl` and `residual.wgsl`.
//!
//! ```text
//! stored per substep:   n(t1), s(t1) − n(t1)·o, Ā, c + Ā o   (→ f32)
//!                       meshes: Rᵀ, e = Rᵀ(o − b) − o, Ā, c + Ā o (→ f32;
//!                       hyperpbd_core::moving_mesh)
//!                       pins: x(t1) − o, (x(t1) − x(t0)) / h (→ f32)
//! contact   C = n·x − rest − s;  q = (Ā p + c) + p  (static friction)
//! friction  rel = v − (Ā p + c) / h
//! residual  max(−(n·x − rest − s), 0)
//! ```
//! With o = 0 (every f64 scene, and f32 scenes near the world origin) the
//! values are the golden path's, unchanged.

// Coordinate loops index several arrays at once, as a kernel does.
#![allow(clippy::needless_range_loop)]

use hyperpbd_core::motion::{SubstepMotion, local_carry, local_plane, local_position};
use hyperpbd_core::moving_mesh::MeshFrame;

use super::Particles;
use hyperpbd_core::kinds::contact_friction::{clamp_relative, dot_from_zero, static_friction};
use hyperpbd_core::kinds::hyperplane_contact::contact_update;

/// A carry D(p) = Ā p + c of one substep, in f32 device coordinates.
#[derive(Debug, Clone, Default)]
pub struct Carry32 {
    /// Ā, row-major (`None`: no rotation, D = c).
    pub matrix: Option<Vec<f32>>,
    /// c + Ā o.
    pub offset: Vec<f32>,
}

/// A moving plane of one substep, in f32 device coordinates.
#[derive(Debug, Clone, Default)]
pub struct Plane32 {
    pub normal: Vec<f32>,
    pub shift: f32,
    pub carry: Carry32,
}

/// A moving mesh of one substep, in f32 device coordinates: the map into
/// its frame (`hyperpbd_core::moving_mesh`) and its carry.
#[derive(Debug, Clone)]
pub struct Mesh32At {
    pub frame: MeshFrame<f32>,
    pub carry: Carry32,
}

/// One substep's prescribed values in f32.
#[derive(Debug, Clone, Default)]
pub struct Motion32 {
    pub planes: Vec<Plane32>,
    pub meshes: Vec<Mesh32At>,
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
                carry: Carry32 {
                    matrix: plane.carry.matrix.as_deref().map(round_all),
                    offset: round_all(&offset),
                },
            }
        })
        .collect();
    let meshes = now
        .meshes
        .iter()
        .map(|mesh| Mesh32At {
            frame: mesh.frame(origin).to_f32(),
            carry: Carry32 {
                matrix: mesh.carry.matrix.as_deref().map(round_all),
                offset: round_all(&local_carry(&mesh.carry, origin)),
            },
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
        meshes,
        pin_positions,
        pin_velocities: now.pin_velocities.iter().map(|&v| v as f32).collect(),
    }
}

/// Each value rounded to f32 once.
fn round_all(values: &[f64]) -> Vec<f32> {
    values.iter().map(|&v| v as f32).collect()
}

impl Carry32 {
    /// D(p) = Σ_b Ā_ab p_b + c_a (or c_a).
    pub fn at(&self, p: &[f32], out: &mut [f32]) {
        let n = p.len();
        match &self.matrix {
            None => out.copy_from_slice(&self.offset),
            Some(m) => {
                for a in 0..n {
                    let mut s = 0.0f32;
                    for b in 0..n {
                        s += m[a * n + b] * p[b];
                    }
                    out[a] = s + self.offset[a];
                }
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
            carried_static_friction(&c.plane.carry, (normal, c.mu * w * l_new), p, &mut q, x);
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
        let limit = c.mu * s.w[i] * l / h;
        let (p, v) = (&s.p[i * n..(i + 1) * n], &mut s.v[i * n..(i + 1) * n]);
        if carried_friction(&c.plane.carry, (normal, limit, h), p, &mut rel, v)
            && !v.iter().all(|c| c.is_finite())
        {
            failed = Some(failed.map_or(i, |f: usize| f.min(i)));
        }
    }
    failed.map_or(Ok(()), Err)
}

/// Static friction against the carried point q = D(p) + p (`q`: scratch).
pub fn carried_static_friction(
    carry: &Carry32,
    (normal, bound): (&[f32], f32),
    p: &[f32],
    q: &mut [f32],
    x: &mut [f32],
) {
    carry.at(p, q);
    for a in 0..p.len() {
        q[a] += p[a];
    }
    static_friction(normal, bound, q, x);
}

/// Dynamic friction on v relative to the carry: u = v − D(p)/h clamped
/// (`rel`: scratch); whether v changed.
pub fn carried_friction(
    carry: &Carry32,
    (normal, limit, h): (&[f32], f32, f32),
    p: &[f32],
    rel: &mut [f32],
    v: &mut [f32],
) -> bool {
    carry.at(p, rel);
    for a in 0..v.len() {
        rel[a] = v[a] - rel[a] / h;
    }
    let vn = dot_from_zero(normal, rel);
    clamp_relative(normal, limit, (vn, rel), v)
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
