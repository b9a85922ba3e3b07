//! Prescribed motion of obstacles (hyperplanes, simplex meshes:
//! `moving_mesh.rs`) and fixed particles (pins): a list of rigid motions
//! composed in order, a pure function of time.
//!
//! ```text
//! M(t) = M_k(t) ∘ … ∘ M_1(t),  each M_j(t): x ↦ R_j x + b_j   (rigid)
//!   translate  R = I,  b = u t
//!   rotate     R = Q_ij(θ), θ = rate·t: turns e_i toward e_j in the plane
//!              (e_i, e_j), about `center` c: x ↦ c + Q (x − c)
//!                Q u:  u_i ← cos θ u_i − sin θ u_j,  u_j ← sin θ u_i + cos θ u_j
//!   keyframes  R = I,  b = T(t): piecewise linear through (t_m, T_m), held
//!              at T_0 before t_0 and at T_last after t_last
//! composed:    R ← R_j R,  b ← R_j b + b_j   for j = 1 … k   (start R = I, b = 0)
//!
//! pin         x(t) = R(t) x_0 + b(t)              (x_0 the authored position)
//! hyperplane  n(t) = R(t) n_0,  offset(t) = d_0 + s(t),  s(t) = n(t)·b(t)
//!             contact C = n(t)·x − (d_0 + r) − s(t) ≥ 0
//! substep [t0, t1] (t_s = step·dt + s·h; constraints solved at t1):
//!   carry      D(p) = M(t1)(M(t0)⁻¹ p) − p = Ā p + c,
//!              Ā = R1 R0ᵀ − I,  c = b1 − R1 R0ᵀ b0
//!              (no rotation in the list: D = b1 − b0, no matrix)
//!   static friction cancels the tangential part of x − p − D(p)
//!   dynamic friction clamps the tangential part of v − D(p)/h
//!   pin        x = x(t1),  v = (x(t1) − x(t0)) / h
//! ```
//! Everything here is f64 and runs on the host; every backend takes these
//! values (the f32 ones rounded once), so the backends agree by
//! construction. sin and cos go through `libm` (the golden path's
//! transcendentals).

use serde::{Deserialize, Serialize};

/// One rigid motion of a list (`"motion": [...]` on an obstacle or a
/// fixed particle).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum Motion {
    /// x ↦ x + velocity·t.
    Translate {
        /// Velocity (length `dim`).
        velocity: Vec<f64>,
    },
    /// x ↦ center + Q(rate·t)(x − center), Q turning e_i toward e_j.
    Rotate {
        /// The coordinate plane [i, j] (distinct, both < dim).
        plane: [usize; 2],
        /// Centre of the rotation (length `dim`).
        center: Vec<f64>,
        /// Angular rate in rad/s.
        rate: f64,
    },
    /// x ↦ x + T(t), T piecewise linear through the keyframes, held at its
    /// ends.
    Keyframes {
        /// Keyframe times, strictly increasing (at least one).
        times: Vec<f64>,
        /// One translation (length `dim`) per time.
        translations: Vec<Vec<f64>>,
    },
}

/// A rigid map x ↦ R x + b of R^N.
#[derive(Debug, Clone, PartialEq)]
pub struct Rigid {
    /// R, row-major N × N.
    pub rotation: Vec<f64>,
    /// b.
    pub translation: Vec<f64>,
    /// Whether any rotation took part (R may differ from I).
    pub rotates: bool,
}

impl Rigid {
    /// The identity of R^dim.
    pub fn identity(dim: usize) -> Rigid {
        let mut rotation = vec![0.0; dim * dim];
        for a in 0..dim {
            rotation[a * dim + a] = 1.0;
        }
        Rigid {
            rotation,
            translation: vec![0.0; dim],
            rotates: false,
        }
    }

    /// R x + b, summed over b = 0, 1, … in order (then + b).
    pub fn apply(&self, x: &[f64]) -> Vec<f64> {
        let mut out = self.rotate(x);
        for (o, b) in out.iter_mut().zip(&self.translation) {
            *o += b;
        }
        out
    }

    /// R u.
    pub fn rotate(&self, u: &[f64]) -> Vec<f64> {
        let n = u.len();
        if !self.rotates {
            return u.to_vec();
        }
        (0..n)
            .map(|a| {
                let row = &self.rotation[a * n..(a + 1) * n];
                let mut s = 0.0;
                for (r, x) in row.iter().zip(u) {
                    s += r * x;
                }
                s
            })
            .collect()
    }
}

