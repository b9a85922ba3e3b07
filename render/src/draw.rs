//! Drawing one picture with tiny-skia.
//!
//! ```text
//! background
//! hyperplanes   where their prescribed motion has them at the snapshot's time
//!               orthographic: excluded half-space shaded, trace as a line
//!               perspective:  floor patch with grid lines
//! meshes        their faces where their motion has them (mesh.rs)
//! edges         anti-aliased lines, colour of the edge's value (darkened)
//! particles     anti-aliased discs, radius max(min px, r · pixels per length);
//!               fixed particles as dark squares
//! order         orthographic: edges, then particles in index order
//!               perspective:  everything far to near (painter's algorithm),
//!               ties: edges before particles, lower index first
//! ```

use crate::color::{
    BACKGROUND, ColorBy, FIXED, FLOOR_FILL, FLOOR_GRID, GROUND_FILL, GROUND_LINE, RESIDUAL_LOG_MAX,
    RESIDUAL_LOG_MIN, colormap, darker, fog, residual_value,
};
use crate::framing::{Camera, Projected};
use crate::geometry::{SceneGeometry, clip_polygon, clip_segment};
use crate::{Image, RenderError, Snapshot, View};
use glam::DVec2;
use hyperpbd_core::{Scene, State};
use tiny_skia::{Color, FillRule, LineCap, Paint, PathBuilder, Pixmap, Rect, Stroke, Transform};

/// The affine world → pixel map of an orthographic view
/// ([`Renderer::pixel_map`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PixelMap {
    /// World axis drawn left to right.
    pub horizontal: usize,
    /// World axis drawn along the picture's rows (`ky` < 0: up).
    pub vertical: usize,
    /// Pixel x of world coordinate `x[horizontal]` = 0.
    pub x0: f64,
    /// Pixel y of world coordinate `x[vertical]` = 0.
    pub y0: f64,
    /// Pixels per unit along `horizontal`.
    pub kx: f64,
    /// Pixels per unit along `vertical` (negative: rows grow downwards).
    pub ky: f64,
    /// Disc radius in pixels per unit of particle radius.
    pub scale: f64,
    /// Smallest disc radius in pixels.
    pub min_radius_px: f64,
}

/// Draws the snapshots of one run with one fixed framing.
#[derive(Debug, Clone)]
pub struct Renderer {
    geometry: SceneGeometry,
    meshes: Vec<crate::mesh::Mesh>,
    camera: Camera,
    max_speed: f64,
}

fn paint(c: [u8; 4]) -> Paint<'static> {
    let mut p = Paint::default();
    p.set_color(Color::from_rgba8(c[0], c[1], c[2], c[3]));
    p.anti_alias = true;
    p
}

fn rgb(c: [u8; 3], alpha: u8) -> [u8; 4] {
    [c[0], c[1], c[2], alpha]
}

/// A snapshot must fit the scene (dimension, particle count) and be finite.
fn check_state(dim: usize, particles: usize, snap: &Snapshot) -> Result<(), RenderError> {
    let expected = particles * dim;
    let state = &snap.state;
    if state.dim != dim || state.positions.len() != expected || state.velocities.len() != expected {
        return Err(RenderError::Snapshot {
            frame: snap.frame,
            message: format!(
                "state has dim {} with {} position and {} velocity values; the scene needs dim {dim} and {expected} each",
                state.dim,
                state.positions.len(),
                state.velocities.len(),
            ),
        });
    }
    if !(snap.time.is_finite() && state.positions.iter().all(|x| x.is_finite())) {
        return Err(RenderError::Snapshot {
            frame: snap.frame,
            message: "time or positions are not finite".into(),
        });
    }
    Ok(())
}

/// One primitive of the painter's list.
#[derive(Debug, Clone, Copy)]
enum Item {
    Edge(usize),
    Particle(usize),
}

