//! Curvature of a potential of one edge length, projected to PSD in closed
//! form. Distance and tether springs and the ball–ball barrier are all of
//! this kind: φ(ℓ) with ℓ = |e|, e = x_1 − x_0.
//!
//! ```text
//! n      = e / ℓ                                   (unit; ∇_1 ℓ = n, ∇_0 ℓ = −n)
//! ∇_e φ  = φ'(ℓ) n
//! ∇²_e φ = φ''(ℓ) n nᵀ + (φ'(ℓ) / ℓ) (I − n nᵀ)    (∇²_e ℓ = (I − n nᵀ)/ℓ)
//!        = K: eigenvalue φ'' along n, φ'/ℓ (N − 1 times) across n
//! vertex block over (x_0, x_1):   [[K, −K], [−K, K]] = [[1, −1], [−1, 1]] ⊗ K
//!        eigenvalues 2·eig(K) and 0 (N times: translations)
//! PSD projection (exact, no eigensolver):
//!   K⁺ = max(φ'', 0) n nᵀ + max(φ'/ℓ, 0) (I − n nᵀ),   block⁺ = [[1, −1], [−1, 1]] ⊗ K⁺
//! ℓ = 0: no direction exists (∇ℓ = 0, the geometry convention): K⁺ = 0
//! ```
//! The projection of [[1, −1], [−1, 1]] ⊗ K is [[1, −1], [−1, 1]] ⊗ K⁺
//! because the Kronecker factors share eigenvectors: clamping eig(K)
//! clamps every nonzero eigenvalue of the block, and the translations stay
//! at 0. Only K⁺'s two scalars and n are stored; products are
//!
//! ```text
//! v = p_1 − p_0,  s = n·v  (a ascending),
//! y_a = along·s·n_a + across·(v_a − s·n_a),   out_0 = −y, out_1 = +y
//! diagonal of K⁺:  along·n_a² + across·(1 − n_a²)
//! ```

/// K⁺ of one edge: its eigenvalues along and across the unit normal n
/// (which the caller keeps, e.g. as ∇_1 of the distance).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct RadialCurvature {
    /// Eigenvalue along n.
    pub along: f64,
    /// Eigenvalue across n (multiplicity N − 1).
    pub across: f64,
}

impl RadialCurvature {
    /// The exact (unprojected) K of φ with φ'(ℓ) = `first`, φ''(ℓ) =
    /// `second`, at edge length `length`; zero when `length` is 0.
    pub fn exact(first: f64, second: f64, length: f64) -> RadialCurvature {
        if length > 0.0 {
            RadialCurvature {
                along: second,
                across: first / length,
            }
        } else {
            RadialCurvature::default()
        }
    }

    /// K⁺: both eigenvalues clamped at 0.
    pub fn projected(self) -> RadialCurvature {
        RadialCurvature {
            along: self.along.max(0.0),
            across: self.across.max(0.0),
        }
    }

    /// y = K v for an edge-space vector v (length N) into `out`.
    pub fn apply_edge(&self, normal: &[f64], v: &[f64], out: &mut [f64]) {
        let dim = normal.len();
        let mut s = 0.0;
        for a in 0..dim {
            s += normal[a] * v[a];
        }
        for a in 0..dim {
            let radial = s * normal[a];
            out[a] = self.along * radial + self.across * (v[a] - radial);
        }
    }

    /// out = block · p for the gathered pair vector p = (p_0, p_1), both
    /// of length N; `out` has the same layout and is overwritten.
    pub fn apply(&self, normal: &[f64], p: &[f64], out: &mut [f64]) {
        let dim = normal.len();
        let mut s = 0.0;
        for a in 0..dim {
            s += normal[a] * (p[dim + a] - p[a]);
        }
        for a in 0..dim {
            let v = p[dim + a] - p[a];
            let radial = s * normal[a];
            let y = self.along * radial + self.across * (v - radial);
            out[a] = -y;
            out[dim + a] = y;
        }
    }

    /// Diagonal of K into `out` (length N); the block's diagonal is this
    /// for both vertices.
    pub fn diagonal(&self, normal: &[f64], out: &mut [f64]) {
        for a in 0..normal.len() {
            let nn = normal[a] * normal[a];
            out[a] = self.along * nn + self.across * (1.0 - nn);
        }
    }

    /// The dense 2N × 2N vertex block [[K, −K], [−K, K]] (row-major).
    pub fn block(&self, normal: &[f64], out: &mut [f64]) {
        let dim = normal.len();
        let size = 2 * dim;
        for a in 0..dim {
            for b in 0..dim {
                let identity = if a == b { 1.0 } else { 0.0 };
                let nn = normal[a] * normal[b];
                let k = self.along * nn + self.across * (identity - nn);
                out[a * size + b] = k;
                out[(dim + a) * size + dim + b] = k;
                out[a * size + dim + b] = -k;
                out[(dim + a) * size + b] = -k;
            }
        }
    }
}
