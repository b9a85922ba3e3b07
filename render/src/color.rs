//! Colours: the value → colour map, the palette, depth fog.
//!
//! ```text
//! speed      v = |v_i| / v_max ∈ [0, 1],  v_max = max over the run of |v_j|
//!            (dynamic particles), at least 0.01 L / dt (L: scene extent), so a
//!            run that barely moves is drawn slow rather than as amplified noise
//! residual   v = (log10 r − log10 1e-6) / 5  clamped to [0, 1],
//!            r = relative violation of the worst element touching the particle
//!                (see geometry::element_residual), so 1e-6 → 0, 1e-1 → 1
//! colour     piecewise-linear through five stops: blue → teal → green → amber → red
//! fog        c' = c + 0.6 · depth · (background − c),  depth ∈ [0, 1] (0 nearest)
//! ```

/// What the colour of particles and edges encodes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ColorBy {
    /// Speed relative to the fastest particle of the whole run.
    #[default]
    Speed,
    /// Relative constraint violation on a log scale from 1e-6 to 1e-1.
    Residual,
}

/// log10 of the residual drawn at the bottom of the colour map.
pub(crate) const RESIDUAL_LOG_MIN: f64 = -6.0;
/// log10 of the residual drawn at the top of the colour map.
pub(crate) const RESIDUAL_LOG_MAX: f64 = -1.0;

/// Picture background.
pub const BACKGROUND: [u8; 3] = [248, 247, 243];
/// The excluded half-space of a hyperplane.
pub(crate) const GROUND_FILL: [u8; 4] = [214, 208, 196, 255];
/// A hyperplane's trace.
pub(crate) const GROUND_LINE: [u8; 4] = [96, 88, 78, 255];
/// Floor patch in perspective.
pub(crate) const FLOOR_FILL: [u8; 4] = [205, 199, 186, 170];
/// Floor grid lines in perspective.
pub(crate) const FLOOR_GRID: [u8; 4] = [150, 143, 130, 150];
/// A simplex mesh's faces (translucent).
pub(crate) const MESH_FILL: [u8; 4] = [176, 186, 200, 150];
/// A simplex mesh's edges.
pub(crate) const MESH_EDGE: [u8; 4] = [104, 114, 130, 180];
/// Fixed particles.
pub(crate) const FIXED: [u8; 3] = [40, 40, 44];

const STOPS: [[f64; 3]; 5] = [
    [44.0, 62.0, 160.0],
    [27.0, 145.0, 165.0],
    [110.0, 185.0, 80.0],
    [238.0, 168.0, 38.0],
    [212.0, 45.0, 38.0],
];

/// The colour of `value` ∈ [0, 1] (clamped; NaN maps to 0).
pub fn colormap(value: f64) -> [u8; 3] {
    let v = if value.is_nan() {
        0.0
    } else {
        value.clamp(0.0, 1.0)
    };
    let x = v * (STOPS.len() - 1) as f64;
    let i = (x.floor() as usize).min(STOPS.len() - 2);
    let f = x - i as f64;
    let mut out = [0u8; 3];
    for (c, o) in out.iter_mut().enumerate() {
        *o = (STOPS[i][c] + f * (STOPS[i + 1][c] - STOPS[i][c])).round() as u8;
    }
    out
}

/// Colour-map position of a relative residual.
pub(crate) fn residual_value(r: f64) -> f64 {
    if r <= 0.0 || r.is_nan() {
        return 0.0;
    }
    ((r.log10() - RESIDUAL_LOG_MIN) / (RESIDUAL_LOG_MAX - RESIDUAL_LOG_MIN)).clamp(0.0, 1.0)
}

/// Mixes `c` towards the background by `0.6 · depth`.
pub(crate) fn fog(c: [u8; 3], depth: f64) -> [u8; 3] {
    let k = 0.6 * depth.clamp(0.0, 1.0);
    let mut out = [0u8; 3];
    for i in 0..3 {
        let a = f64::from(c[i]);
        let b = f64::from(BACKGROUND[i]);
        out[i] = (a + k * (b - a)).round() as u8;
    }
    out
}

/// A darker shade of `c` (outlines, edges).
pub(crate) fn darker(c: [u8; 3], k: f64) -> [u8; 3] {
    c.map(|x| (f64::from(x) * k).round() as u8)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn map_ends_and_clamps() {
        assert_eq!(colormap(0.0), [44, 62, 160]);
        assert_eq!(colormap(1.0), [212, 45, 38]);
        assert_eq!(colormap(-3.0), colormap(0.0));
        assert_eq!(colormap(f64::NAN), colormap(0.0));
        assert_eq!(colormap(7.0), colormap(1.0));
    }

    #[test]
    fn residual_scale() {
        assert_eq!(residual_value(1e-6), 0.0);
        assert_eq!(residual_value(1e-1), 1.0);
        assert!((residual_value(1e-3) - 0.6).abs() < 1e-12);
        assert_eq!(residual_value(0.0), 0.0);
    }
}
