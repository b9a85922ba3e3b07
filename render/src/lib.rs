//! hyperpbd-render: pictures of N-dimensional particle scenes.
//!
//! ```text
//! Scene + Options ──View::new──▶ View            (options checked against the scene)
//! View + snapshots ──Renderer::new──▶ Renderer  (framing fitted to every snapshot)
//! Renderer::draw(snapshot) ──▶ Image ──▶ PNG bytes / GifEncoder frame
//! ```
//!
//! A picture is a projection of R^N onto the image plane (see [`view`]):
//! orthographic onto two chosen axes, or, for N ≥ 3, a perspective camera
//! (N ≥ 4: a 4D→3D perspective first, then 3D→2D) with depth shading,
//! optionally turning in one coordinate plane over time. Particles are
//! discs sized by their radius, constraint elements are drawn as their
//! edges, hyperplanes as the slice of the hyperplane through the view (a
//! line with the excluded half-space shaded, or a floor patch in
//! perspective), simplex meshes as their faces. Colour is speed or constraint residual ([`ColorBy`]).
//!
//! All drawing goes through `tiny-skia` (anti-aliased paths); PNG encoding
//! through `tiny-skia`'s `png` support, animation through the `gif` crate.
//! Everything is a pure function of the scene, the options and the
//! snapshots: the same run gives the same bytes.

pub mod chart;
mod color;
mod draw;
mod encode;
mod error;
mod framing;
mod geometry;
mod mesh;
pub mod view;

pub use color::{BACKGROUND, ColorBy, colormap};
pub use draw::{PixelMap, Renderer};
pub use encode::{GifEncoder, Image};
pub use error::RenderError;
pub use view::{Options, View, parse_axes};

use hyperpbd_core::State;

/// One recorded moment of a run: the frame number, its time and the state.
#[derive(Debug, Clone, PartialEq)]
pub struct Snapshot {
    /// Frame (step) number; 0 is the initial state.
    pub frame: u64,
    /// Simulated time in seconds.
    pub time: f64,
    /// Positions and velocities.
    pub state: State,
}