impl Renderer {
    /// Frames `snapshots` (the whole run; the scene's initial state when
    /// empty) for `view`. Every later [`Renderer::draw`] uses this framing
    /// and this speed scale.
    pub fn new(scene: &Scene, view: View, snapshots: &[Snapshot]) -> Result<Renderer, RenderError> {
        scene
            .validate()
            .map_err(|e| RenderError::Scene(e.to_string()))?;
        if view.dim != scene.dim {
            return Err(RenderError::Scene(format!(
                "the view was made for dim {}, the scene has dim {}",
                view.dim, scene.dim
            )));
        }
        let initial;
        let snapshots = if snapshots.is_empty() {
            initial = [Snapshot {
                frame: 0,
                time: 0.0,
                state: State::from_scene(scene),
            }];
            &initial[..]
        } else {
            snapshots
        };
        for snap in snapshots {
            check_state(scene.dim, scene.particles.len(), snap)?;
        }
        let geometry = SceneGeometry::new(scene);
        let max_speed = snapshots
            .iter()
            .flat_map(|s| {
                let fixed = &geometry.fixed;
                (0..s.state.len())
                    .filter(|&i| !fixed[i])
                    .map(|i| speed(&s.state, i))
            })
            .filter(|v| v.is_finite())
            .fold(0.0, f64::max)
            // A run that barely moves is drawn slow, not as amplified noise.
            .max(0.01 * geometry.length / scene.dt);
        let camera = Camera::fit(view, &geometry, snapshots);
        Ok(Renderer {
            geometry,
            meshes: crate::mesh::meshes(scene),
            camera,
            max_speed,
        })
    }

    /// The view.
    pub fn view(&self) -> &View {
        &self.camera.view
    }

    /// Where an orthographic, non-rotating view puts the world: pixel
    /// coordinates of a particle at x are `(x0 + kx · x[horizontal],
    /// y0 + ky · x[vertical])`, and its disc radius `max(r · scale,
    /// min_radius_px)` — so another renderer (a wgpu pipeline drawing
    /// straight from the GPU backend's buffers) can draw the same picture.
    /// `None` for perspective or rotating views.
    pub fn pixel_map(&self) -> Option<PixelMap> {
        let view = &self.camera.view;
        if view.is_perspective() || view.rotate.is_some() {
            return None;
        }
        let mut y = vec![0.0; view.dim];
        let mut at = |x: &[f64]| {
            view.centred(x, &self.camera.centre, 0.0, &mut y);
            self.camera.project(&y)
        };
        let zero = vec![0.0; view.dim];
        let o = at(&zero);
        let mut e = zero.clone();
        e[view.horizontal] = 1.0;
        let h = at(&e);
        let mut e = zero;
        e[view.vertical] = 1.0;
        let v = at(&e);
        Some(PixelMap {
            horizontal: view.horizontal,
            vertical: view.vertical,
            x0: o.x,
            y0: o.y,
            kx: h.x - o.x,
            ky: v.y - o.y,
            scale: o.scale,
            min_radius_px: view.min_radius_px,
        })
    }

    /// The speed drawn red: the fastest particle of the framed snapshots,
    /// at least 1 % of the scene extent per step.
    pub fn max_speed(&self) -> f64 {
        self.max_speed
    }

    /// One line explaining the colours.
    pub fn legend(&self) -> String {
        match self.camera.view.color {
            ColorBy::Speed => format!(
                "colour: speed, blue 0 -> red {:.4} (the fastest particle of the run, at least 1% of the scene extent per step); fixed particles dark squares",
                self.max_speed
            ),
            ColorBy::Residual => format!(
                "colour: relative constraint violation, log scale, blue 1e{RESIDUAL_LOG_MIN} -> red 1e{RESIDUAL_LOG_MAX}; fixed particles dark squares"
            ),
        }
    }

