//! Lagged friction: a smoothed Coulomb tangent ball in R^N, conservative
//! for one frozen lag so every line-search trial sees one objective.
//!
//! ```text
//! lag (frozen at the start of the step's minimisation, an accepted state):
//!   n        unit contact normal (plane: its normal; simplex: (x − q)/|x − q|;
//!            ball pair: (x_j − x_i)/|x_j − x_i|)
//!   λ        = −b'(d_lag) ≥ 0, the barrier's normal force (force units: U is an
//!            energy and b' its derivative; no h² here — the h² of F multiplies
//!            the whole friction energy like every other term of U)
//!   μ        obstacle `friction` or `collisions.friction`;   F_max = μ λ
//!   ε        = ε_v h: slip length of one step from the slip-velocity threshold ε_v
//! slip over the step:  w = x − x^t (obstacle) or (x_j − x_j^t) − (x_i − x_i^t) (pair)
//!                      u = P w,  P = I − n nᵀ   (no tangent basis),  y = |u|
//! mollifier (IPC):  f₁(y) = 2y/ε − y²/ε²  (y < ε),  1 (y ≥ ε)        force profile, ≤ 1
//!                   f₀(y) = −y³/(3ε²) + y²/ε + ε/3  (y < ε),  y (y ≥ ε)   f₀' = f₁
//! energy  D = F_max f₀(y)                       (in F as h² D)
//! ∇_w D = F_max g(y) u,  g = f₁(y)/y = 2/ε − y/ε² (y < ε, finite at 0),  1/y (y ≥ ε)
//!         obstacle: ∇_x D = ∇_w D;  pair: ∇_j D = ∇_w D, ∇_i D = −∇_w D
//! ∇²_w D = F_max [g(y) P + (f₁'(y) − g(y)) û ûᵀ],   û = u/y
//!   eigenvalues: f₁'(y) ≥ 0 along û (2/ε − 2y/ε² sticking, 0 sliding),
//!                g(y) > 0 across û in the tangent space, 0 along n
//!   ⇒ already PSD: the projection is the identity (f₁ is increasing and concave)
//! y = 0: ∇²_w D = F_max (2/ε) P (isotropic; û is never formed)
//! ```
//! |∇D| = F_max f₁(y) ≤ μλ by construction (no clamp); the force is linear
//! through zero slip (a stiff tangential spring of stiffness 2 μλ/ε, the
//! sticking regime y < ε) and exactly μλ while sliding (y ≥ ε). f₁ and f₀
//! are continuous at y = ε with f₁'(ε⁻) = 0 = f₁'(ε⁺): the force is C¹,
//! the energy C². The products and the diagonal (pair: vertex layout as
//! radial.rs, ±):
//!
//! ```text
//! s_n = n·v,  s_u = û·v  (a ascending)
//! y_a = across (v_a − s_n n_a) + (along − across) s_u û_a
//! diagonal: across (1 − n_a²) + (along − across) û_a²
//! ```

use crate::Refusal;
use crate::barrier::BarrierLaw;
use crate::broadphase::Pair;
use crate::geometry::separation;

/// Slip regime of one evaluation (a statement about the slip alone).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FrictionRegime {
    /// y < ε: the smoothed static branch (force linear in slip).
    Sticking,
    /// y ≥ ε: force μλ opposing the slip.
    Sliding,
}

/// The (already PSD) tangent curvature F_max [g P + (f₁' − g) û ûᵀ].
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct TangentCurvature {
    /// Eigenvalue along the slip direction û: F_max f₁'(y).
    pub along: f64,
    /// Eigenvalue across û in the tangent space: F_max g(y).
    pub across: f64,
}

/// One friction term evaluated at a trial point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FrictionTerm {
    /// D = F_max f₀(y).
    pub energy: f64,
    /// y = |u|, the tangential slip over the step.
    pub slip: f64,
    /// Sticking or sliding.
    pub regime: FrictionRegime,
    /// The curvature (PSD).
    pub curvature: TangentCurvature,
}

