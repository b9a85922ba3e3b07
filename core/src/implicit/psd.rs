//! Projection of a symmetric block onto the PSD cone: the nearest PSD
//! matrix in the Frobenius norm.
//!
//! ```text
//! A = V Λ Vᵀ                    geometry::symmetric_eigen (cyclic Jacobi, fixed sweep order)
//! A⁺ = V max(Λ, 0) Vᵀ
//! reassembly, fixed order:  for i ascending, for j = i.. ascending:
//!   s = 0;  for l ascending with λ_l > 0:  s += (λ_l V[i][l]) V[j][l]
//!   A⁺[i][j] = A⁺[j][i] = s                                  (exactly symmetric)
//! no λ_l < 0:  A is returned unchanged, bit for bit (no reassembly rounding)
//! ```
//! A block with a non-finite entry is left unchanged and reported
//! (`finite: false`); the caller refuses it. The Jacobi iteration is
//! reported too (sweeps, off-diagonal residual, convergence within
//! `MAX_SWEEPS`), as is every clipped eigenvalue's count and the smallest
//! raw eigenvalue.

use crate::geometry::{SymmetricEigen, symmetric_eigen};
use crate::kinds::ProjectionReal;

/// Buffers of the projection, reused between blocks (in precision `R`:
/// f64 on the golden path, f32 in the f32 reference).
#[derive(Debug, Clone)]
pub struct PsdScratch<R = f64> {
    work: Vec<R>,
    values: Vec<R>,
    vectors: Vec<R>,
}

impl<R> Default for PsdScratch<R> {
    fn default() -> Self {
        PsdScratch {
            work: Vec::new(),
            values: Vec::new(),
            vectors: Vec::new(),
        }
    }
}

impl<R> PsdScratch<R> {
    /// Empty scratch; buffers grow on first use.
    pub fn new() -> Self {
        PsdScratch::default()
    }
}

/// What one projection did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PsdProjection {
    /// Every entry of the input was finite (otherwise nothing was done).
    pub finite: bool,
    /// Eigenvalues clamped to 0.
    pub clipped: usize,
    /// The smallest raw eigenvalue (+∞ for an empty block, NaN if not finite).
    pub smallest: f64,
    /// The eigensolver's evidence (zero sweeps when not run).
    pub eigen: SymmetricEigen,
}

/// Projects the symmetric row-major n × n `block` onto the PSD cone in
/// place.
pub fn project_psd<R: ProjectionReal>(
    block: &mut [R],
    n: usize,
    scratch: &mut PsdScratch<R>,
) -> PsdProjection {
    let unrun = SymmetricEigen {
        sweeps: 0,
        off_diagonal: 0.0,
        converged: true,
    };
    let zero = R::constant(0.0);
    if block[..n * n].iter().any(|v| !v.finite()) {
        return PsdProjection {
            finite: false,
            clipped: 0,
            smallest: f64::NAN,
            eigen: unrun,
        };
    }
    let PsdScratch {
        work,
        values,
        vectors,
    } = scratch;
    work.clear();
    work.extend_from_slice(&block[..n * n]);
    values.resize(n, zero);
    vectors.resize(n * n, zero);
    let eigen = symmetric_eigen(work, n, values, vectors);
    let mut clipped = 0;
    let mut smallest = f64::INFINITY;
    for &l in values.iter() {
        smallest = smallest.min(l.to_f64());
        if l < zero {
            clipped += 1;
        }
    }
    if clipped > 0 {
        for i in 0..n {
            for j in i..n {
                let mut s = zero;
                for l in 0..n {
                    if values[l] > zero {
                        s += (values[l] * vectors[i * n + l]) * vectors[j * n + l];
                    }
                }
                block[i * n + j] = s;
                block[j * n + i] = s;
            }
        }
    }
    PsdProjection {
        finite: true,
        clipped,
        smallest,
        eigen,
    }
}
