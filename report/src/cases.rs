//! Reference scenes with known answers.
//!
//! ```text
//! closed forms (one particle; the answer is the exact solution of the ODE,
//! not of the discretisation, so the error is the method's error):
//!   pendulum    2D, L = 1 m, θ0 = 0.05 rad, rigid link to a fixed pivot
//!               T* = 2π √(L/g) / AGM(1, cos(θ0/2))        (exact; small-angle
//!               limit 2π √(L/g), which is off by θ0²/16 ≈ 1.6e-4 here)
//!               error |T − T*| / T*, T from zero crossings of the swing
//!               coordinate (cubic interpolation through 4 frames)
//!   free_fall   3D, v0 = (1, 5, 0.5) m/s, 1 s:  x* = x0 + v0 t + ½ g t²
//!   incline     3D, θ = 30°, μ = 0.3 < tan θ, from rest, 1 s:
//!               x* = ½ g (sin θ − μ cos θ) t² · (down-slope unit vector)
//!   damping     3D, v0 = (2, 0, 0) m/s, rate r = 1.5 /s, no gravity, 2 s:
//!               x* = x0 + v0 (1 − e^(−r t)) / r
//!   error       |x − x*| / |x* − x0|  (relative position error)
//!   stretch     2D Neo-Hookean bar (scenes::stretched_bar: 20 × 2 Kuhn cells,
//!               E = 100 Pa, ν = 0.3) under nominal traction P = 0.1 E,
//!               settling 5 s under damping; s* the closed-form uniaxial
//!               stretch (core::material::uniaxial_stretch_under_stress)
//!               error |ε − ε*| / ε*, ε = s − 1 the axial strain between
//!               the sections at 1/4 and 3/4 of the bar
//!
//! converged references (many particles; no closed form):
//!   cloth       scenes::hanging_cloth(n) with link compliance 1e-5 m/N
//!               (stretch under its own weight ~1e-4 m), 0.25 s. The rigid
//!               benchmark cloth (compliance 0, both shear diagonals) is an
//!               over-constrained plate whose flat start is a singular
//!               configuration: it folds along grid lines in a direction
//!               that rounding picks, so its trajectories have no converged
//!               limit (references at 8× and 16× the substeps disagree at
//!               the 1e-2 level; the report measures and prints this)
//!   tesseract   scenes::tesseract() (soft 4-cube dropped on a plane), 0.5 s
//!   chain2d     scenes::chain2d() (rope bridge), 1 s
//!   reference   cpu-f64 at 16 × the finest swept substeps and the most
//!               swept iterations; its own error is estimated by the same run
//!               at 8 × (|ref16 − ref8|: for a first-order method this equals
//!               ref16's distance to the limit)
//!   error       max_i |x_i − x_i^ref| / extent   (extent: Scene::extent)
//! ```
//! Energy drift, (E_end − E_0) / E_scale with E = Σ m (½|v|² − s g·x), is
//! reported for the conservative scenes (pendulum, free fall, hanging
//! cloth), where the exact dynamics keep E constant. E_scale is the swing
//! energy m g L (1 − cos θ0) for the pendulum, and max(KE_0, Σ m |g| ·
//! extent) otherwise.

use hyperpbd::core::material::{Law, Material, uniaxial_stretch_under_stress};
use hyperpbd::{ConstraintFamily, ConstraintKind, Particle, Scene, SceneBuilder, State};
use serde::Serialize;

const G: f64 = 9.81;
const PENDULUM_LENGTH: f64 = 1.0;
const PENDULUM_THETA0: f64 = 0.05;
const FREE_FALL_V0: [f64; 3] = [1.0, 5.0, 0.5];
const INCLINE_THETA_DEG: f64 = 30.0;
const INCLINE_MU: f64 = 0.3;
const DAMPING_V0: f64 = 2.0;
const DAMPING_RATE: f64 = 1.5;
/// Nominal traction of the stretch case: 0.1 E.
const STRETCH_TRACTION: f64 = 0.1 * hyperpbd::scenes::BAR_YOUNGS;
/// Link compliance of the sweep's cloth (m/N).
pub const CLOTH_COMPLIANCE: f64 = 1e-5;

