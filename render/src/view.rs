//! Views: which axes of R^N reach the picture, and how.
//!
//! ```text
//! y = Rot_ab(ω t) (x − c)          c: centre of the run's bounding box;
//!                                  Rot_ab turns the (a, b) coordinate plane
//!                                  (identity without --rotate)
//! orthographic   (s, t) = (y_h, σ y_v)
//! perspective    X = y_h, Y = σ y_v, Z = y_d, W = y_w (N ≥ 4, else 0)
//!   4D → 3D      f = D4 / (D4 − W/R),  D4 = 3          (R: largest |x − c| of the run)
//!                (X, Y − Y0, Z) ← f (X, Y − Y0, Z)      (Y0: lowest point of the run,
//!                                                       so what rests on the floor stays there)
//!   3D → 2D      camera on a sphere of radius D3 = 5R around the centre at azimuth φ and
//!                elevation ε, looking at it:  (s, t) = (x_r, y_u) · D3 / (D3 − z_b)
//!   depth shade  3D distance and (N ≥ 4) the 4th coordinate W fade colours
//!                towards the background, far side palest
//! ```
//! h and v are the horizontal and vertical axes; σ = −1 when the vertical
//! axis is the gravity axis and gravity points along +v (so "up" is always
//! opposite gravity), else +1. Axes of R^N not named by the view are
//! dropped (orthographic in them).

use crate::{ColorBy, RenderError};
use glam::DVec3;
use hyperpbd_core::Scene;

/// Rendering options, as the `render` command takes them.
#[derive(Debug, Clone, PartialEq)]
pub struct Options {
    /// Picture width in pixels (16..=4096).
    pub width: u32,
    /// Picture height in pixels (16..=4096).
    pub height: u32,
    /// Axes shown: `[h, v]` (orthographic) or `[h, v, depth[, w]]`
    /// (perspective). `None`: x horizontal, the up axis vertical.
    pub axes: Option<Vec<usize>>,
    /// Perspective camera (N ≥ 3; N ≥ 4 adds a 4D→3D perspective).
    pub perspective: bool,
    /// Coordinate plane `[a, b]` turned at `rotate_speed` rad/s.
    pub rotate: Option<Vec<usize>>,
    /// Angular speed of the rotation in rad/s of simulated time.
    pub rotate_speed: f64,
    /// What colour encodes.
    pub color: ColorBy,
    /// Perspective camera azimuth in degrees (turns about the up axis).
    pub azimuth_deg: f64,
    /// Perspective camera elevation in degrees (−89..=89; positive looks down).
    pub elevation_deg: f64,
    /// Smallest disc radius in pixels (particles of radius 0 get this);
    /// `None`: 3.5 px for scenes of at most 100 particles, else 2 px, both
    /// scaled with the picture (× min(width, height) / 360, at least 0.75).
    pub min_radius_px: Option<f64>,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            width: 480,
            height: 360,
            axes: None,
            perspective: false,
            rotate: None,
            rotate_speed: 0.5,
            color: ColorBy::Speed,
            azimuth_deg: 30.0,
            elevation_deg: 25.0,
            min_radius_px: None,
        }
    }
}

/// How R^N reaches the picture plane.
#[derive(Debug, Clone, PartialEq)]
pub enum Projection {
    /// Drop every axis except the horizontal and vertical ones.
    Orthographic,
    /// Perspective camera.
    Perspective {
        /// Axis along the 3D depth.
        depth: usize,
        /// Axis of the 4D→3D perspective (N ≥ 4).
        w: Option<usize>,
        /// Camera azimuth, radians.
        azimuth: f64,
        /// Camera elevation, radians.
        elevation: f64,
    },
}

/// A checked view: options resolved against one scene.
#[derive(Debug, Clone, PartialEq)]
pub struct View {
    /// Dimension N of the scene.
    pub dim: usize,
    /// Axis drawn left to right.
    pub horizontal: usize,
    /// Axis drawn bottom to top.
    pub vertical: usize,
    /// +1, or −1 when gravity points along +vertical (up is opposite gravity).
    pub up_sign: f64,
    /// Orthographic or perspective.
    pub projection: Projection,
    /// Rotation plane (a, b) and angular speed in rad/s.
    pub rotate: Option<(usize, usize, f64)>,
    /// Picture width in pixels.
    pub width: u32,
    /// Picture height in pixels.
    pub height: u32,
    /// What colour encodes.
    pub color: ColorBy,
    /// Smallest disc radius in pixels.
    pub min_radius_px: f64,
    /// Why the vertical axis was chosen (for messages).
    pub vertical_reason: String,
}

