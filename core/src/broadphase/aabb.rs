//! Axis-aligned boxes in R^N, flat: box i spans `min[i N + a] ..= max[i N + a]`.
//!
//! ```text
//! particle (static)   lo = x − (r + m),              hi = x + (r + m)
//! particle (swept)    lo = min(x, y) − (r + m),      hi = max(x, y) + (r + m)
//! simplex             lo = min over vertices − m,    hi = max over vertices + m
//! ```
//! A swept box covers the straight path from the start x to the predicted
//! end y of a step, so any contact along the step is a candidate.

/// The swept boxes of the particles whose radii are `radius` (any run of
/// particles: `start`, `end`, `min` and `max` hold their coordinates,
/// `radius.len()` × N values each) into `min` and `max`.
pub fn swept_boxes(
    start: &[f64],
    end: &[f64],
    radius: &[f64],
    margin: f64,
    min: &mut [f64],
    max: &mut [f64],
) {
    let dim = start.len().checked_div(radius.len()).unwrap_or(0);
    for (i, &r) in radius.iter().enumerate() {
        let pad = r + margin;
        for a in i * dim..(i + 1) * dim {
            let (s, e) = (start[a], end[a]);
            min[a] = s.min(e) - pad;
            max[a] = s.max(e) + pad;
        }
    }
}

/// Boxes of one kind of object, `dim` coordinates each.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Aabbs {
    /// Dimension N.
    pub dim: usize,
    /// Lower corners, `len × dim`.
    pub min: Vec<f64>,
    /// Upper corners, `len × dim`.
    pub max: Vec<f64>,
}

impl Aabbs {
    /// Boxes from flat corner arrays (equal lengths, multiples of `dim`).
    pub fn new(dim: usize, min: Vec<f64>, max: Vec<f64>) -> Self {
        debug_assert_eq!(min.len(), max.len());
        Aabbs { dim, min, max }
    }

    /// Number of boxes.
    pub fn len(&self) -> usize {
        self.min.len().checked_div(self.dim).unwrap_or(0)
    }

    /// True without boxes.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The boxes as an f32 kernel must hold them: every lower corner
    /// rounded down and every upper corner rounded up to f32
    /// ([`key_down`](super::key_down), [`key_up`](super::key_up)), so each box
    /// contains its f64 original and no overlapping pair is lost to rounding
    /// (values exact in f32 are unchanged, up to the sign of zero).
    pub fn rounded_outward_to_f32(&self) -> Self {
        Aabbs {
            dim: self.dim,
            min: self
                .min
                .iter()
                .map(|&v| f64::from(super::key_down(v)))
                .collect(),
            max: self
                .max
                .iter()
                .map(|&v| f64::from(super::key_up(v)))
                .collect(),
        }
    }

    /// Static particle boxes: x_i ± (r_i + margin).
    pub fn particles(dim: usize, x: &[f64], radius: &[f64], margin: f64) -> Self {
        Self::swept_particles(dim, x, x, radius, margin)
    }

    /// Swept particle boxes over a step from `start` to the predicted `end`.
    pub fn swept_particles(
        dim: usize,
        start: &[f64],
        end: &[f64],
        radius: &[f64],
        margin: f64,
    ) -> Self {
        let mut min = vec![0.0; start.len()];
        let mut max = vec![0.0; start.len()];
        swept_boxes(start, end, radius, margin, &mut min, &mut max);
        Aabbs { dim, min, max }
    }

    /// Boxes of simplices: `simplices` holds `arity` point indices per
    /// simplex into the flat `points`; each box is padded by `margin`.
    pub fn simplices(
        dim: usize,
        points: &[f64],
        simplices: &[u32],
        arity: usize,
        margin: f64,
    ) -> Self {
        let count = simplices.len().checked_div(arity).unwrap_or(0);
        let mut min = vec![f64::INFINITY; count * dim];
        let mut max = vec![f64::NEG_INFINITY; count * dim];
        for (s, simplex) in simplices.chunks_exact(arity.max(1)).enumerate() {
            for &v in simplex {
                let v = v as usize;
                for a in 0..dim {
                    let c = points[v * dim + a];
                    min[s * dim + a] = min[s * dim + a].min(c);
                    max[s * dim + a] = max[s * dim + a].max(c);
                }
            }
            for a in 0..dim {
                min[s * dim + a] -= margin;
                max[s * dim + a] += margin;
            }
        }
        Aabbs { dim, min, max }
    }

    /// Closed-interval overlap on every axis (touching boxes overlap).
    pub fn overlap(&self, i: usize, j: usize) -> bool {
        let d = self.dim;
        (0..d).all(|a| {
            self.min[i * d + a] <= self.max[j * d + a] && self.min[j * d + a] <= self.max[i * d + a]
        })
    }
}