/// A reference scene.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum CaseId {
    /// Rigid pendulum period.
    Pendulum,
    /// Ballistic flight.
    FreeFall,
    /// Sliding down a plane with Coulomb friction.
    Incline,
    /// Exponential velocity decay.
    Damping,
    /// Hanging cloth (converged reference).
    Cloth,
    /// Soft tesseract on a plane (converged reference).
    Tesseract,
    /// Rope bridge (converged reference).
    Chain2d,
    /// Uniaxial stretch of a Neo-Hookean bar (closed form).
    Stretch,
}

/// Every case, in report order.
pub const ALL: [CaseId; 8] = [
    CaseId::Pendulum,
    CaseId::FreeFall,
    CaseId::Incline,
    CaseId::Damping,
    CaseId::Cloth,
    CaseId::Tesseract,
    CaseId::Chain2d,
    CaseId::Stretch,
];

/// Where the right answer comes from.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub enum Answer {
    /// A closed form (the formula, as printed).
    ClosedForm(&'static str),
    /// A converged cpu-f64 run.
    Converged,
}

/// What a run left behind for the error measures.
#[derive(Debug, Clone)]
pub struct Observed {
    /// One state per frame, the initial one first (only for cases that
    /// need the trajectory; otherwise empty).
    pub trajectory: Vec<State>,
    /// The state after the last frame.
    pub final_state: State,
}

