//! The camera: one framing for the whole run, then projection to pixels.
//!
//! ```text
//! c    centre of the axis-aligned bounding box of every particle of every
//!      snapshot (R^N)
//! R    largest |x − c| over the run (scale of the perspective camera)
//! fit  project every particle of every snapshot (± its radius), and in
//!      perspective every floor-patch corner; take the 2D bounding box,
//!      (orthographic: plus the foot of any hyperplane trace within one
//!      box size of the particles, so a nearby ground shows); grow it by
//!      6 % per side, and scale it uniformly to the picture
//! ```
//! The framing is computed once from all snapshots, before the first
//! picture, so the camera never moves during an animation: a falling
//! object starts at the top of the frame and lands at the bottom.

use crate::Snapshot;
use crate::geometry::{Plane, SceneGeometry, clip_polygon, clip_segment};
use crate::view::{Projection, View};
use glam::{DVec2, DVec3};

/// Share of the picture kept free on each side.
const MARGIN: f64 = 0.06;
/// Distance of the 4D eye, in units of R.
const EYE_4D: f64 = 3.0;
/// Distance of the 3D camera, in units of R.
const EYE_3D: f64 = 5.0;

/// A projected point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Projected {
    /// Pixel column.
    pub x: f64,
    /// Pixel row (0 at the top).
    pub y: f64,
    /// Distance from the camera (perspective; 0 in orthographic).
    pub distance: f64,
    /// Depth shading in [0, 1], 0 nearest.
    pub fog: f64,
    /// Pixels per unit length at this point.
    pub scale: f64,
}

/// A point on the picture plane (before the pixel mapping).
#[derive(Debug, Clone, Copy)]
struct PlanePoint {
    s: f64,
    t: f64,
    distance: f64,
    fog: f64,
    /// Picture-plane units per unit length.
    scale: f64,
}

/// A floor patch: the hyperplane's slice through the 3D view, clipped to
/// the scene's box, with grid lines; 3D view coordinates.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Patch {
    pub polygon: Vec<DVec3>,
    pub grid: Vec<(DVec3, DVec3)>,
}

/// The view with its framing.
#[derive(Debug, Clone)]
pub(crate) struct Camera {
    pub view: View,
    pub centre: Vec<f64>,
    radius: f64,
    /// Lowest Y (view coordinates) of the run: centre of the 4D perspective.
    floor: f64,
    /// 3D view-coordinate box of the run, grown (perspective patches).
    box3: [[f64; 2]; 3],
    /// Camera basis: right, up, back (towards the camera).
    basis: [DVec3; 3],
    /// Picture-plane point at the centre of the picture.
    middle: DVec2,
    /// Pixels per unit of the picture plane.
    zoom: f64,
}

/// Right, up and back (towards the camera) of a camera at azimuth φ and
/// elevation ε: back = (cos ε sin φ, sin ε, cos ε cos φ), right ⟂ back in
/// the horizontal plane, up = back × right.
fn camera_basis(projection: &Projection) -> [DVec3; 3] {
    match *projection {
        Projection::Orthographic => [DVec3::X, DVec3::Y, DVec3::Z],
        Projection::Perspective {
            azimuth: phi,
            elevation: eps,
            ..
        } => {
            let (sp, cp) = phi.sin_cos();
            let (se, ce) = eps.sin_cos();
            [
                DVec3::new(cp, 0.0, -sp),
                DVec3::new(-se * sp, ce, -se * cp),
                DVec3::new(ce * sp, se, ce * cp),
            ]
        }
    }
}

/// 1, 2 or 5 × 10^e, the largest not above `x`.
fn nice_step(x: f64) -> f64 {
    let base = 10f64.powf(x.log10().floor());
    let m = x / base;
    base * if m >= 5.0 {
        5.0
    } else if m >= 2.0 {
        2.0
    } else {
        1.0
    }
}

