//! Per-element rest data: the rest frame R and the rest k-measure V_0,
//! computed once from rest positions.
//!
//! ```text
//! D_m = [X_1 − X_0 … X_k − X_0]     (N × k)
//! D_m = Q U                          (modified Gram–Schmidt, j ascending:
//!                                     v = d_j;  for i < j: u_ij = q_i·v, v −= u_ij q_i;
//!                                     u_jj = |v| (refuse unless > 0), q_j = v / u_jj)
//! G_0 = D_mᵀ D_m = Uᵀ U = L Lᵀ,  L = Uᵀ  (U has a positive diagonal: L is G_0's Cholesky factor)
//! V_0 = (Π_j u_jj) / k!             (= √det G_0 / k!)
//! R   = U⁻¹ = (L⁻¹)ᵀ                 (upper triangular, R Rᵀ = G_0⁻¹, D_m R = Q)
//! k = N and det D_m < 0:  R[:, k−1] ← −R[:, k−1]   (then D_m R ∈ SO(N) and det F̂ = J)
//! degenerate unless V_0 > DEGENERATE_VOLUME_RATIO · ℓ^k / k!,  ℓ = longest vertex distance
//! ```
//! The factor comes from a QR of D_m rather than a Cholesky of G_0 so that
//! a thin rest simplex keeps its accuracy: forming G_0 squares the
//! condition number (a pivot of G_0 is only known to ε ℓ², so a collinear
//! triangle would get V_0 ≈ √ε ℓ² instead of ≈ ε ℓ²). The floor is the one
//! scene validation applies to oriented-measure elements.

use super::cholesky::lower_triangular_inverse;
use super::{MaterialError, MaterialScratch, RestView};
use crate::DEGENERATE_VOLUME_RATIO;
use crate::geometry::edge_matrix;
use crate::geometry::{determinant, factorial};

/// Why a rest simplex defines no element: its measure and the floor it
/// is not above.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DegenerateRest {
    /// V_0 as computed (0 when an edge lies in the span of the previous
    /// ones exactly).
    pub measure: f64,
    /// The degeneracy floor.
    pub floor: f64,
}

/// The rest frame R of the simplex `points` (k + 1 points of length
/// `dim`, k = points / dim − 1) into `frame` (k × k), returning V_0.
pub fn rest_element(
    points: &[f64],
    dim: usize,
    frame: &mut [f64],
    scratch: &mut MaterialScratch,
) -> Result<f64, DegenerateRest> {
    let k = points.len() / dim - 1;
    scratch.resize(k, dim);
    let MaterialScratch {
        edges,
        image: q,
        factor,
        factor_inverse,
        square,
        ..
    } = scratch;
    edge_matrix(points, dim, k, edges);
    let mut longest: f64 = 0.0;
    for i in 0..=k {
        for j in i + 1..=k {
            let mut d2 = 0.0;
            for a in 0..dim {
                let d = points[j * dim + a] - points[i * dim + a];
                d2 += d * d;
            }
            longest = longest.max(d2.sqrt());
        }
    }
    let floor = DEGENERATE_VOLUME_RATIO * longest.powi(k as i32) / factorial(k);
    factor[..k * k].fill(0.0);
    let mut product = 1.0;
    for j in 0..k {
        for a in 0..dim {
            q[a * k + j] = edges[a * k + j];
        }
        for i in 0..j {
            let mut u = 0.0;
            for a in 0..dim {
                u += q[a * k + i] * q[a * k + j];
            }
            for a in 0..dim {
                q[a * k + j] -= u * q[a * k + i];
            }
            factor[j * k + i] = u;
        }
        let mut norm2 = 0.0;
        for a in 0..dim {
            norm2 += q[a * k + j] * q[a * k + j];
        }
        let u = norm2.sqrt();
        if u.is_nan() || u <= 0.0 {
            return Err(DegenerateRest {
                measure: 0.0,
                floor,
            });
        }
        factor[j * k + j] = u;
        product *= u;
        for a in 0..dim {
            q[a * k + j] /= u;
        }
    }
    let measure = product / factorial(k);
    if !(measure > floor && measure.is_finite()) {
        return Err(DegenerateRest { measure, floor });
    }
    lower_triangular_inverse(factor, k, factor_inverse);
    for i in 0..k {
        for j in 0..k {
            frame[i * k + j] = factor_inverse[j * k + i];
        }
    }
    if k == dim {
        square[..k * k].copy_from_slice(&edges[..k * k]);
        if determinant(square, k) < 0.0 {
            for i in 0..k {
                frame[i * k + k - 1] = -frame[i * k + k - 1];
            }
        }
    }
    Ok(measure)
}