impl CaseId {
    /// Short name used in files and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            CaseId::Pendulum => "pendulum",
            CaseId::FreeFall => "free_fall",
            CaseId::Incline => "incline",
            CaseId::Damping => "damping",
            CaseId::Cloth => "cloth",
            CaseId::Tesseract => "tesseract",
            CaseId::Chain2d => "chain2d",
            CaseId::Stretch => "stretch",
        }
    }

    /// Parses [`CaseId::name`].
    pub fn parse(name: &str) -> Option<CaseId> {
        ALL.into_iter().find(|c| c.name() == name)
    }

    /// One-line description with the parameters.
    pub fn title(self, cloth_n: usize) -> String {
        match self {
            CaseId::Pendulum => "pendulum period (2D, L = 1 m, θ0 = 0.05 rad, 3 periods)".into(),
            CaseId::FreeFall => "free fall (3D, v0 = (1, 5, 0.5) m/s, 1 s)".into(),
            CaseId::Incline => "incline slide (3D, θ = 30°, μ = 0.3, 1 s)".into(),
            CaseId::Damping => "damping decay (3D, v0 = 2 m/s, rate 1.5/s, 2 s)".into(),
            CaseId::Cloth => format!(
                "hanging cloth {cloth_n}×{cloth_n} (3D, links α = {CLOTH_COMPLIANCE:e} m/N, 0.25 s)"
            ),
            CaseId::Tesseract => "soft tesseract on a plane (4D, 81 nodes, 0.5 s)".into(),
            CaseId::Chain2d => "rope bridge (2D, 21 particles, 1 s)".into(),
            CaseId::Stretch => {
                "uniaxial stretch (2D Neo-Hookean bar, 20 × 2 cells, P = 0.1 E, 5 s)".into()
            }
        }
    }

    /// The error measure, in words.
    pub fn metric(self) -> &'static str {
        match self {
            CaseId::Pendulum => "relative period error |T − T*| / T*",
            CaseId::FreeFall | CaseId::Incline | CaseId::Damping => {
                "relative position error |x − x*| / |x* − x0|"
            }
            CaseId::Cloth | CaseId::Tesseract | CaseId::Chain2d => {
                "max position error vs reference / extent"
            }
            CaseId::Stretch => "relative axial strain error |ε − ε*| / ε*",
        }
    }

    /// Where the answer comes from.
    pub fn answer(self) -> Answer {
        match self {
            CaseId::Pendulum => Answer::ClosedForm("T* = 2π√(L/g) / AGM(1, cos(θ0/2))"),
            CaseId::FreeFall => Answer::ClosedForm("x* = x0 + v0 t + ½ g t²"),
            CaseId::Incline => Answer::ClosedForm("x* = ½ g (sin θ − μ cos θ) t² · down-slope"),
            CaseId::Damping => Answer::ClosedForm("x* = x0 + v0 (1 − e^(−r t)) / r"),
            CaseId::Stretch => Answer::ClosedForm("s* = uniaxial_stretch_under_stress(NH, 2D, P)"),
            CaseId::Cloth | CaseId::Tesseract | CaseId::Chain2d => Answer::Converged,
        }
    }

    /// True when the iteration count changes the result (several coupled
    /// constraints); single-particle cases are swept over substeps only.
    pub fn uses_iterations(self) -> bool {
        matches!(
            self,
            CaseId::Cloth | CaseId::Tesseract | CaseId::Chain2d | CaseId::Stretch
        )
    }

    /// True when the exact dynamics conserve energy (no friction, damping
    /// or contact), so energy drift is an error.
    pub fn conservative(self) -> bool {
        matches!(self, CaseId::Pendulum | CaseId::FreeFall | CaseId::Cloth)
    }

    /// True when the error needs every frame (the pendulum's crossings).
    pub fn needs_trajectory(self) -> bool {
        self == CaseId::Pendulum
    }

    /// Frames (steps of 1/60 s) simulated.
    pub fn frames(self) -> u64 {
        match self {
            // Three exact periods (≈ 6.02 s) plus a frame for the last crossing.
            CaseId::Pendulum => (3.0 * pendulum_period() * 60.0).ceil() as u64 + 2,
            CaseId::FreeFall | CaseId::Incline | CaseId::Chain2d => 60,
            CaseId::Damping => 120,
            CaseId::Cloth => 15,
            CaseId::Tesseract => 30,
            CaseId::Stretch => 300,
        }
    }

    /// The scene at `substeps` and `iterations` (`cloth_n` sizes the cloth).
    pub fn scene(self, substeps: u32, iterations: u32, cloth_n: usize) -> Scene {
        let mut scene = match self {
            CaseId::Pendulum => {
                let mut b = SceneBuilder::new(2).gravity_along(1, G);
                b.particle(Particle::fixed(vec![0.0, 0.0]));
                b.particle(Particle::new(
                    vec![
                        PENDULUM_LENGTH * PENDULUM_THETA0.sin(),
                        -PENDULUM_LENGTH * PENDULUM_THETA0.cos(),
                    ],
                    1.0,
                ));
                b.family(ConstraintFamily::new(
                    ConstraintKind::Distance,
                    0.0,
                    vec![vec![0, 1]],
                ));
                b.build()
            }
            CaseId::FreeFall => {
                let mut b = SceneBuilder::new(3).gravity_along(1, G);
                b.particle(Particle::new(vec![0.0; 3], 1.0).with_velocity(FREE_FALL_V0.to_vec()));
                b.build()
            }
            CaseId::Incline => {
                let theta = INCLINE_THETA_DEG.to_radians();
                let mut b = SceneBuilder::new(3).gravity_along(1, G);
                b.hyperplane(vec![theta.sin(), theta.cos(), 0.0], 0.0, INCLINE_MU);
                b.particle(Particle::new(vec![0.0; 3], 1.0));
                b.build()
            }
            CaseId::Damping => {
                let mut b = SceneBuilder::new(3).damping(DAMPING_RATE);
                b.particle(
                    Particle::new(vec![0.0; 3], 1.0).with_velocity(vec![DAMPING_V0, 0.0, 0.0]),
                );
                b.build()
            }
            CaseId::Cloth => {
                let mut scene = hyperpbd::scenes::hanging_cloth(cloth_n);
                for family in &mut scene.constraints {
                    family.compliance = CLOTH_COMPLIANCE;
                }
                Ok(scene)
            }
            CaseId::Tesseract => Ok(hyperpbd::scenes::tesseract()),
            CaseId::Chain2d => Ok(hyperpbd::scenes::chain2d()),
            CaseId::Stretch => Ok(hyperpbd::scenes::stretched_bar(
                Law::NeoHookean,
                2,
                STRETCH_TRACTION,
                substeps,
                iterations,
            )),
        }
        .unwrap_or_else(|e| unreachable!("reference scenes are valid: {e}"));
        scene.dt = 1.0 / 60.0;
        scene.substeps = substeps;
        scene.iterations = iterations;
        scene
    }

    /// The rigid variant whose references are compared for contrast
    /// (the cloth only: `scenes::hanging_cloth` as shipped).
    pub fn rigid_variant(self, substeps: u32, iterations: u32, cloth_n: usize) -> Option<Scene> {
        (self == CaseId::Cloth).then(|| {
            let mut scene = hyperpbd::scenes::hanging_cloth(cloth_n);
            scene.substeps = substeps;
            scene.iterations = iterations;
            scene
        })
    }

    /// The closed-form final position of particle `index` after `t`, for
    /// the single-particle cases.
    fn exact_position(self, t: f64) -> Option<Vec<f64>> {
        match self {
            CaseId::FreeFall => Some(
                FREE_FALL_V0
                    .iter()
                    .enumerate()
                    .map(|(a, v)| v * t - if a == 1 { 0.5 * G * t * t } else { 0.0 })
                    .collect(),
            ),
            CaseId::Incline => {
                let theta = INCLINE_THETA_DEG.to_radians();
                let s = 0.5 * G * (theta.sin() - INCLINE_MU * theta.cos()) * t * t;
                Some(vec![s * theta.cos(), -s * theta.sin(), 0.0])
            }
            CaseId::Damping => {
                let x = DAMPING_V0 * (1.0 - (-DAMPING_RATE * t).exp()) / DAMPING_RATE;
                Some(vec![x, 0.0, 0.0])
            }
            _ => None,
        }
    }

    /// The error of a run against the closed form (`None` for converged
    /// cases). `Err` says why it could not be measured (e.g. a pendulum
    /// that never swung through the bottom).
    pub fn closed_form_error(
        self,
        observed: &Observed,
        dt: f64,
        frames: u64,
    ) -> Option<Result<f64, String>> {
        let t = dt * frames as f64;
        match self {
            CaseId::Pendulum => Some(pendulum_error(&observed.trajectory, dt)),
            CaseId::FreeFall | CaseId::Incline | CaseId::Damping => {
                let exact = self.exact_position(t)?;
                let x = observed.final_state.position(0);
                let diff = distance(x, &exact);
                let travel = exact.iter().map(|e| e * e).sum::<f64>().sqrt();
                Some(Ok(diff / travel))
            }
            CaseId::Stretch => {
                let material = match Material::new(
                    Law::NeoHookean,
                    2,
                    hyperpbd::scenes::BAR_YOUNGS,
                    hyperpbd::scenes::BAR_POISSON,
                ) {
                    Ok(m) => m,
                    Err(e) => return Some(Err(format!("no material: {e}"))),
                };
                let Some(exact) = uniaxial_stretch_under_stress(&material, 2, STRETCH_TRACTION)
                else {
                    return Some(Err("no closed-form stretch for this traction".into()));
                };
                let exact = exact.stretch - 1.0;
                let (axial, _) = hyperpbd::scenes::bar_strains(2, &observed.final_state);
                Some(Ok(((axial - exact) / exact).abs()))
            }
            _ => None,
        }
    }

    /// The energy scale drift is measured against.
    pub fn energy_scale(self, scene: &Scene, initial: &State) -> f64 {
        if self == CaseId::Pendulum {
            return G * PENDULUM_LENGTH * (1.0 - PENDULUM_THETA0.cos());
        }
        let g = scene
            .gravity
            .as_ref()
            .map_or(0.0, |g| g.iter().map(|x| x * x).sum::<f64>().sqrt());
        let mass: f64 = dynamic(scene).map(|(_, m, _)| m).sum();
        let kinetic = energy(
            scene,
            &State {
                positions: vec![0.0; initial.positions.len()],
                ..initial.clone()
            },
        );
        kinetic.max(mass * g * scene.extent())
    }
}