impl Camera {
    /// Frames `snapshots` (at least one) for `view`.
    pub fn fit(view: View, geometry: &SceneGeometry, snapshots: &[Snapshot]) -> Camera {
        let dim = view.dim;
        let mut lo = vec![f64::INFINITY; dim];
        let mut hi = vec![f64::NEG_INFINITY; dim];
        for snap in snapshots {
            for (k, &x) in snap.state.positions.iter().enumerate() {
                lo[k % dim] = lo[k % dim].min(x);
                hi[k % dim] = hi[k % dim].max(x);
            }
        }
        let centre: Vec<f64> = lo
            .iter()
            .zip(&hi)
            .map(|(l, h)| if l <= h { 0.5 * (l + h) } else { 0.0 })
            .collect();
        let mut y = vec![0.0; dim];
        let mut radius: f64 = 0.0;
        let mut box3 = [[f64::INFINITY, f64::NEG_INFINITY]; 3];
        let mut largest_particle: f64 = 0.0;
        for snap in snapshots {
            for i in 0..snap.state.len() {
                view.centred(snap.state.position(i), &centre, snap.time, &mut y);
                radius = radius.max(y.iter().map(|v| v * v).sum::<f64>().sqrt());
                let r = geometry.radius[i];
                largest_particle = largest_particle.max(r);
                let (p, _) = view.view_coords(&y);
                for a in 0..3 {
                    box3[a][0] = box3[a][0].min(p[a] - r);
                    box3[a][1] = box3[a][1].max(p[a] + r);
                }
            }
        }
        if radius.is_nan() || radius <= 0.0 {
            radius = (0.5 * geometry.length).max(largest_particle).max(1e-9);
        }
        let floor = if box3[1][0].is_finite() {
            box3[1][0]
        } else {
            0.0
        };
        let mut camera = Camera {
            basis: camera_basis(&view.projection),
            view,
            centre,
            radius,
            floor,
            box3,
            middle: DVec2::ZERO,
            zoom: 1.0,
        };
        // With a 4D→3D perspective the floor patch must cover the points
        // where they are drawn: box them after the 4D step.
        if let Projection::Perspective { w: Some(_), .. } = camera.view.projection {
            box3 = [[f64::INFINITY, f64::NEG_INFINITY]; 3];
            for snap in snapshots {
                for i in 0..snap.state.len() {
                    camera
                        .view
                        .centred(snap.state.position(i), &camera.centre, snap.time, &mut y);
                    let (p, w) = camera.view.view_coords(&y);
                    let (p, factor, _) = camera.lift(p, w);
                    let r = geometry.radius[i] * factor;
                    for a in 0..3 {
                        box3[a][0] = box3[a][0].min(p[a] - r);
                        box3[a][1] = box3[a][1].max(p[a] + r);
                    }
                }
            }
        }
        let extent = box3
            .iter()
            .map(|[l, h]| h - l)
            .filter(|e| e.is_finite())
            .fold(0.0f64, f64::max)
            .max(radius);
        for side in &mut box3 {
            if side[0].is_nan() || side[1].is_nan() || side[0] > side[1] {
                *side = [0.0, 0.0];
            }
            side[0] -= 0.15 * extent;
            side[1] += 0.15 * extent;
        }
        camera.box3 = box3;

        // The 2D bounding box of everything drawn, over the whole run.
        let mut lo2 = [f64::INFINITY; 2];
        let mut hi2 = [f64::NEG_INFINITY; 2];
        let mut grow = |q: PlanePoint, r: f64| {
            lo2[0] = lo2[0].min(q.s - r * q.scale);
            hi2[0] = hi2[0].max(q.s + r * q.scale);
            lo2[1] = lo2[1].min(q.t - r * q.scale);
            hi2[1] = hi2[1].max(q.t + r * q.scale);
        };
        for snap in snapshots {
            for i in 0..snap.state.len() {
                camera
                    .view
                    .centred(snap.state.position(i), &camera.centre, snap.time, &mut y);
                grow(camera.plane_point(&y), geometry.radius[i]);
            }
            for plane in &geometry.planes {
                if let Some(patch) = camera.patch(plane, snap.time) {
                    for &p in &patch.polygon {
                        grow(camera.plane_point3(p), 0.0);
                    }
                }
            }
        }
        // Orthographic: a hyperplane trace within one picture size of the
        // particles joins the framing (with a strip of its shaded side), so
        // a nearby ground is in the picture.
        if !camera.view.is_perspective() && lo2[0] <= hi2[0] && lo2[1] <= hi2[1] {
            let reach = (hi2[0] - lo2[0]).max(hi2[1] - lo2[1]);
            let middle = DVec2::new(0.5 * (lo2[0] + hi2[0]), 0.5 * (lo2[1] + hi2[1]));
            let mut feet = Vec::new();
            for plane in &geometry.planes {
                for snap in snapshots {
                    let (ab, k) = camera.trace(plane, snap.time);
                    let norm = ab.length();
                    if norm < 1e-9 {
                        continue;
                    }
                    let u = ab / norm;
                    let distance = u.dot(middle) - k / norm;
                    if distance.abs() <= reach {
                        let beyond = distance + 0.08 * reach * distance.signum();
                        feet.push(middle - u * beyond);
                    }
                }
            }
            for foot in feet {
                for a in 0..2 {
                    lo2[a] = lo2[a].min(foot[a]);
                    hi2[a] = hi2[a].max(foot[a]);
                }
            }
        }
        let min_half = 0.05 * geometry.length.max(radius);
        let mut size = [0.0; 2];
        for a in 0..2 {
            if lo2[a].is_nan() || hi2[a].is_nan() || lo2[a] > hi2[a] {
                lo2[a] = 0.0;
                hi2[a] = 0.0;
            }
            camera.middle[a] = 0.5 * (lo2[a] + hi2[a]);
            size[a] = (hi2[a] - lo2[a]).max(2.0 * min_half);
        }
        let usable = 1.0 - 2.0 * MARGIN;
        camera.zoom = (f64::from(camera.view.width) * usable / size[0])
            .min(f64::from(camera.view.height) * usable / size[1]);
        camera
    }