/// The keyframed translation at `t` (module docs).
fn keyframe(times: &[f64], translations: &[Vec<f64>], t: f64, out: &mut [f64]) {
    let last = times.len() - 1;
    let held = if t <= times[0] {
        Some(0)
    } else if t >= times[last] {
        Some(last)
    } else {
        None
    };
    if let Some(k) = held {
        out.copy_from_slice(&translations[k]);
        return;
    }
    // times[k] ≤ t < times[k + 1].
    let k = times.partition_point(|&s| s <= t) - 1;
    let alpha = (t - times[k]) / (times[k + 1] - times[k]);
    for (a, o) in out.iter_mut().enumerate() {
        let (from, to) = (translations[k][a], translations[k + 1][a]);
        *o = from + alpha * (to - from);
    }
}

/// M(t) of a motion list in R^dim (module docs).
pub fn rigid_at(motions: &[Motion], dim: usize, t: f64) -> Rigid {
    let mut m = Rigid::identity(dim);
    let mut frame = vec![0.0; dim];
    for motion in motions {
        match motion {
            Motion::Translate { velocity } => {
                for (b, v) in m.translation.iter_mut().zip(velocity) {
                    *b += v * t;
                }
            }
            Motion::Rotate {
                plane,
                center,
                rate,
            } => {
                let theta = rate * t;
                let (s, c) = (libm::sin(theta), libm::cos(theta));
                let (i, j) = (plane[0], plane[1]);
                let turn = |u: &mut [f64], stride: usize| {
                    let (ui, uj) = (u[i * stride], u[j * stride]);
                    u[i * stride] = c * ui - s * uj;
                    u[j * stride] = s * ui + c * uj;
                };
                for column in 0..dim {
                    turn(&mut m.rotation[column..], dim);
                }
                // b ← c + Q (b − c)
                for (b, o) in m.translation.iter_mut().zip(center) {
                    *b -= o;
                }
                turn(&mut m.translation, 1);
                for (b, o) in m.translation.iter_mut().zip(center) {
                    *b += o;
                }
                m.rotates = true;
            }
            Motion::Keyframes {
                times,
                translations,
            } => {
                keyframe(times, translations, t, &mut frame);
                for (b, f) in m.translation.iter_mut().zip(&frame) {
                    *b += f;
                }
            }
        }
    }
    m
}

/// The time of substep boundary `s` of step `step` (s = 0 … substeps):
/// step·dt + s·h. Every backend takes it from here.
pub fn substep_time(step: u64, dt: f64, s: u32, h: f64) -> f64 {
    step as f64 * dt + f64::from(s) * h
}

/// The displacement of the obstacle's material points over a substep,
/// D(p) = Ā p + c (module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct Carry {
    /// Ā = R1 R0ᵀ − I, row-major; `None` when the list has no rotation
    /// (then D = c).
    pub matrix: Option<Vec<f64>>,
    /// c.
    pub offset: Vec<f64>,
}

impl Carry {
    /// D(p) into `out`: Σ_b Ā_ab p_b (b in order) + c_a.
    #[inline]
    pub fn at(&self, p: &[f64], out: &mut [f64]) {
        let n = p.len();
        match &self.matrix {
            None => out.copy_from_slice(&self.offset),
            Some(m) => {
                for a in 0..n {
                    let mut s = 0.0;
                    for b in 0..n {
                        s += m[a * n + b] * p[b];
                    }
                    out[a] = s + self.offset[a];
                }
            }
        }
    }
}

/// A moving hyperplane of the plan.
#[derive(Debug, Clone, PartialEq)]
pub struct MovingPlane {
    /// Its contact family in [`crate::Plan::families`].
    pub family: usize,
    /// The authored unit normal n_0.
    pub normal: Vec<f64>,
    /// Its motion list.
    pub motion: Vec<Motion>,
}

/// A moving simplex mesh of the plan (`moving_mesh.rs` has its frame).
#[derive(Debug, Clone, PartialEq)]
pub struct MovingMesh {
    /// Its contact family in [`crate::Plan::families`].
    pub family: usize,
    /// Its authored obstacle index.
    pub obstacle: usize,
    /// Its motion list.
    pub motion: Vec<Motion>,
    /// The box of its authored vertices: lowest, then highest coordinates.
    pub bounds: [Vec<f64>; 2],
    /// The smallest radius of a particle it contacts.
    pub smallest_radius: f64,
}

/// A moving mesh over one substep.
#[derive(Debug, Clone, PartialEq)]
pub struct MeshAt {
    /// M(t1).
    pub placed: Rigid,
    /// D over [t0, t1].
    pub carry: Carry,
}

/// A fixed particle with a motion.
#[derive(Debug, Clone, PartialEq)]
pub struct Pin {
    /// Particle index.
    pub particle: usize,
    /// The authored position x_0.
    pub position: Vec<f64>,
    /// Its motion list.
    pub motion: Vec<Motion>,
}