/// The rest data of every element of one material family.
#[derive(Debug, Clone, PartialEq)]
pub struct RestShapes {
    order: usize,
    frames: Vec<f64>,
    measures: Vec<f64>,
}

impl RestShapes {
    /// Rest data of `elements` (each k + 1 particle indices, the same k
    /// for all) over the flat rest `positions` (particles × `dim`).
    pub fn compile(
        dim: usize,
        elements: &[Vec<usize>],
        positions: &[f64],
    ) -> Result<RestShapes, MaterialError> {
        if dim == 0 || !positions.len().is_multiple_of(dim) {
            return Err(MaterialError::PositionsLength {
                len: positions.len(),
                dim,
            });
        }
        let count = positions.len() / dim;
        let vertices = elements.first().map_or(0, Vec::len);
        let order = vertices.saturating_sub(1);
        let mut shapes = RestShapes {
            order,
            frames: vec![0.0; elements.len() * order * order],
            measures: Vec::with_capacity(elements.len()),
        };
        let mut points = Vec::with_capacity(vertices * dim);
        let mut scratch = MaterialScratch::new();
        for (e, element) in elements.iter().enumerate() {
            if element.len() != vertices {
                return Err(MaterialError::MixedOrder {
                    element: e,
                    expected: vertices,
                    found: element.len(),
                });
            }
            if order < 1 || order > dim {
                return Err(MaterialError::Order {
                    element: e,
                    vertices,
                    dim,
                });
            }
            points.clear();
            for &i in element {
                if i >= count {
                    return Err(MaterialError::IndexOutOfRange {
                        element: e,
                        index: i,
                        count,
                    });
                }
                points.extend_from_slice(&positions[i * dim..(i + 1) * dim]);
            }
            let frame = &mut shapes.frames[e * order * order..(e + 1) * order * order];
            let measure = rest_element(&points, dim, frame, &mut scratch).map_err(|d| {
                MaterialError::DegenerateRest {
                    element: e,
                    order,
                    measure: d.measure,
                    floor: d.floor,
                }
            })?;
            shapes.measures.push(measure);
        }
        Ok(shapes)
    }

    /// The simplex order k.
    pub fn order(&self) -> usize {
        self.order
    }

    /// Number of elements.
    pub fn len(&self) -> usize {
        self.measures.len()
    }

    /// True with no element.
    pub fn is_empty(&self) -> bool {
        self.measures.is_empty()
    }