    /// Projects a centred, rotated point `y` of R^N to pixels.
    pub fn project(&self, y: &[f64]) -> Projected {
        self.pixels(self.plane_point(y))
    }

    /// Projects 3D view coordinates (no 4D perspective) to pixels.
    pub fn project3(&self, p: DVec3) -> Projected {
        self.pixels(self.plane_point3(p))
    }

    fn pixels(&self, q: PlanePoint) -> Projected {
        let (x, y) = self.to_pixels(DVec2::new(q.s, q.t));
        Projected {
            x,
            y,
            distance: q.distance,
            fog: q.fog,
            scale: self.zoom * q.scale,
        }
    }

    /// A centred, rotated point `y` of R^N on the picture plane.
    fn plane_point(&self, y: &[f64]) -> PlanePoint {
        let (p, w) = self.view.view_coords(y);
        let (p, factor, w_depth) = self.lift(p, w);
        let mut q = self.plane_point3(p);
        q.scale *= factor;
        if let Some(d4) = w_depth {
            q.fog = 0.5 * (q.fog + d4);
        }
        q
    }

    /// The 4D→3D perspective (identity without a 4th axis): the 3D point,
    /// its scale factor and its depth in W (0 nearest, 1 farthest).
    fn lift(&self, mut p: DVec3, w: f64) -> (DVec3, f64, Option<f64>) {
        if let Projection::Perspective { w: Some(_), .. } = self.view.projection {
            let u = (w / self.radius).clamp(-1.0, 1.0);
            let factor = EYE_4D / (EYE_4D - u);
            p.x *= factor;
            p.y = self.floor + (p.y - self.floor) * factor;
            p.z *= factor;
            (p, factor, Some(0.5 * (1.0 - u)))
        } else {
            (p, 1.0, None)
        }
    }

    /// 3D view coordinates (no 4D perspective) on the picture plane.
    fn plane_point3(&self, p: DVec3) -> PlanePoint {
        match self.view.projection {
            Projection::Orthographic => PlanePoint {
                s: p.x,
                t: p.y,
                distance: 0.0,
                fog: 0.0,
                scale: 1.0,
            },
            Projection::Perspective { .. } => {
                let d3 = EYE_3D * self.radius;
                let [right, up, back] = self.basis;
                let distance = (d3 - p.dot(back)).max(0.05 * self.radius);
                let persp = d3 / distance;
                PlanePoint {
                    s: p.dot(right) * persp,
                    t: p.dot(up) * persp,
                    distance,
                    fog: ((distance - (d3 - 1.5 * self.radius)) / (3.0 * self.radius))
                        .clamp(0.0, 1.0),
                    scale: persp,
                }
            }
        }
    }

    /// The picture rectangle in picture-plane coordinates (s, t), as a polygon.
    pub fn visible_rect(&self) -> [DVec2; 4] {
        let hw = 0.5 * f64::from(self.view.width) / self.zoom;
        let hh = 0.5 * f64::from(self.view.height) / self.zoom;
        let DVec2 { x: ms, y: mt } = self.middle;
        [
            DVec2::new(ms - hw, mt - hh),
            DVec2::new(ms + hw, mt - hh),
            DVec2::new(ms + hw, mt + hh),
            DVec2::new(ms - hw, mt + hh),
        ]
    }