/// (f₀(y), f₁(y), f₁'(y)) of the mollifier with slip length ε > 0.
pub fn mollifier(y: f64, epsilon: f64) -> (f64, f64, f64) {
    if y < epsilon {
        let q = y / epsilon;
        let f0 = -y * q * q / 3.0 + y * q + epsilon / 3.0;
        let f1 = 2.0 * q - q * q;
        let f1_prime = (2.0 - 2.0 * q) / epsilon;
        (f0, f1, f1_prime)
    } else {
        (y, 1.0, 0.0)
    }
}

/// λ = −b'(d) ≥ 0: the normal force a lag freezes for a barrier term at
/// distance d (0 outside (0, d^)).
pub fn normal_force(law: &BarrierLaw, distance: f64) -> f64 {
    if distance > 0.0 && distance < law.activation_distance {
        -law.evaluate(distance).1
    } else {
        0.0
    }
}

/// The term for slip vector w (length N) in the tangent space of `normal`.
/// Writes ∇_w D into `gradient` and û (0 when y = 0) into `slip_direction`.
fn tangent_term(
    normal: &[f64],
    force_limit: f64,
    slip_length: f64,
    w: &[f64],
    gradient: &mut [f64],
    slip_direction: &mut [f64],
) -> FrictionTerm {
    let dim = normal.len();
    let mut s = 0.0;
    for a in 0..dim {
        s += normal[a] * w[a];
    }
    let mut y_squared = 0.0;
    for a in 0..dim {
        let u = w[a] - s * normal[a];
        slip_direction[a] = u;
        y_squared += u * u;
    }
    let y = y_squared.sqrt();
    let (f0, _, f1_prime) = mollifier(y, slip_length);
    let (regime, g) = if y < slip_length {
        (
            FrictionRegime::Sticking,
            (2.0 - y / slip_length) / slip_length,
        )
    } else {
        (FrictionRegime::Sliding, 1.0 / y)
    };
    let scale = force_limit * g;
    for a in 0..dim {
        gradient[a] = scale * slip_direction[a];
    }
    let inverse = if y > 0.0 { 1.0 / y } else { 0.0 };
    for a in 0..dim {
        slip_direction[a] *= inverse;
    }
    FrictionTerm {
        energy: force_limit * f0,
        slip: y,
        regime,
        curvature: TangentCurvature {
            along: force_limit * f1_prime,
            across: scale,
        },
    }
}

/// Friction of a particle against a static obstacle: lag `normal`,
/// F_max = `force_limit` (μλ), ε = `slip_length`, at `x` with step start
/// `start`. ∇_x D into `gradient`, û into `slip_direction` (both length N).
pub fn obstacle_friction(
    normal: &[f64],
    force_limit: f64,
    slip_length: f64,
    x: &[f64],
    start: &[f64],
    gradient: &mut [f64],
    slip_direction: &mut [f64],
) -> FrictionTerm {
    let mut w = [0.0f64; crate::MAX_DIM];
    let dim = x.len();
    for a in 0..dim {
        w[a] = x[a] - start[a];
    }
    tangent_term(
        normal,
        force_limit,
        slip_length,
        &w[..dim],
        gradient,
        slip_direction,
    )
}

/// Friction of the ball pair `points` = (x_i, x_j) with step starts
/// `starts` (2 × N each): ∇D into `gradient` (2 × N: −∇_w D, +∇_w D), û
/// into `slip_direction` (N). `normal` points from i to j.
pub fn pair_friction(
    normal: &[f64],
    force_limit: f64,
    slip_length: f64,
    points: &[f64],
    starts: &[f64],
    gradient: &mut [f64],
    slip_direction: &mut [f64],
) -> FrictionTerm {
    let dim = normal.len();
    let mut w = [0.0f64; crate::MAX_DIM];
    for a in 0..dim {
        w[a] = (points[dim + a] - starts[dim + a]) - (points[a] - starts[a]);
    }
    let (gi, gj) = gradient.split_at_mut(dim);
    let term = tangent_term(
        normal,
        force_limit,
        slip_length,
        &w[..dim],
        &mut gj[..dim],
        slip_direction,
    );
    for a in 0..dim {
        gi[a] = -gj[a];
    }
    term
}