/// Dynamic particles: (index, mass, gravity scale); the mass authored or
/// lumped from a material family's density.
fn dynamic(scene: &Scene) -> impl Iterator<Item = (usize, f64, f64)> + '_ {
    let masses = hyperpbd::particle_masses(scene).unwrap_or_default();
    scene
        .particles
        .iter()
        .enumerate()
        .filter(|(_, p)| !p.fixed)
        .map(move |(i, p)| (i, masses.get(i).copied().unwrap_or(0.0), p.gravity_scale))
}

/// E = Σ m (½|v|² − s g·x) over dynamic particles.
pub fn energy(scene: &Scene, state: &State) -> f64 {
    let zero = vec![0.0; scene.dim];
    let g = scene.gravity.as_ref().unwrap_or(&zero);
    dynamic(scene)
        .map(|(i, m, s)| {
            let v2: f64 = state.velocity(i).iter().map(|v| v * v).sum();
            let gx: f64 = state.position(i).iter().zip(g).map(|(x, g)| x * g).sum();
            m * (0.5 * v2 - s * gx)
        })
        .sum()
}

/// |a − b|.
pub fn distance(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y) * (x - y))
        .sum::<f64>()
        .sqrt()
}

/// max_i |x_i − y_i| over particles, divided by `extent`.
pub fn relative_position_error(a: &State, b: &State, extent: f64) -> f64 {
    (0..a.len())
        .map(|i| distance(a.position(i), b.position(i)))
        .fold(0.0, f64::max)
        / extent
}