/// The prescribed motions of a plan (`None` in the plan when the scene
/// has none: nothing is evaluated).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct MotionPlan {
    /// Moving hyperplanes (those with a contact family), in obstacle order.
    pub planes: Vec<MovingPlane>,
    /// Moving simplex meshes (those with a contact family), in obstacle
    /// order.
    pub meshes: Vec<MovingMesh>,
    /// Animated pins, in particle order.
    pub pins: Vec<Pin>,
}

/// A moving hyperplane over one substep.
#[derive(Debug, Clone, PartialEq)]
pub struct PlaneAt {
    /// n(t1).
    pub normal: Vec<f64>,
    /// s(t1) = n(t1)·b(t1).
    pub shift: f64,
    /// D over [t0, t1].
    pub carry: Carry,
}

/// Every prescribed value of one substep.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct SubstepMotion {
    /// Per [`MotionPlan::planes`] entry.
    pub planes: Vec<PlaneAt>,
    /// Per [`MotionPlan::meshes`] entry.
    pub meshes: Vec<MeshAt>,
    /// Per [`MotionPlan::pins`] entry: x(t1), `dim` each.
    pub pin_positions: Vec<f64>,
    /// Per pin: (x(t1) − x(t0)) / h.
    pub pin_velocities: Vec<f64>,
}

impl SubstepMotion {
    /// The plane of family `family` in this substep, if it moves
    /// (`motion`: the plan's).
    pub fn plane(&self, motion: Option<&MotionPlan>, family: usize) -> Option<&PlaneAt> {
        self.planes.get(motion?.plane_of(family)?)
    }

    /// The mesh of family `family` in this substep, if it moves
    /// (`motion`: the plan's).
    pub fn mesh(&self, motion: Option<&MotionPlan>, family: usize) -> Option<&MeshAt> {
        self.meshes.get(motion?.mesh_of(family)?)
    }
}

impl MotionPlan {
    /// The index in [`MotionPlan::planes`] of family `family`'s plane.
    pub fn plane_of(&self, family: usize) -> Option<usize> {
        self.planes.iter().position(|p| p.family == family)
    }

    /// The index in [`MotionPlan::meshes`] of family `family`'s mesh.
    pub fn mesh_of(&self, family: usize) -> Option<usize> {
        self.meshes.iter().position(|m| m.family == family)
    }

    /// Whether nothing moves.
    pub fn is_empty(&self) -> bool {
        self.planes.is_empty() && self.meshes.is_empty() && self.pins.is_empty()
    }

    /// The prescribed values of the substep from `t0` to `t1` (length h).
    pub fn substep(&self, dim: usize, t0: f64, t1: f64, h: f64) -> SubstepMotion {
        let planes = self
            .planes
            .iter()
            .map(|plane| {
                let (m0, m1) = (
                    rigid_at(&plane.motion, dim, t0),
                    rigid_at(&plane.motion, dim, t1),
                );
                let normal = m1.rotate(&plane.normal);
                let shift = dot(&normal, &m1.translation);
                PlaneAt {
                    normal,
                    shift,
                    carry: carry(&m0, &m1, dim),
                }
            })
            .collect();
        let meshes = self
            .meshes
            .iter()
            .map(|mesh| {
                let (m0, m1) = (
                    rigid_at(&mesh.motion, dim, t0),
                    rigid_at(&mesh.motion, dim, t1),
                );
                MeshAt {
                    carry: carry(&m0, &m1, dim),
                    placed: m1,
                }
            })
            .collect();
        let mut pin_positions = Vec::with_capacity(self.pins.len() * dim);
        let mut pin_velocities = Vec::with_capacity(self.pins.len() * dim);
        for pin in &self.pins {
            let x0 = rigid_at(&pin.motion, dim, t0).apply(&pin.position);
            let x1 = rigid_at(&pin.motion, dim, t1).apply(&pin.position);
            pin_velocities.extend(x1.iter().zip(&x0).map(|(a, b)| (a - b) / h));
            pin_positions.extend(x1);
        }
        SubstepMotion {
            planes,
            meshes,
            pin_positions,
            pin_velocities,
        }
    }
}

/// n·o (f64, in order), 0 with no origin.
fn along(normal: &[f64], origin: &[f64]) -> Option<f64> {
    if origin.iter().all(|&o| o == 0.0) {
        return None;
    }
    let mut s = 0.0;
    for (n, o) in normal.iter().zip(origin) {
        s += n * o;
    }
    Some(s)
}

/// A moving plane's values in coordinates relative to `origin` (the GPU
/// backend's scene origin; f64, before any rounding): (shift s − n·o,
/// carry offset c + Ā o). With no origin (empty or zero) both are the
/// world values, unchanged.
pub fn local_plane(plane: &PlaneAt, origin: &[f64]) -> (f64, Vec<f64>) {
    let Some(no) = along(&plane.normal, origin) else {
        return (plane.shift, plane.carry.offset.clone());
    };
    (plane.shift - no, local_carry(&plane.carry, origin))
}