    /// Picture-plane point to pixels.
    pub fn to_pixels(&self, p: DVec2) -> (f64, f64) {
        (
            0.5 * f64::from(self.view.width) + self.zoom * (p.x - self.middle.x),
            0.5 * f64::from(self.view.height) - self.zoom * (p.y - self.middle.y),
        )
    }

    /// The hyperplane in centred, rotated coordinates at `time` (where its
    /// prescribed motion has it then): (n', k) with n'·y = k on it and
    /// n'·y < k excluded.
    fn plane_now(&self, plane: &Plane, time: f64) -> (Vec<f64>, f64) {
        let (mut n, offset) = plane.at(time);
        let k = offset - dot_slice(&n, &self.centre);
        self.view.rotate_vector(time, &mut n);
        (n, k)
    }

    /// Orthographic trace of a hyperplane: a s + b t = k, a s + b t < k
    /// excluded.
    pub fn trace(&self, plane: &Plane, time: f64) -> (DVec2, f64) {
        let (n, k) = self.plane_now(plane, time);
        (
            DVec2::new(
                n[self.view.horizontal],
                self.view.up_sign * n[self.view.vertical],
            ),
            k,
        )
    }

    /// Perspective floor patch of a hyperplane at `time`, if its slice
    /// through the 3D view meets the scene's box.
    pub fn patch(&self, plane: &Plane, time: f64) -> Option<Patch> {
        let Projection::Perspective { depth, .. } = self.view.projection else {
            return None;
        };
        let (n, k) = self.plane_now(plane, time);
        let m = DVec3::new(
            n[self.view.horizontal],
            self.view.up_sign * n[self.view.vertical],
            n[depth],
        );
        let length = m.length();
        if length < 1e-9 {
            return None;
        }
        let m = m / length;
        let k = k / length;
        // In-plane basis from the coordinate axis most orthogonal to m.
        let axis = (0..3)
            .min_by(|&a, &b| m[a].abs().total_cmp(&m[b].abs()))
            .unwrap_or(0);
        let e1 = DVec3::AXES[axis] - m * m[axis];
        let e1 = e1 / e1.length();
        let e2 = m.cross(e1);
        // Anchor: the world origin dropped onto the plane, so grid lines
        // sit at fixed world positions.
        let mut origin = vec![0.0; self.view.dim];
        self.view
            .centred(&vec![0.0; self.view.dim], &self.centre, time, &mut origin);
        let (o3, _) = self.view.view_coords(&origin);
        let anchor = o3 - m * (m.dot(o3) - k);
        let halfspaces: Vec<(DVec3, f64)> = (0..3)
            .flat_map(|a| {
                let unit = DVec3::AXES[a];
                [(unit, self.box3[a][1]), (-unit, -self.box3[a][0])]
            })
            .collect();
        let reach = self
            .box3
            .iter()
            .map(|[l, h]| (h - l) * (h - l) + (l + h) * (l + h))
            .sum::<f64>()
            .sqrt()
            + anchor.length();
        let at = |u: f64, v: f64| anchor + e1 * u + e2 * v;
        let mut polygon = vec![
            at(-reach, -reach),
            at(reach, -reach),
            at(reach, reach),
            at(-reach, reach),
        ];
        for &(n, k) in &halfspaces {
            polygon = clip_polygon(&polygon, n, k);
        }
        if polygon.len() < 3 {
            return None;
        }
        let extent = self.box3.iter().map(|[l, h]| h - l).fold(0.0f64, f64::max);
        let step = nice_step(extent / 6.0);
        let mut grid = Vec::new();
        if step > 0.0 && step.is_finite() {
            let count = (reach / step).ceil().min(1000.0) as i64;
            for j in -count..=count {
                let u = j as f64 * step;
                for (a, b) in [(at(u, -reach), at(u, reach)), (at(-reach, u), at(reach, u))] {
                    if let Some(segment) = clip_segment(a, b, &halfspaces) {
                        grid.push(segment);
                    }
                }
            }
        }
        Some(Patch { polygon, grid })
    }
}

fn dot_slice(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

#[cfg(test)]
mod tests {
    use super::nice_step;

    #[test]
    fn steps_are_round() {
        assert_eq!(nice_step(0.37), 0.2);
        assert_eq!(nice_step(7.0), 5.0);
        assert_eq!(nice_step(1.0), 1.0);
    }
}