/// Parses an axis list such as `0,3` or `x,w` (x, y, z, w name axes 0..=3).
pub fn parse_axes(option: &'static str, text: &str) -> Result<Vec<usize>, RenderError> {
    text.split(',')
        .map(|token| {
            let token = token.trim();
            match token {
                "x" | "X" => Ok(0),
                "y" | "Y" => Ok(1),
                "z" | "Z" => Ok(2),
                "w" | "W" => Ok(3),
                _ => token.parse::<usize>().map_err(|_| {
                    RenderError::option(
                        option,
                        format!(
                            "unknown axis {token:?} in {text:?}; axes are numbers 0..N-1 (or x, y, z, w for 0..3), separated by commas, e.g. 0,1"
                        ),
                    )
                }),
            }
        })
        .collect()
}

/// The axis gravity pulls along (largest |g| component, lowest index on a
/// tie) and its sign, if the scene has gravity.
fn gravity_axis(scene: &Scene) -> Option<(usize, f64)> {
    let g = scene.gravity.as_ref()?;
    let mut best: Option<(usize, f64)> = None;
    for (a, &ga) in g.iter().enumerate() {
        if ga != 0.0 && best.is_none_or(|(_, gb)| ga.abs() > gb.abs()) {
            best = Some((a, ga));
        }
    }
    best
}

fn check_axes(
    option: &'static str,
    axes: &[usize],
    dim: usize,
    text: &str,
) -> Result<(), RenderError> {
    for &a in axes {
        if a >= dim {
            return Err(RenderError::option(
                option,
                format!(
                    "axis {a} in {text} is out of range: the scene has dim {dim}, so axes are 0..={}",
                    dim - 1
                ),
            ));
        }
    }
    for (i, a) in axes.iter().enumerate() {
        if axes[..i].contains(a) {
            return Err(RenderError::option(
                option,
                format!("axis {a} appears twice in {text}; the axes must differ"),
            ));
        }
    }
    Ok(())
}

fn list(axes: &[usize]) -> String {
    axes.iter()
        .map(usize::to_string)
        .collect::<Vec<_>>()
        .join(",")
}

