//! The scene origin: f32 kernels work in coordinates relative to it.
//!
//! An f32 coordinate near magnitude X is rounded to ulp(X)/2 = 2⁻²⁴·2^⌊log₂X⌋:
//! 6.1e-5 m at X = 1e3 and 3.9e-3 m at X = 1e5 (ulp(1e5) = 7.8e-3 m). A
//! scene 1e5 m from the world origin then loses every displacement below
//! 4 mm per substep — gravity's h·v at 60 Hz × 10 substeps is 0.3 mm after
//! one second of fall — so it freezes, and constraint corrections are
//! quantised to that grid. Storing x − o instead, with o near the scene,
//! gives the f32 kernels the accuracy they have at the world origin.
//!
//! ```text
//! c = centre of the axis-aligned box of the initial positions
//! q = 2^⌈log₂ e⌉,  e = largest box edge (q = 1 when e = 0)
//! o = q · round(c / q)   where |c| ≥ 4q, else 0    (per axis; f64, exact)
//! upload        x_local = x − o               (f64, exact: see below)
//! hyperplane    n·x ≥ r  ⇔  n·x_local ≥ r − n·o
//! read back     x = x_local + o               (f64)
//! ```
//! o is a multiple of q ≥ e, so |x − o| ≤ 1.5 q: the subtraction of two
//! doubles of which the result is no larger than the operands and o has
//! no bits below q is exact. Translation-invariant constraints (distance,
//! simplex and oriented measures) do not change. An axis whose centre is
//! within 4q of the world origin is not shifted (it would gain at most two
//! bits), so a scene near the world origin runs exactly as without this.
//!
//! f64 kernels keep o = 0 ([`SceneOrigin::for_state`]): a shift would
//! reorder their roundings and break bit identity with the CPU golden path,
//! and f64 has ulp(1e5) = 1.5e-11 m to spare.
//!
//! Anything the GPU stores in world coordinates (positions, hyperplane
//! offsets, static obstacle geometry) goes through this one type.

use crate::Precision;

/// The translation between world coordinates and the coordinates the GPU
/// stores.
#[derive(Debug, Clone, PartialEq)]
pub struct SceneOrigin {
    origin: Vec<f64>,
}

impl SceneOrigin {
    /// No shift: device coordinates are world coordinates.
    pub fn zero(dim: usize) -> Self {
        SceneOrigin {
            origin: vec![0.0; dim],
        }
    }

    /// The origin the backend uses for `positions` (flat, `dim` per
    /// particle) at `precision`: the rounded box centre in f32, zero in
    /// f64.
    pub fn for_state(dim: usize, positions: &[f64], precision: Precision) -> Self {
        match precision {
            Precision::F32 => Self::box_centre(dim, positions),
            Precision::F64 => Self::zero(dim),
        }
    }

    /// o = q · round(c / q), c the centre of the bounding box, q the
    /// power of two at or above its largest edge; 0 on axes with
    /// |c| < 4q.
    pub fn box_centre(dim: usize, positions: &[f64]) -> Self {
        if dim == 0 || positions.len() < dim {
            return Self::zero(dim);
        }
        let mut low = vec![f64::INFINITY; dim];
        let mut high = vec![f64::NEG_INFINITY; dim];
        for point in positions.chunks_exact(dim) {
            for a in 0..dim {
                low[a] = low[a].min(point[a]);
                high[a] = high[a].max(point[a]);
            }
        }
        let edge = (0..dim).map(|a| high[a] - low[a]).fold(0.0, f64::max);
        if !edge.is_finite() {
            return Self::zero(dim);
        }
        let q = if edge > 0.0 {
            libm::exp2(libm::ceil(libm::log2(edge)))
        } else {
            1.0
        };
        let origin = (0..dim)
            .map(|a| {
                let centre = 0.5 * low[a] + 0.5 * high[a];
                let o = q * libm::round(centre / q);
                if o.is_finite() && centre.abs() >= 4.0 * q {
                    o
                } else {
                    0.0
                }
            })
            .collect();
        SceneOrigin { origin }
    }

    /// The origin o (world coordinates).
    pub fn as_slice(&self) -> &[f64] {
        &self.origin
    }

    /// True when o = 0 (no shift at all).
    pub fn is_zero(&self) -> bool {
        self.origin.iter().all(|&o| o == 0.0)
    }

    /// World positions (flat) to device positions: x − o.
    pub fn to_local(&self, positions: &[f64]) -> Vec<f64> {
        if self.is_zero() {
            return positions.to_vec();
        }
        let dim = self.origin.len();
        positions
            .chunks_exact(dim)
            .flat_map(|p| p.iter().zip(&self.origin).map(|(x, o)| x - o))
            .collect()
    }

    /// Device positions (flat) back to world positions: x_local + o.
    pub fn to_world(&self, positions: &mut [f64]) {
        if self.is_zero() {
            return;
        }
        let dim = self.origin.len();
        for p in positions.chunks_exact_mut(dim) {
            for (x, o) in p.iter_mut().zip(&self.origin) {
                *x += o;
            }
        }
    }

    /// The right-hand side of a half-space n·x ≥ `rest` in device
    /// coordinates: rest − n·o.
    pub fn local_offset(&self, normal: &[f64], rest: f64) -> f64 {
        if self.is_zero() {
            return rest;
        }
        let shift: f64 = normal.iter().zip(&self.origin).map(|(n, o)| n * o).sum();
        rest - shift
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scenes_near_the_world_origin_are_not_shifted() {
        let positions = [-0.5, 0.5, 0.0, 0.5, 0.9, 0.0, 0.0, 3.0, 0.0];
        assert!(SceneOrigin::box_centre(3, &positions).is_zero());
        assert!(SceneOrigin::for_state(3, &[1e5, 0.0, 0.0], Precision::F64).is_zero());
    }

    #[test]
    fn far_scenes_are_shifted_exactly() {
        let positions = [1e5 + 0.25, -3e3, 1e5 - 0.75, -3e3 + 1.0];
        let origin = SceneOrigin::box_centre(2, &positions);
        assert_eq!(origin.as_slice(), &[1e5, -3e3]);
        // An axis near the world origin stays put: q = 1, centre 2 < 4q.
        let mixed = SceneOrigin::box_centre(2, &[1e5, 1.5, 1e5 + 1.0, 2.5]);
        assert_eq!(mixed.as_slice(), &[1e5 + 1.0, 0.0]);
        let local = origin.to_local(&positions);
        let mut back = local.clone();
        origin.to_world(&mut back);
        assert_eq!(back, positions, "x - o + o is exact");
        assert!(local.iter().all(|x| x.abs() <= 1.0));
    }

    #[test]
    fn half_spaces_move_with_the_origin() {
        let origin = SceneOrigin::box_centre(2, &[1e3, 2e3, 1e3, 2e3]);
        let normal = [0.6, 0.8];
        let world = [1e3 + 0.1, 2e3 - 0.2];
        let local = origin.to_local(&world);
        let lhs_world: f64 = normal.iter().zip(&world).map(|(n, x)| n * x).sum();
        let lhs_local: f64 = normal.iter().zip(&local).map(|(n, x)| n * x).sum();
        let rest = 2200.0;
        let gap_world = lhs_world - rest;
        let gap_local = lhs_local - origin.local_offset(&normal, rest);
        assert!(
            (gap_world - gap_local).abs() < 1e-9,
            "{gap_world} vs {gap_local}"
        );
    }
}
