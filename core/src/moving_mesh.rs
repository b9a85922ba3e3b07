//! A simplex mesh that moves rigidly (`"motion"` on a `simplex_mesh`): the
//! mesh keeps its authored vertices and its hierarchy (built once at load),
//! and every query is made in its frame.
//!
//! ```text
//! M(t1) x = R x + b          the mesh's motion at the substep's end (motion.rs)
//! to the frame     y = Rᵀ x + e,   e = Rᵀ (o − b) − o
//!                  (coordinates relative to the origin o, in order:
//!                   y_a = (Σ_b Rᵀ_ab x_b) + e_a;  without a rotation y_a = x_a + e_a)
//! contact          (C, n_f) = kinds::mesh_contact::closest(mesh, y, r, reach)
//!                  C is the world's: the map is rigid (|x − M q| = |y − q|)
//! normal back      n_a = Σ_b R_ab n_f,b          (without a rotation n = n_f)
//! friction         the moving plane's (motion.rs): static friction against
//!                  q = p + D(p), dynamic friction on v − D(p) / h, with this n
//! ```
//! Reach: the unsigned distance pushes a particle out on the side its
//! centre is on, so a mesh that moves by d ≥ r (r a particle's radius) in
//! one substep could carry a resting particle's centre through it.
//! ```text
//! d = max over the corners c of the mesh's authored box |D(c)|
//!   ≥ max over its points |D(p)|  (|D(p)| = |Ā p + c| is convex in p)
//! d ≥ the smallest radius of the particles it contacts → the substep is
//! rejected (a guard rejection, `GuardKind::MeshReach`: with `adaptive`
//! the step is retried with more substeps; without, it fails, the state
//! unchanged), before anything moves
//! ```
//! The particles' own speed is theirs to bound (substeps, `max_speed`).
//!
//! e, Rᵀ and D are evaluated on the host in f64 once per substep (the
//! golden path with o = 0; the f32 device and its reference take them
//! relative to their origin, rounded once), so every backend maps a
//! particle with the same operations in the same order. The rotation of
//! the normal back is written once over [`ProjectionReal`] for both
//! precisions.

// Coordinate loops index several arrays at once, as a kernel does.
#![allow(clippy::needless_range_loop)]

use crate::barrier::BarrierObstacles;
use crate::guard_rules::{GuardKind, GuardRejection, GuardSubject};
use crate::kinds::ProjectionReal;
use crate::kinds::mesh_candidates::Candidates;
use crate::kinds::mesh_contact::{closest, closest_kept};
use crate::motion::{Carry, MeshAt, MotionPlan, SubstepMotion};

/// The map into a mesh's frame in some precision (module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct MeshFrame<R> {
    /// Rᵀ, row-major (`None`: no rotation in the list).
    pub inverse: Option<Vec<R>>,
    /// e = Rᵀ (o − b) − o.
    pub offset: Vec<R>,
}

impl MeshAt {
    /// The frame map in coordinates relative to `origin` (empty or zero:
    /// the world's, the golden path's), in f64.
    pub fn frame(&self, origin: &[f64]) -> MeshFrame<f64> {
        let placed = &self.placed;
        let n = placed.translation.len();
        let o = |a: usize| origin.get(a).copied().unwrap_or(0.0);
        let d: Vec<f64> = (0..n).map(|a| o(a) - placed.translation[a]).collect();
        let inverse = placed.rotates.then(|| {
            let r = &placed.rotation;
            (0..n * n)
                .map(|k| r[(k % n) * n + k / n])
                .collect::<Vec<f64>>()
        });
        let offset = (0..n)
            .map(|a| match &inverse {
                None => d[a] - o(a),
                Some(t) => {
                    let mut s = 0.0;
                    for b in 0..n {
                        s += t[a * n + b] * d[b];
                    }
                    s - o(a)
                }
            })
            .collect();
        MeshFrame { inverse, offset }
    }
}

impl MeshFrame<f64> {
    /// The frame rounded to f32 once.
    pub fn to_f32(&self) -> MeshFrame<f32> {
        let round = |v: &[f64]| v.iter().map(|&c| c as f32).collect::<Vec<f32>>();
        MeshFrame {
            inverse: self.inverse.as_deref().map(round),
            offset: round(&self.offset),
        }
    }
}