/// Arithmetic–geometric mean.
fn agm(mut a: f64, mut b: f64) -> f64 {
    for _ in 0..64 {
        let (next_a, next_b) = (0.5 * (a + b), (a * b).sqrt());
        if next_a == a && next_b == b {
            break;
        }
        a = next_a;
        b = next_b;
    }
    a
}

/// The exact period of the reference pendulum.
pub fn pendulum_period() -> f64 {
    2.0 * std::f64::consts::PI * (PENDULUM_LENGTH / G).sqrt()
        / agm(1.0, (0.5 * PENDULUM_THETA0).cos())
}

/// Zero crossings of `y` sampled every `dt` (from t = 0), each located by
/// the cubic through the four nearest samples (linear at the ends) and
/// bisection.
pub fn zero_crossings(y: &[f64], dt: f64) -> Vec<f64> {
    let mut out = Vec::new();
    for k in 0..y.len().saturating_sub(1) {
        let (a, b) = (y[k], y[k + 1]);
        if !(a.is_finite() && b.is_finite()) || a == 0.0 || a.signum() == b.signum() && b != 0.0 {
            continue;
        }
        let cubic = k >= 1 && k + 2 < y.len();
        // Lagrange basis on nodes −1, 0, 1, 2 (cubic) or 0, 1 (linear).
        let p = |s: f64| -> f64 {
            if cubic {
                let (ym, y0, y1, y2) = (y[k - 1], y[k], y[k + 1], y[k + 2]);
                ym * (-s * (s - 1.0) * (s - 2.0) / 6.0)
                    + y0 * ((s + 1.0) * (s - 1.0) * (s - 2.0) / 2.0)
                    + y1 * (-(s + 1.0) * s * (s - 2.0) / 2.0)
                    + y2 * ((s + 1.0) * s * (s - 1.0) / 6.0)
            } else {
                a + (b - a) * s
            }
        };
        let (mut lo, mut hi) = (0.0, 1.0);
        let sign_lo = p(lo).signum();
        for _ in 0..80 {
            let mid = 0.5 * (lo + hi);
            if p(mid).signum() == sign_lo {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        out.push((k as f64 + 0.5 * (lo + hi)) * dt);
    }
    out
}

/// Relative period error of a pendulum trajectory (swing coordinate: x of
/// particle 1).
fn pendulum_error(trajectory: &[State], dt: f64) -> Result<f64, String> {
    let x: Vec<f64> = trajectory.iter().map(|s| s.position(1)[0]).collect();
    let crossings = zero_crossings(&x, dt);
    if crossings.len() < 3 {
        return Err(format!(
            "only {} zero crossings in {} frames: no full period",
            crossings.len(),
            trajectory.len().saturating_sub(1)
        ));
    }
    let half_periods = (crossings.len() - 1) as f64;
    let period = 2.0 * (crossings[crossings.len() - 1] - crossings[0]) / half_periods;
    let exact = pendulum_period();
    Ok((period - exact).abs() / exact)
}