impl TangentCurvature {
    /// y = K v for a slip-space vector v (length N) into `out`.
    pub fn apply_slip(&self, normal: &[f64], slip_direction: &[f64], v: &[f64], out: &mut [f64]) {
        let dim = normal.len();
        let mut s_n = 0.0;
        let mut s_u = 0.0;
        for a in 0..dim {
            s_n += normal[a] * v[a];
            s_u += slip_direction[a] * v[a];
        }
        let extra = (self.along - self.across) * s_u;
        for a in 0..dim {
            out[a] = self.across * (v[a] - s_n * normal[a]) + extra * slip_direction[a];
        }
    }

    /// Pair product: out = [[K, −K], [−K, K]] p for p = (p_i, p_j).
    pub fn apply_pair(&self, normal: &[f64], slip_direction: &[f64], p: &[f64], out: &mut [f64]) {
        let dim = normal.len();
        let mut v = [0.0f64; crate::MAX_DIM];
        for a in 0..dim {
            v[a] = p[dim + a] - p[a];
        }
        let (oi, oj) = out.split_at_mut(dim);
        self.apply_slip(normal, slip_direction, &v[..dim], &mut oj[..dim]);
        for a in 0..dim {
            oi[a] = -oj[a];
        }
    }

    /// Diagonal of K (length N) into `out`.
    pub fn diagonal(&self, normal: &[f64], slip_direction: &[f64], out: &mut [f64]) {
        for a in 0..normal.len() {
            out[a] = self.across * (1.0 - normal[a] * normal[a])
                + (self.along - self.across) * slip_direction[a] * slip_direction[a];
        }
    }

    /// The dense N × N K (row-major) into `out`.
    pub fn block(&self, normal: &[f64], slip_direction: &[f64], out: &mut [f64]) {
        let dim = normal.len();
        for a in 0..dim {
            for b in 0..dim {
                let identity = if a == b { 1.0 } else { 0.0 };
                out[a * dim + b] = self.across * (identity - normal[a] * normal[b])
                    + (self.along - self.across) * slip_direction[a] * slip_direction[b];
            }
        }
    }
}

/// A frozen friction lag of one ball pair (at x^t).
#[derive(Debug, Clone, PartialEq)]
pub struct PairLag {
    /// The pair (i < j).
    pub pair: Pair,
    /// n = (x_j − x_i)/|x_j − x_i| at x^t.
    pub normal: Vec<f64>,
    /// F_max = μ λ.
    pub force_limit: f64,
}

/// The lags of the ball pairs `pairs` at x^t = `x` (docs/implicit.md §7
/// step 2): every pair with 0 < d < d^ when μ = `friction` > 0, in pair
/// order; the first pair at d ≤ 0 is `Refusal::OverlappingStart`.
pub fn pair_lags(
    law: &BarrierLaw,
    friction: f64,
    x: &[f64],
    radius: &[f64],
    dim: usize,
    pairs: &[Pair],
) -> Result<Vec<PairLag>, Refusal> {
    let mut lags = Vec::new();
    let mut normal = vec![0.0; dim];
    for &[i, j] in pairs {
        let (i, j) = (i as usize, j as usize);
        let length = separation(x, i, j, dim, &mut normal);
        let d = length - radius[i] - radius[j];
        if d.is_nan() || d <= 0.0 {
            return Err(Refusal::OverlappingStart {
                first: i,
                second: j,
                distance: d,
            });
        }
        let force = normal_force(law, d);
        if friction > 0.0 && force > 0.0 {
            lags.push(PairLag {
                pair: [i as u32, j as u32],
                normal: normal.iter().map(|c| c / length).collect(),
                force_limit: friction * force,
            });
        }
    }
    Ok(lags)
}