impl<R: ProjectionReal> MeshFrame<R> {
    /// y = Rᵀ x + e into `y` (module docs).
    #[inline]
    pub fn to_frame(&self, x: &[R], y: &mut [R]) {
        let n = x.len();
        for a in 0..n {
            y[a] = match &self.inverse {
                None => x[a] + self.offset[a],
                Some(t) => {
                    let mut s = R::constant(0.0);
                    for b in 0..n {
                        s += t[a * n + b] * x[b];
                    }
                    s + self.offset[a]
                }
            };
        }
    }

    /// n ← R n (a normal of the frame back to the world; `scratch` holds
    /// the frame's normal meanwhile).
    #[inline]
    pub fn normal_back(&self, normal: &mut [R], scratch: &mut [R]) {
        let Some(t) = &self.inverse else {
            return;
        };
        let n = normal.len();
        scratch.copy_from_slice(normal);
        for a in 0..n {
            let mut s = R::constant(0.0);
            for b in 0..n {
                s += t[b * n + a] * scratch[b];
            }
            normal[a] = s;
        }
    }
}

/// [`closest`] for a mesh placed by `frame` (`None`: static): the query
/// made in the mesh's frame, the normal turned back to the world; with
/// `kept`, the particle's candidates kept between queries (in the mesh's
/// frame, where the hierarchy is: [`closest_kept`]).
pub fn closest_placed(
    mesh: &BarrierObstacles,
    frame: Option<&MeshFrame<f64>>,
    (x, radius, reach): (&[f64], f64, f64),
    normal: &mut [f64],
    kept: Option<&mut Candidates>,
) -> Option<f64> {
    let query = |y: &[f64], normal: &mut [f64]| match kept {
        Some(kept) => closest_kept(mesh, y, (radius, reach), normal, kept),
        None => closest(mesh, y, radius, reach, normal),
    };
    let Some(frame) = frame else {
        return query(x, normal);
    };
    let n = x.len();
    let mut y = [0.0f64; crate::MAX_DIM];
    let mut scratch = [0.0f64; crate::MAX_DIM];
    frame.to_frame(x, &mut y[..n]);
    let c = query(&y[..n], normal)?;
    frame.normal_back(normal, &mut scratch[..n]);
    Some(c)
}

/// Up to this dimension [`box_reach`] visits the box's 2^N corners.
const CORNERS_UP_TO: usize = 8;

/// The largest displacement over the substep of a point of the box
/// `bounds` carried by `carry` (module docs, "Reach"); above
/// 8 dimensions (`CORNERS_UP_TO`) the bound |D(m)| + ‖Ā‖_F |h| (m the box's
/// centre, h its half-diagonal), which is at least that.
pub fn box_reach(bounds: &[Vec<f64>; 2], carry: &Carry) -> f64 {
    let n = bounds[0].len();
    let length = |d: &[f64]| d.iter().map(|c| c * c).sum::<f64>().sqrt();
    let Some(matrix) = &carry.matrix else {
        return length(&carry.offset);
    };
    let (mut corner, mut d) = (vec![0.0; n], vec![0.0; n]);
    if n > CORNERS_UP_TO {
        let centre: Vec<f64> = (0..n)
            .map(|a| 0.5 * (bounds[0][a] + bounds[1][a]))
            .collect();
        let half: Vec<f64> = (0..n)
            .map(|a| 0.5 * (bounds[1][a] - bounds[0][a]))
            .collect();
        carry.at(&centre, &mut d);
        return length(&d) + length(matrix) * length(&half);
    }
    let mut largest: f64 = 0.0;
    for k in 0..1usize << n {
        for a in 0..n {
            corner[a] = bounds[(k >> a) & 1][a];
        }
        carry.at(&corner, &mut d);
        largest = largest.max(length(&d));
    }
    largest
}