    /// Draws one snapshot.
    pub fn draw(&self, snap: &Snapshot) -> Result<Image, RenderError> {
        let geometry = &self.geometry;
        let view = &self.camera.view;
        check_state(geometry.dim, geometry.len(), snap)?;
        let mut pixmap =
            Pixmap::new(view.width, view.height).ok_or_else(|| RenderError::Option {
                option: "--width",
                message: format!("cannot allocate a {}x{} picture", view.width, view.height),
            })?;
        pixmap.fill(Color::from_rgba8(
            BACKGROUND[0],
            BACKGROUND[1],
            BACKGROUND[2],
            255,
        ));
        let unit = (f64::from(view.width.min(view.height)) / 360.0).max(0.75);

        self.draw_planes(&mut pixmap, snap.time, unit);
        crate::mesh::draw_meshes(&self.meshes, &self.camera, (&mut pixmap, snap.time, unit));

        // Values in [0, 1] per particle and per edge.
        let (particle_value, edge_value): (Vec<f64>, Vec<f64>) = match view.color {
            ColorBy::Speed => {
                let p: Vec<f64> = (0..geometry.len())
                    .map(|i| {
                        if self.max_speed > 0.0 {
                            speed(&snap.state, i) / self.max_speed
                        } else {
                            0.0
                        }
                    })
                    .collect();
                let e = geometry
                    .edges
                    .iter()
                    .map(|&(i, j)| 0.5 * (p[i] + p[j]))
                    .collect();
                (p, e)
            }
            ColorBy::Residual => {
                let (p, e) = geometry.residuals(&snap.state, snap.time);
                (
                    p.into_iter().map(residual_value).collect(),
                    e.into_iter().map(residual_value).collect(),
                )
            }
        };

        let mut y = vec![0.0; geometry.dim];
        let points: Vec<Projected> = (0..geometry.len())
            .map(|i| {
                view.centred(
                    snap.state.position(i),
                    &self.camera.centre,
                    snap.time,
                    &mut y,
                );
                self.camera.project(&y)
            })
            .collect();

        let mut items: Vec<Item> = (0..geometry.edges.len())
            .map(Item::Edge)
            .chain((0..geometry.len()).map(Item::Particle))
            .collect();
        if view.is_perspective() {
            let depth = |item: &Item| match *item {
                Item::Edge(e) => {
                    let (i, j) = geometry.edges[e];
                    0.5 * (points[i].distance + points[j].distance)
                }
                Item::Particle(i) => points[i].distance,
            };
            // Stable sort: equal depths keep edges first, then index order.
            items.sort_by(|a, b| depth(b).total_cmp(&depth(a)));
        }

        // Few edges: thicker lines read better.
        let line_width = if geometry.edges.len() <= 100 {
            1.5
        } else {
            1.0
        } * unit;
        let line = Stroke {
            width: line_width as f32,
            line_cap: LineCap::Round,
            ..Stroke::default()
        };
        let outline = Stroke {
            width: (0.8 * unit) as f32,
            ..Stroke::default()
        };
        for item in items {
            match item {
                Item::Edge(e) => {
                    let (i, j) = geometry.edges[e];
                    let (a, b) = (points[i], points[j]);
                    let mut pb = PathBuilder::new();
                    pb.move_to(a.x as f32, a.y as f32);
                    pb.line_to(b.x as f32, b.y as f32);
                    if let Some(path) = pb.finish() {
                        let c = fog(darker(colormap(edge_value[e]), 0.85), 0.5 * (a.fog + b.fog));
                        let alpha = (215.0 * geometry.edge_weight[e]).round() as u8;
                        pixmap.stroke_path(
                            &path,
                            &paint(rgb(c, alpha)),
                            &line,
                            Transform::identity(),
                            None,
                        );
                    }
                }
                Item::Particle(i) => {
                    let p = points[i];
                    let r = (geometry.radius[i] * p.scale).max(view.min_radius_px);
                    if geometry.fixed[i] {
                        let half = r.max(2.5 * unit);
                        let c = fog(FIXED, p.fog);
                        if let Some(rect) = Rect::from_xywh(
                            (p.x - half) as f32,
                            (p.y - half) as f32,
                            (2.0 * half) as f32,
                            (2.0 * half) as f32,
                        ) {
                            pixmap.fill_rect(
                                rect,
                                &paint(rgb(c, 255)),
                                Transform::identity(),
                                None,
                            );
                        }
                        continue;
                    }
                    let c = fog(colormap(particle_value[i]), p.fog);
                    if let Some(path) = PathBuilder::from_circle(p.x as f32, p.y as f32, r as f32) {
                        pixmap.fill_path(
                            &path,
                            &paint(rgb(c, 255)),
                            FillRule::Winding,
                            Transform::identity(),
                            None,
                        );
                        if r >= 3.5 * unit {
                            pixmap.stroke_path(
                                &path,
                                &paint(rgb(darker(c, 0.6), 255)),
                                &outline,
                                Transform::identity(),
                                None,
                            );
                        }
                    }
                }
            }
        }
        Ok(Image::from_pixmap(pixmap))
    }