impl View {
    /// Checks `options` against `scene` and resolves the defaults.
    pub fn new(scene: &Scene, options: &Options) -> Result<View, RenderError> {
        let dim = scene.dim;
        for (option, value) in [("--width", options.width), ("--height", options.height)] {
            if !(16..=4096).contains(&value) {
                return Err(RenderError::option(
                    option,
                    format!("{value} pixels is outside 16..=4096"),
                ));
            }
        }
        let min_radius_px = match options.min_radius_px {
            Some(r) if !(r.is_finite() && (0.0..=100.0).contains(&r)) => {
                return Err(RenderError::option(
                    "--min-radius",
                    format!("{r} pixels is outside 0..=100"),
                ));
            }
            Some(r) => r,
            None => {
                let base = if scene.particles.len() <= 100 {
                    3.5
                } else {
                    2.0
                };
                base * (f64::from(options.width.min(options.height)) / 360.0).max(0.75)
            }
        };
        if dim < 2 {
            return Err(RenderError::option(
                "--axes",
                format!(
                    "the scene has dim {dim}, but a picture needs two axes (horizontal and vertical), so N must be at least 2"
                ),
            ));
        }
        if options.perspective && dim < 3 {
            return Err(RenderError::option(
                "--perspective",
                format!(
                    "a perspective view needs a depth axis, so dim ≥ 3; the scene has dim {dim} (leave --perspective out for an orthographic picture)"
                ),
            ));
        }
        let gravity = gravity_axis(scene);
        let (horizontal, vertical, extra, vertical_reason) = match &options.axes {
            Some(axes) => {
                let text = list(axes);
                let allowed = if options.perspective { 2..=4 } else { 2..=2 };
                if !allowed.contains(&axes.len()) {
                    return Err(RenderError::option(
                        "--axes",
                        if options.perspective {
                            format!(
                                "{text}: a perspective view takes 2 to 4 axes (horizontal, vertical, depth, 4th)"
                            )
                        } else {
                            format!(
                                "{text}: an orthographic view takes exactly 2 axes (horizontal, vertical); pass --perspective to name a depth axis"
                            )
                        },
                    ));
                }
                check_axes("--axes", axes, dim, &text)?;
                (
                    axes[0],
                    axes[1],
                    axes[2..].to_vec(),
                    "chosen with --axes".to_string(),
                )
            }
            None => {
                let (up, reason) = match gravity {
                    Some((a, _)) => (a, "up: opposite gravity".to_string()),
                    None => (1, "up: the scene has no gravity".to_string()),
                };
                let horizontal = if up == 0 { 1 } else { 0 };
                (horizontal, up, Vec::new(), reason)
            }
        };
        let up_sign = match gravity {
            Some((a, g)) if a == vertical && g > 0.0 => -1.0,
            _ => 1.0,
        };
        let projection = if options.perspective {
            let mut remaining =
                (0..dim).filter(|a| ![horizontal, vertical].contains(a) && !extra.contains(a));
            let depth = match extra.first() {
                Some(&d) => d,
                None => remaining.next().unwrap_or(0),
            };
            let w = match extra.get(1) {
                Some(&w) => Some(w),
                None => remaining.next(),
            };
            for (option, value) in [
                ("--azimuth", options.azimuth_deg),
                ("--elevation", options.elevation_deg),
            ] {
                if !value.is_finite() {
                    return Err(RenderError::option(
                        option,
                        format!("{value} is not a finite angle"),
                    ));
                }
            }
            if !(-89.0..=89.0).contains(&options.elevation_deg) {
                return Err(RenderError::option(
                    "--elevation",
                    format!("{} degrees is outside -89..=89", options.elevation_deg),
                ));
            }
            Projection::Perspective {
                depth,
                w,
                azimuth: options.azimuth_deg.to_radians(),
                elevation: options.elevation_deg.to_radians(),
            }
        } else {
            Projection::Orthographic
        };
        let rotate = match &options.rotate {
            None => None,
            Some(axes) => {
                let text = list(axes);
                if axes.len() != 2 {
                    return Err(RenderError::option(
                        "--rotate",
                        format!("{text}: a rotation plane is two axes, e.g. 0,3"),
                    ));
                }
                check_axes("--rotate", axes, dim, &text)?;
                if !options.rotate_speed.is_finite() {
                    return Err(RenderError::option(
                        "--rotate-speed",
                        format!("{} is not a finite angular speed", options.rotate_speed),
                    ));
                }
                Some((axes[0], axes[1], options.rotate_speed))
            }
        };
        Ok(View {
            dim,
            horizontal,
            vertical,
            up_sign,
            projection,
            rotate,
            width: options.width,
            height: options.height,
            color: options.color,
            min_radius_px,
            vertical_reason,
        })
    }

    /// One line saying what the picture shows.
    pub fn describe(&self) -> String {
        let up = if self.up_sign < 0.0 { "-" } else { "" };
        let mut s = match &self.projection {
            Projection::Orthographic => format!(
                "orthographic: axis {} horizontal, axis {up}{} vertical ({})",
                self.horizontal, self.vertical, self.vertical_reason
            ),
            Projection::Perspective {
                depth,
                w,
                azimuth,
                elevation,
            } => {
                let mut s = format!(
                    "perspective: axis {} horizontal, axis {up}{} vertical ({}), axis {depth} depth",
                    self.horizontal, self.vertical, self.vertical_reason
                );
                if let Some(w) = w {
                    s += &format!(", axis {w} as the 4th dimension (4D→3D perspective)");
                }
                s + &format!(
                    "; camera azimuth {:.0}°, elevation {:.0}°",
                    azimuth.to_degrees(),
                    elevation.to_degrees()
                )
            }
        };
        let shown = self.shown_axes();
        let dropped: Vec<String> = (0..self.dim)
            .filter(|a| !shown.contains(a))
            .map(|a| a.to_string())
            .collect();
        if !dropped.is_empty() {
            s += &format!("; axes {} not shown", dropped.join(","));
        }
        if let Some((a, b, speed)) = self.rotate {
            s += &format!("; turning in plane {a},{b} at {speed} rad/s");
        }
        s
    }

    /// The axes that reach the picture.
    pub fn shown_axes(&self) -> Vec<usize> {
        let mut axes = vec![self.horizontal, self.vertical];
        if let Projection::Perspective { depth, w, .. } = self.projection {
            axes.push(depth);
            axes.extend(w);
        }
        axes
    }

    /// True for the perspective camera.
    pub fn is_perspective(&self) -> bool {
        matches!(self.projection, Projection::Perspective { .. })
    }