    /// Rest data of element `e`.
    pub fn element(&self, e: usize) -> RestView<'_> {
        let kk = self.order * self.order;
        RestView {
            frame: &self.frames[e * kk..(e + 1) * kk],
            measure: self.measures[e],
        }
    }

    /// Every R, k × k per element, in element order (the layout a kernel
    /// buffer takes).
    pub fn frames(&self) -> &[f64] {
        &self.frames
    }

    /// Every V_0, in element order.
    pub fn measures(&self) -> &[f64] {
        &self.measures
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frame_orthonormalises_the_rest_edges() {
        // A sheared, reflected tetrahedron in R^3 and a triangle in R^4.
        let cases: [(&[f64], usize); 2] = [
            (
                &[0.1, 0.2, 0.3, 1.3, 0.1, 0.2, 0.4, 0.9, 0.1, 0.2, 0.3, -1.1],
                3,
            ),
            (
                &[0.0, 0.0, 0.0, 0.0, 1.0, 0.5, 0.0, 0.2, 0.3, 1.1, 0.4, -0.2],
                4,
            ),
        ];
        for (points, dim) in cases {
            let k = points.len() / dim - 1;
            let mut frame = vec![0.0; k * k];
            let v0 = rest_element(points, dim, &mut frame, &mut MaterialScratch::new())
                .expect("regular rest");
            let mut q = vec![0.0; dim * k];
            for a in 0..dim {
                for j in 0..k {
                    for i in 0..k {
                        q[a * k + j] += (points[(i + 1) * dim + a] - points[a]) * frame[i * k + j];
                    }
                }
            }
            for i in 0..k {
                for j in 0..k {
                    let qq: f64 = (0..dim).map(|a| q[a * k + i] * q[a * k + j]).sum();
                    let id = if i == j { 1.0 } else { 0.0 };
                    approx::assert_abs_diff_eq!(qq, id, epsilon = 1e-14);
                    if i > j {
                        assert_eq!(frame[i * k + j], 0.0, "R is upper triangular");
                    }
                }
            }
            let mut s = crate::geometry::Scratch::new();
            let mut grad = vec![0.0; points.len()];
            let squared = crate::geometry::simplex_squared_measure(points, dim, &mut grad, &mut s);
            approx::assert_relative_eq!(v0 * v0, squared, max_relative = 1e-14);
            if k == dim {
                let mut qs = q.clone();
                approx::assert_relative_eq!(determinant(&mut qs, k), 1.0, epsilon = 1e-14);
            }
        }
    }

    #[test]
    fn degenerate_and_malformed_rest_shapes_are_typed_errors() {
        let collinear = [0.0, 0.0, 1.0, 1.0, 2.0, 2.0];
        let err = RestShapes::compile(2, &[vec![0, 1, 2]], &collinear).expect_err("collinear");
        assert!(matches!(
            err,
            MaterialError::DegenerateRest {
                element: 0,
                order: 2,
                ..
            }
        ));
        let tri = [0.0, 0.0, 1.0, 0.0, 0.0, 1.0];
        let err = RestShapes::compile(2, &[vec![0, 1, 2], vec![0, 1]], &tri).expect_err("mixed");
        assert!(matches!(err, MaterialError::MixedOrder { element: 1, .. }));
        let err = RestShapes::compile(2, &[vec![0, 1, 3]], &tri).expect_err("index");
        assert!(matches!(
            err,
            MaterialError::IndexOutOfRange { index: 3, .. }
        ));
        let err = RestShapes::compile(1, &[vec![0, 1, 2]], &[0.0, 1.0, 2.0]).expect_err("order");
        assert!(matches!(
            err,
            MaterialError::Order {
                vertices: 3,
                dim: 1,
                ..
            }
        ));
        let err = RestShapes::compile(2, &[vec![0]], &tri).expect_err("one vertex");
        assert!(matches!(err, MaterialError::Order { vertices: 1, .. }));
        let err = RestShapes::compile(2, &[], &[0.0; 3]).expect_err("length");
        assert!(matches!(
            err,
            MaterialError::PositionsLength { len: 3, dim: 2 }
        ));
        let nan = [0.0, 0.0, f64::NAN, 0.0, 0.0, 1.0];
        assert!(RestShapes::compile(2, &[vec![0, 1, 2]], &nan).is_err());
        let ok = RestShapes::compile(2, &[vec![0, 1, 2], vec![2, 1, 0]], &tri).expect("valid");
        assert_eq!((ok.order(), ok.len()), (2, 2));
        approx::assert_relative_eq!(ok.element(1).measure, 0.5, max_relative = 1e-15);
    }
}