/// The first moving mesh of `motion` whose reach over substep `substep`
/// (values `now`) is at least the smallest radius it contacts (module
/// docs, "Reach"), as a guard rejection.
pub fn reach_rejection(
    motion: &MotionPlan,
    now: &SubstepMotion,
    substep: u32,
) -> Option<GuardRejection> {
    motion
        .meshes
        .iter()
        .zip(&now.meshes)
        .find_map(|(mesh, at)| {
            let reach = box_reach(&mesh.bounds, &at.carry);
            (reach >= mesh.smallest_radius || reach.is_nan()).then_some(GuardRejection {
                guard: GuardKind::MeshReach,
                subject: GuardSubject::Obstacle(mesh.obstacle),
                value: reach,
                limit: mesh.smallest_radius,
                substep,
            })
        })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::motion::{Carry, Motion, rigid_at};

    fn still(n: usize) -> Carry {
        Carry {
            matrix: None,
            offset: vec![0.0; n],
        }
    }

    fn turning() -> Vec<Motion> {
        vec![
            Motion::Rotate {
                plane: [0, 2],
                center: vec![0.5, 0.0, -1.0],
                rate: 0.9,
            },
            Motion::Translate {
                velocity: vec![0.2, 0.3, -0.1],
            },
        ]
    }

    #[test]
    fn the_frame_map_inverts_the_motion() {
        let placed = rigid_at(&turning(), 3, 0.7);
        let at = MeshAt {
            placed: placed.clone(),
            carry: still(3),
        };
        let q = [0.3, -1.2, 2.5];
        let x = placed.apply(&q);
        for origin in [vec![], vec![100.0, -3.0, 7.0]] {
            let frame = at.frame(&origin);
            let o = |a: usize| origin.get(a).copied().unwrap_or(0.0);
            let local: Vec<f64> = (0..3).map(|a| x[a] - o(a)).collect();
            let mut y = [0.0; 3];
            frame.to_frame(&local, &mut y);
            for a in 0..3 {
                assert!((y[a] + o(a) - q[a]).abs() < 1e-12, "{origin:?} {y:?}");
            }
        }
        // A frame normal turns back with R.
        let frame = at.frame(&[]);
        let mut n = [0.0, 0.0, 1.0];
        frame.normal_back(&mut n, &mut [0.0; 3]);
        let want = placed.rotate(&[0.0, 0.0, 1.0]);
        assert_eq!(n.to_vec(), want);
    }

    #[test]
    fn a_translation_alone_maps_by_subtraction_exactly() {
        let motion = [Motion::Translate {
            velocity: vec![0.1, 0.25],
        }];
        let at = MeshAt {
            placed: rigid_at(&motion, 2, 3.0),
            carry: still(2),
        };
        let frame = at.frame(&[]);
        assert!(frame.inverse.is_none());
        let x = [0.7, -0.05];
        let mut y = [0.0; 2];
        frame.to_frame(&x, &mut y);
        let b = &at.placed.translation;
        assert_eq!(y, [x[0] - b[0], x[1] - b[1]]);
    }

    #[test]
    fn the_reach_of_a_turn_is_its_farthest_corner_chord() {
        let turn = [Motion::Rotate {
            plane: [0, 1],
            center: vec![0.0, 0.0],
            rate: 1.0,
        }];
        let (m0, m1) = (rigid_at(&turn, 2, 0.2), rigid_at(&turn, 2, 0.25));
        let plan = MotionPlan {
            meshes: vec![crate::motion::MovingMesh {
                family: 0,
                obstacle: 3,
                motion: turn.to_vec(),
                bounds: [vec![-1.0, -1.0], vec![1.0, 1.0]],
                smallest_radius: 0.1,
            }],
            ..MotionPlan::default()
        };
        let now = plan.substep(2, 0.2, 0.25, 0.05);
        // The corner at √2 moves along a chord 2 √2 sin(θ/2), θ = 0.05.
        let want = 2.0 * 2f64.sqrt() * (0.025f64).sin();
        let reach = box_reach(&plan.meshes[0].bounds, &now.meshes[0].carry);
        assert!((reach - want).abs() <= 1e-14, "{reach} vs {want}");
        let _ = (m0, m1);
        assert!(reach_rejection(&plan, &now, 4).is_none());
        let mut small = plan.clone();
        small.meshes[0].smallest_radius = 0.05;
        let r = reach_rejection(&small, &now, 4).expect("0.0707 ≥ 0.05");
        assert_eq!(
            (r.guard, r.subject, r.substep),
            (GuardKind::MeshReach, GuardSubject::Obstacle(3), 4)
        );
    }
}