    /// `y = Rot(t) (x − c)` into `out`.
    pub(crate) fn centred(&self, x: &[f64], centre: &[f64], time: f64, out: &mut [f64]) {
        for ((o, xa), ca) in out.iter_mut().zip(x).zip(centre) {
            *o = xa - ca;
        }
        self.rotate_vector(time, out);
    }

    /// Applies the rotation at time `t` to a vector in place.
    pub(crate) fn rotate_vector(&self, time: f64, v: &mut [f64]) {
        if let Some((a, b, speed)) = self.rotate {
            let angle = speed * time;
            let (sin, cos) = angle.sin_cos();
            let (va, vb) = (v[a], v[b]);
            v[a] = cos * va - sin * vb;
            v[b] = sin * va + cos * vb;
        }
    }

    /// The 3D view coordinates (X, Y, Z) and W of a centred, rotated point.
    pub(crate) fn view_coords(&self, y: &[f64]) -> (DVec3, f64) {
        let x = y[self.horizontal];
        let up = self.up_sign * y[self.vertical];
        match self.projection {
            Projection::Orthographic => (DVec3::new(x, up, 0.0), 0.0),
            Projection::Perspective { depth, w, .. } => {
                (DVec3::new(x, up, y[depth]), w.map_or(0.0, |w| y[w]))
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use hyperpbd_core::{Particle, SceneBuilder};

    fn scene(dim: usize, gravity_axis: Option<usize>) -> Scene {
        let mut b = SceneBuilder::new(dim).dt(0.01);
        if let Some(a) = gravity_axis {
            b = b.gravity_along(a, 9.81);
        }
        b.particle(Particle::new(vec![0.0; dim], 1.0));
        b.build().unwrap()
    }

    #[test]
    fn parses_numbers_and_letters() {
        assert_eq!(parse_axes("--axes", "0,3").unwrap(), vec![0, 3]);
        assert_eq!(parse_axes("--axes", "x, w").unwrap(), vec![0, 3]);
        let e = parse_axes("--axes", "0,q").unwrap_err().to_string();
        assert!(e.contains("unknown axis \"q\""), "{e}");
    }

    #[test]
    fn default_vertical_is_up() {
        let v = View::new(&scene(4, Some(3)), &Options::default()).unwrap();
        assert_eq!((v.horizontal, v.vertical, v.up_sign), (0, 3, 1.0));
        let v = View::new(&scene(3, None), &Options::default()).unwrap();
        assert_eq!((v.horizontal, v.vertical), (0, 1));
        let v = View::new(&scene(3, Some(0)), &Options::default()).unwrap();
        assert_eq!((v.horizontal, v.vertical), (1, 0));
        let mut s = scene(3, None);
        s.gravity = Some(vec![0.0, 0.0, 9.81]);
        let v = View::new(&s, &Options::default()).unwrap();
        assert_eq!((v.vertical, v.up_sign), (2, -1.0));
    }

    #[test]
    fn perspective_picks_depth_and_w() {
        let options = Options {
            perspective: true,
            ..Options::default()
        };
        let v = View::new(&scene(4, Some(3)), &options).unwrap();
        assert!(matches!(
            v.projection,
            Projection::Perspective {
                depth: 1,
                w: Some(2),
                ..
            }
        ));
        let v = View::new(&scene(3, Some(1)), &options).unwrap();
        assert!(matches!(
            v.projection,
            Projection::Perspective {
                depth: 2,
                w: None,
                ..
            }
        ));
    }

    #[test]
    fn rejects_bad_axes() {
        let bad = |dim: usize, options: Options| {
            View::new(&scene(dim, None), &options)
                .unwrap_err()
                .to_string()
        };
        let axes = |a: Vec<usize>| Options {
            axes: Some(a),
            ..Options::default()
        };
        assert!(bad(3, axes(vec![0, 3])).contains("out of range"));
        assert!(bad(3, axes(vec![1, 1])).contains("twice"));
        assert!(bad(3, axes(vec![0, 1, 2])).contains("exactly 2"));
        assert!(bad(1, Options::default()).contains("at least 2"));
        assert!(
            bad(
                2,
                Options {
                    perspective: true,
                    ..Options::default()
                }
            )
            .contains("dim ≥ 3")
        );
        assert!(
            bad(
                3,
                Options {
                    rotate: Some(vec![0, 4]),
                    ..Options::default()
                }
            )
            .starts_with("--rotate: axis 4")
        );
    }
}