    fn draw_planes(&self, pixmap: &mut Pixmap, time: f64, unit: f64) {
        let camera = &self.camera;
        let ground_line = Stroke {
            width: (1.5 * unit) as f32,
            ..Stroke::default()
        };
        let grid_line = Stroke {
            width: (0.75 * unit) as f32,
            ..Stroke::default()
        };
        for plane in &self.geometry.planes {
            if camera.view.is_perspective() {
                let Some(patch) = camera.patch(plane, time) else {
                    continue;
                };
                let corners: Vec<(f64, f64)> = patch
                    .polygon
                    .iter()
                    .map(|&p| {
                        let q = camera.project3(p);
                        (q.x, q.y)
                    })
                    .collect();
                if let Some(path) = polygon_path(&corners) {
                    pixmap.fill_path(
                        &path,
                        &paint(FLOOR_FILL),
                        FillRule::Winding,
                        Transform::identity(),
                        None,
                    );
                }
                for (a, b) in &patch.grid {
                    let (a, b) = (camera.project3(*a), camera.project3(*b));
                    let mut pb = PathBuilder::new();
                    pb.move_to(a.x as f32, a.y as f32);
                    pb.line_to(b.x as f32, b.y as f32);
                    if let Some(path) = pb.finish() {
                        pixmap.stroke_path(
                            &path,
                            &paint(FLOOR_GRID),
                            &grid_line,
                            Transform::identity(),
                            None,
                        );
                    }
                }
                continue;
            }
            let (ab, k) = camera.trace(plane, time);
            let rect = camera.visible_rect();
            let excluded = clip_polygon(&rect, ab, k);
            let corners: Vec<(f64, f64)> = excluded.iter().map(|&p| camera.to_pixels(p)).collect();
            if let Some(path) = polygon_path(&corners) {
                pixmap.fill_path(
                    &path,
                    &paint(GROUND_FILL),
                    FillRule::Winding,
                    Transform::identity(),
                    None,
                );
            }
            let norm2 = ab.length_squared();
            if norm2 < 1e-18 {
                continue;
            }
            let foot = ab * k / norm2;
            let dir = ab.perp() / norm2.sqrt();
            let [lo, _, hi, _] = rect;
            let reach = {
                let (diagonal, from_middle) = (hi - lo, foot - (lo + hi) / 2.0);
                diagonal.x.hypot(diagonal.y) + from_middle.x.hypot(from_middle.y)
            };
            let a = foot - dir * reach;
            let b = foot + dir * reach;
            let halfspaces = [
                (DVec2::X, hi.x),
                (DVec2::NEG_X, -lo.x),
                (DVec2::Y, hi.y),
                (DVec2::NEG_Y, -lo.y),
            ];
            if let Some((p, q)) = clip_segment(a, b, &halfspaces) {
                let (p, q) = (camera.to_pixels(p), camera.to_pixels(q));
                let mut pb = PathBuilder::new();
                pb.move_to(p.0 as f32, p.1 as f32);
                pb.line_to(q.0 as f32, q.1 as f32);
                if let Some(path) = pb.finish() {
                    pixmap.stroke_path(
                        &path,
                        &paint(GROUND_LINE),
                        &ground_line,
                        Transform::identity(),
                        None,
                    );
                }
            }
        }
    }
}

fn speed(state: &State, i: usize) -> f64 {
    state.velocity(i).iter().map(|v| v * v).sum::<f64>().sqrt()
}

fn polygon_path(corners: &[(f64, f64)]) -> Option<tiny_skia::Path> {
    if corners.len() < 3 {
        return None;
    }
    let mut pb = PathBuilder::new();
    pb.move_to(corners[0].0 as f32, corners[0].1 as f32);
    for &(x, y) in &corners[1..] {
        pb.line_to(x as f32, y as f32);
    }
    pb.close();
    pb.finish()
}