/// A carry's offset relative to `origin`: c + Ā o (f64; c unchanged
/// without an origin or without a rotation).
pub fn local_carry(carry: &Carry, origin: &[f64]) -> Vec<f64> {
    let n = origin.len();
    match &carry.matrix {
        Some(m) if origin.iter().any(|&o| o != 0.0) => (0..n)
            .map(|a| {
                let mut s = 0.0;
                for b in 0..n {
                    s += m[a * n + b] * origin[b];
                }
                carry.offset[a] + s
            })
            .collect(),
        Some(_) | None => carry.offset.clone(),
    }
}

/// A pin coordinate relative to origin coordinate `o` (f64; unchanged
/// without one).
pub fn local_position(x: f64, o: Option<&f64>) -> f64 {
    match o {
        Some(&o) if o != 0.0 => x - o,
        _ => x,
    }
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    let mut s = 0.0;
    for (x, y) in a.iter().zip(b) {
        s += x * y;
    }
    s
}

/// D = M1 ∘ M0⁻¹ − id as (Ā, c).
fn carry(m0: &Rigid, m1: &Rigid, n: usize) -> Carry {
    if !m0.rotates && !m1.rotates {
        let offset = m1
            .translation
            .iter()
            .zip(&m0.translation)
            .map(|(b1, b0)| b1 - b0)
            .collect();
        return Carry {
            matrix: None,
            offset,
        };
    }
    // A = R1 R0ᵀ: A_ab = Σ_k R1_ak R0_bk.
    let mut a = vec![0.0; n * n];
    for r in 0..n {
        for col in 0..n {
            let mut s = 0.0;
            for k in 0..n {
                s += m1.rotation[r * n + k] * m0.rotation[col * n + k];
            }
            a[r * n + col] = s;
        }
    }
    let mut offset = vec![0.0; n];
    for r in 0..n {
        let row = &a[r * n..(r + 1) * n];
        offset[r] = m1.translation[r] - dot(row, &m0.translation);
    }
    for r in 0..n {
        a[r * n + r] -= 1.0;
    }
    Carry {
        matrix: Some(a),
        offset,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keyframes_hold_their_ends_and_interpolate_linearly() {
        let m = [Motion::Keyframes {
            times: vec![1.0, 2.0, 4.0],
            translations: vec![vec![0.0, 0.0], vec![1.0, 0.0], vec![1.0, 2.0]],
        }];
        let at = |t| rigid_at(&m, 2, t).translation;
        assert_eq!(at(-3.0), [0.0, 0.0]);
        assert_eq!(at(1.5), [0.5, 0.0]);
        assert_eq!(at(2.0), [1.0, 0.0]);
        assert_eq!(at(3.0), [1.0, 1.0]);
        assert_eq!(at(9.0), [1.0, 2.0]);
    }

    #[test]
    fn a_quarter_turn_in_plane_1_3_of_r4_maps_e1_to_e3() {
        let m = [Motion::Rotate {
            plane: [1, 3],
            center: vec![0.0, 0.0, 0.0, 1.0],
            rate: std::f64::consts::FRAC_PI_2,
        }];
        let y = rigid_at(&m, 4, 1.0).apply(&[5.0, 1.0, 7.0, 1.0]);
        // e1 − about the centre (0,0,0,1): (1, 0) in (x1, x3) turns to (0, 1).
        let want = [5.0, 0.0, 7.0, 2.0];
        for (a, b) in y.iter().zip(want) {
            assert!((a - b).abs() < 1e-15, "{y:?}");
        }
    }

    #[test]
    fn the_carry_of_a_rotation_moves_material_points_along_their_arcs() {
        let m = vec![
            Motion::Rotate {
                plane: [0, 1],
                center: vec![1.0, 0.0, 0.0],
                rate: 0.7,
            },
            Motion::Translate {
                velocity: vec![0.0, 0.0, 0.3],
            },
        ];
        let (t0, t1) = (0.4, 0.45);
        let (m0, m1) = (rigid_at(&m, 3, t0), rigid_at(&m, 3, t1));
        let d = carry(&m0, &m1, 3);
        // The material point x0 sits at m0(x0) at t0 and m1(x0) at t1.
        let x0 = [0.3, -2.0, 1.5];
        let (p, q) = (m0.apply(&x0), m1.apply(&x0));
        let mut moved = [0.0; 3];
        d.at(&p, &mut moved);
        for a in 0..3 {
            assert!((p[a] + moved[a] - q[a]).abs() < 1e-14, "{a}");
        }
    }
}
