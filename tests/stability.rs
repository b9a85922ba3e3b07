//! What stays stable: hard scenes on every backend (cpu-f64, gpu-f32,
//! gpu-f64), each asserting no NaN/Inf, bounded energy and a residual
//! within a stated bound — or a typed refusal where the input is
//! impossible. One test per case per backend; each prints
//!
//! ```text
//! STABLE | case | backend | result | metric = measured | bound (rationale)
//! ```
//! and the README table "What stays stable" is written from
//! `cargo test --release --test stability -- --nocapture --test-threads 1 | grep '^STABLE'`.
//!
//! # The metrics
//!
//! ```text
//! finite     every position and velocity finite after every step (asserted
//!            every step, no bound)
//! energy     ΔE = max over steps of E(t) − E(0), with
//!              E = Σ_dynamic m_i (½|v_i|² − s_i g·(x_i − x_i(0))) − f_i·(x_i − x_i(0))
//!            XPBD is dissipative (implicit Euler on the constraint forces,
//!            inelastic contacts, friction, damping): ΔE ≤ 0 up to rounding
//!            of E itself, bound ε·64·E_scale, E_scale = Σ m (|g|·L + ½ v0² + ½ v²)
//!            + |f|·L with L = max_a |x_a(0)| + |x_a − x_a(0)| per particle
//!            (positions round relative to their magnitude); a case
//!            that starts with violated constraints may release at most the
//!            energy of correcting them in one substep, ½ Σ m (C₀/h)², and
//!            says so
//! residual   max over steps of the step report's max violation of the
//!            length-unit families (distance |C| and contact max(0, −C)),
//!            in metres; each case states its bound and why
//! ```
//! ε is the backend's unit roundoff (f64 2⁻⁵², f32 2⁻²³).

mod common;

use common::gpu::adapter_or_skip;
use hyperpbd::core::builders::{BlockSpec, ChainSpec, GridSpec};
use hyperpbd::gpu::{GpuBackend, Precision, SceneOrigin};
use hyperpbd::{
    Backend, BackendError, ConstraintFamily, ConstraintKind, CpuBackend, FamilyKind, GpuError,
    Particle, Plan, Scene, SceneBuilder, SceneError, State,
};

// ---------------------------------------------------------------- backends

/// The three backends every case runs on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Kind {
    Cpu,
    GpuF32,
    GpuF64,
}

impl Kind {
    fn name(self) -> &'static str {
        match self {
            Kind::Cpu => "cpu-f64",
            Kind::GpuF32 => "gpu-f32",
            Kind::GpuF64 => "gpu-f64",
        }
    }

    /// Unit roundoff of the backend's arithmetic.
    fn epsilon(self) -> f64 {
        match self {
            Kind::GpuF32 => f64::from(f32::EPSILON),
            _ => f64::EPSILON,
        }
    }

    fn precision(self) -> Option<Precision> {
        match self {
            Kind::Cpu => None,
            Kind::GpuF32 => Some(Precision::F32),
            Kind::GpuF64 => Some(Precision::F64),
        }
    }
}

/// The backend of `kind` for `plan` and `state`: `Ok(None)` when the GPU
/// test is skipped (no adapter and GPU not required), `Err` for a typed
/// refusal of the backend.
fn load(
    test: &str,
    kind: Kind,
    plan: Plan,
    state: &State,
) -> Result<Option<Box<dyn Backend>>, BackendError> {
    match kind.precision() {
        None => Ok(Some(Box::new(CpuBackend::new(plan, state)?))),
        Some(precision) => {
            let Some((adapter, _)) = adapter_or_skip(test, precision) else {
                return Ok(None);
            };
            Ok(Some(Box::new(GpuBackend::with_adapter(
                &adapter, plan, state, precision,
            )?)))
        }
    }
}

/// One `STABLE` line.
fn report(case: &str, kind: Kind, result: &str, metric: &str, measured: f64, bound: &str) {
    println!(
        "STABLE | {case} | {} | {result} | {metric} = {measured:.3e} | {bound}",
        kind.name()
    );
}

// ---------------------------------------------------------------- the run

/// What a run measured.
#[derive(Debug, Clone)]
struct Measured {
    /// Largest E(t) − E(0) over the steps.
    energy_gain: f64,
    /// E_scale of the energy bound.
    energy_scale: f64,
    /// Largest length-unit residual over the steps.
    residual: f64,
    /// Largest residual of the other (measure) families over the steps.
    measure_residual: f64,
    /// Length-unit residual after the last step.
    final_residual: f64,
    /// The final state.
    last: State,
}

/// E(t) − E(0) and E_scale for `state` against the initial `x0`, `v0`.
fn energy(plan: &Plan, x0: &State, state: &State) -> (f64, f64) {
    let n = plan.dim;
    let g: f64 = plan.gravity.iter().map(|c| c * c).sum::<f64>().sqrt();
    let (mut now, mut start, mut scale) = (0.0, 0.0, 0.0);
    for (i, &w) in plan.inverse_mass.iter().enumerate() {
        if w == 0.0 {
            continue;
        }
        let m = 1.0 / w;
        let s = plan.gravity_scale[i];
        let (x, x_0) = (state.position(i), x0.position(i));
        let (v, v_0) = (state.velocity(i), x0.velocity(i));
        let f = &plan.force[i * n..(i + 1) * n];
        let mut potential = 0.0;
        let mut excursion: f64 = 0.0;
        let mut force = 0.0;
        for a in 0..n {
            let dx = x[a] - x_0[a];
            potential -= m * s * plan.gravity[a] * dx + f[a] * dx;
            // |x(0)| too: positions round relative to their magnitude.
            excursion = excursion.max(dx.abs() + x_0[a].abs());
            force += f[a] * f[a];
        }
        let kinetic: f64 = 0.5 * m * v.iter().map(|c| c * c).sum::<f64>();
        let kinetic0: f64 = 0.5 * m * v_0.iter().map(|c| c * c).sum::<f64>();
        now += kinetic + potential;
        start += kinetic0;
        scale += m * s.abs() * g * excursion + kinetic0 + kinetic + force.sqrt() * excursion;
    }
    (now - start, scale)
}

fn is_length_unit(kind: &FamilyKind) -> bool {
    matches!(
        kind,
        FamilyKind::Distance | FamilyKind::Tether | FamilyKind::HyperplaneContact { .. }
    )
}

/// Steps `backend` `steps` times from `initial`, asserting finiteness after
/// every step; a step error fails the test (the cases that expect one test
/// it themselves).
fn run(case: &str, backend: &mut dyn Backend, initial: &State, steps: usize) -> Measured {
    let plan = backend.plan().clone();
    let mut m = Measured {
        energy_gain: f64::NEG_INFINITY,
        energy_scale: 0.0,
        residual: 0.0,
        measure_residual: 0.0,
        final_residual: 0.0,
        last: initial.clone(),
    };
    for step in 0..steps {
        let step_report = backend
            .step()
            .unwrap_or_else(|e| panic!("{case} ({}): step {step}: {e}", backend.name()));
        let state = backend.read_state().expect("read_state");
        let bad = state
            .positions
            .iter()
            .chain(&state.velocities)
            .position(|c| !c.is_finite());
        assert!(
            bad.is_none(),
            "{case} ({}): non-finite value at flat index {bad:?} after step {step}",
            backend.name()
        );
        let (gain, scale) = energy(&plan, initial, &state);
        m.energy_gain = m.energy_gain.max(gain);
        m.energy_scale = m.energy_scale.max(scale);
        m.final_residual = 0.0;
        for (f, r) in plan.families.iter().zip(&step_report.residuals) {
            assert!(r.max_violation.is_finite(), "{case}: residual {r:?}");
            if is_length_unit(&f.kind) {
                m.residual = m.residual.max(r.max_violation);
                m.final_residual = m.final_residual.max(r.max_violation);
            } else {
                m.measure_residual = m.measure_residual.max(r.max_violation);
            }
        }
        m.last = state;
    }
    if steps == 0 {
        m.energy_gain = 0.0;
    }
    m
}

/// Asserts and reports the energy metric: ΔE ≤ ε·64·E_scale + `released`.
fn check_energy(case: &str, kind: Kind, m: &Measured, released: f64, why: &str) {
    let bound = kind.epsilon() * 64.0 * m.energy_scale + released;
    report(
        case,
        kind,
        "ok",
        "energy gain (J)",
        m.energy_gain,
        &format!("{bound:.3e} ({why})"),
    );
    assert!(
        m.energy_gain <= bound,
        "{case} ({}): energy gain {:e} J over bound {bound:e} J",
        kind.name(),
        m.energy_gain
    );
}

/// Asserts and reports a residual metric.
fn check_residual(case: &str, kind: Kind, metric: &str, measured: f64, bound: f64, why: &str) {
    report(
        case,
        kind,
        "ok",
        metric,
        measured,
        &format!("{bound:.3e} ({why})"),
    );
    assert!(
        measured <= bound,
        "{case} ({}): {metric} {measured:e} over bound {bound:e} ({why})",
        kind.name()
    );
}

/// Compiles `scene` and loads it on `kind`; `None` when the GPU test is
/// skipped.
fn start(case: &str, kind: Kind, scene: &Scene) -> Option<(Box<dyn Backend>, State)> {
    let plan = Plan::compile(scene).unwrap_or_else(|e| panic!("{case}: {e}"));
    let initial = State::from_scene(scene);
    load(case, kind, plan, &initial)
        .unwrap_or_else(|e| panic!("{case} ({}): {e}", kind.name()))
        .map(|b| (b, initial))
}

/// One test per backend for each case function `fn(Kind)`.
macro_rules! on_every_backend {
    ($($case:ident),* $(,)?) => {
        $(
            mod $case {
                #[test]
                fn cpu_f64() {
                    super::$case(super::Kind::Cpu);
                }
                #[test]
                fn gpu_f32() {
                    super::$case(super::Kind::GpuF32);
                }
                #[test]
                fn gpu_f64() {
                    super::$case(super::Kind::GpuF64);
                }
            }
        )*
    };
}

on_every_backend!(
    mass_ratio_chain,
    mass_ratio_chain_tethered,
    rigid_cloth_100_iterations,
    oriented_near_degenerate,
    oriented_inverted,
    oriented_zero_rest_refused,
    coincident_distance,
    on_hyperplane,
    far_offset_1e3,
    far_offset_1e5,
    dt_one_second,
    dt_one_microsecond,
    fast_impact_xpbd,
    eight_dimensions,
    nine_dimensions,
    empty_scene,
    one_particle,
);

// ---------------------------------------------------------------- cases

/// A 2D chain hanging from a fixed point: 10 links of 0.1 m, particles of
/// 1 kg and a 1e6 kg weight at the end (mass ratio 1:1e6), rigid links,
/// 20 substeps × 4 iterations, 2 s — links only.
///
/// XPBD's Gauss–Seidel does not hold it rigid: the weight receives only
/// m/(m + M) = 1e-6 of each correction of its link, so the chain
/// stretches until (M/m) g h² / iterations = 1.7 m is pulled back per
/// substep, and oscillates about that (3.5 m measured). Finite and
/// dissipative are asserted; the stretch is reported. The remedy, tethers
/// from the anchor (`SceneBuilder::tethers`), is `mass_ratio_chain_tethered`.
fn mass_ratio_chain(kind: Kind) {
    let case = "mass_ratio_chain";
    let mut b = SceneBuilder::new(2)
        .dt(1.0 / 60.0)
        .substeps(20)
        .iterations(4)
        .gravity_along(1, 9.81);
    let grid = b.chain(&ChainSpec {
        start: vec![0.0, 0.0],
        direction: vec![0.0, -1.0],
        count: 11,
        spacing: 0.1,
        mass: 1.0,
        compliance: 0.0,
        fix_first: true,
    });
    b.scene_mut().particles[grid.first + 10].mass = Some(1e6);
    let scene = b.build().expect("valid");
    let Some((mut backend, initial)) = start(case, kind, &scene) else {
        return;
    };
    let m = run(case, backend.as_mut(), &initial, 120);
    check_energy(
        case,
        kind,
        &m,
        0.0,
        "dissipative: starts at rest, rigid links",
    );
    let h = 1.0 / 60.0 / 20.0;
    let law = 1e6 * 9.81 * h * h / 4.0;
    report(
        case,
        kind,
        "bounded, NOT rigid",
        "max |C| (m)",
        m.residual,
        &format!(
            "not asserted: 1% of the link is met only with tethers \
             (mass_ratio_chain_tethered); Gauss–Seidel equilibrium stretch \
             (M/m) g h² / iterations = {law:.2}"
        ),
    );
}

/// `mass_ratio_chain` with tethers (long-range attachments) from the
/// fixed anchor to every particle, rest = the authored distance (= the
/// path length on the straight chain): a tether moves the weight by the
/// whole violation of its own distance to the anchor (the anchor has
/// inverse mass 0), which the links alone could only pass on at 1e-6 per
/// projection. Same steps, same iterations.
///
/// Two starts: hanging at rest (as `mass_ratio_chain`), and released
/// horizontally so the weight swings down through the bottom at ~4.4 m/s
/// (the tethers must hold a moving chain, not only a resting one).
fn mass_ratio_chain_tethered(kind: Kind) {
    tethered_chain(kind, "mass_ratio_chain_tethered (hanging)", vec![0.0, -1.0]);
    tethered_chain(kind, "mass_ratio_chain_tethered (swinging)", vec![1.0, 0.0]);
}

fn tethered_chain(kind: Kind, case: &str, direction: Vec<f64>) {
    let mut b = SceneBuilder::new(2)
        .dt(1.0 / 60.0)
        .substeps(20)
        .iterations(4)
        .gravity_along(1, 9.81);
    let grid = b.chain(&ChainSpec {
        start: vec![0.0, 0.0],
        direction,
        count: 11,
        spacing: 0.1,
        mass: 1.0,
        compliance: 0.0,
        fix_first: true,
    });
    b.scene_mut().particles[grid.first + 10].mass = Some(1e6);
    let chain: Vec<usize> = (grid.first..grid.first + 11).collect();
    b.tethers(grid.first, &chain, 0.0);
    let scene = b.build().expect("valid");
    let Some((mut backend, initial)) = start(case, kind, &scene) else {
        return;
    };
    let m = run(case, backend.as_mut(), &initial, 120);
    check_energy(
        case,
        kind,
        &m,
        0.0,
        "dissipative: starts at rest, rigid links",
    );
    check_residual(
        case,
        kind,
        "max |C| links + tethers (m)",
        m.residual,
        1e-3,
        "1% of the 0.1 m link",
    );
}

/// A 16 × 16 rigid cloth (compliance 0, edges and shear diagonals),
/// horizontal, hanging from one whole edge (a rod) and swinging down,
/// 1 substep × 100 iterations, 1 s: rigid springs that make a
/// summed-Jacobi solver diverge; Gauss–Seidel by colors must not. (Two
/// fixed corners 1 m apart would pull the rigid top edge exactly straight
/// — an infinitely stiff, singular configuration no iteration count
/// resolves; a rod is the well-posed version.)
fn rigid_cloth_100_iterations(kind: Kind) {
    let case = "rigid_cloth_100_iterations";
    let n = 16;
    let spacing = 1.0 / (n - 1) as f64;
    let mut b = SceneBuilder::new(3)
        .dt(1.0 / 60.0)
        .substeps(1)
        .iterations(100)
        .gravity_along(1, 9.81);
    let grid = b.grid(&GridSpec::cloth(n, n, spacing, 1.0));
    for i in 0..n {
        b.fix(grid.index(&[i, n - 1]));
    }
    let scene = b.build().expect("valid");
    let Some((mut backend, initial)) = start(case, kind, &scene) else {
        return;
    };
    let m = run(case, backend.as_mut(), &initial, 60);
    check_energy(
        case,
        kind,
        &m,
        0.0,
        "dissipative: starts at rest, rigid links",
    );
    check_residual(
        case,
        kind,
        "max |C| (m)",
        m.residual,
        0.01 * spacing,
        "1% of the link",
    );
}

/// The oriented volume of tetrahedron `points` (flat, 4 × 3).
fn tet_volume(points: &[f64]) -> f64 {
    let mut grad = vec![0.0; 12];
    let mut scratch = hyperpbd::geometry::Scratch::new();
    hyperpbd::geometry::oriented_measure(points, 3, &mut grad, &mut scratch)
}

/// A sliver tetrahedron just above the degeneracy floor (height 1e-9 m on
/// a 1 m base: volume ratio 1e-9 against the floor's 1e-12), rigid, with
/// its edges as rigid springs, falling onto a plane: the volume gradient
/// is nearly zero across the sliver for the base vertices, so
/// Δλ = −C / Σ w |∇C|² is large — it must not throw the particles away.
fn oriented_near_degenerate(kind: Kind) {
    let case = "oriented_near_degenerate";
    let mut b = SceneBuilder::new(3)
        .dt(1.0 / 60.0)
        .substeps(10)
        .iterations(2)
        .gravity_along(1, 9.81);
    let flat = 1e-9;
    for p in [
        [0.0, 0.5, 0.0],
        [1.0, 0.5, 0.0],
        [0.0, 0.5, 1.0],
        [0.3, 0.5 + flat, 0.3],
    ] {
        b.particle(Particle::new(p.to_vec(), 0.25).with_radius(0.01));
    }
    b.family(ConstraintFamily::new(
        ConstraintKind::OrientedMeasure,
        0.0,
        vec![vec![0, 1, 2, 3]],
    ));
    let edges = vec![
        vec![0, 1],
        vec![0, 2],
        vec![0, 3],
        vec![1, 2],
        vec![1, 3],
        vec![2, 3],
    ];
    b.family(ConstraintFamily::new(ConstraintKind::Distance, 0.0, edges));
    b.hyperplane(vec![0.0, 1.0, 0.0], 0.0, 0.5);
    let scene = b.build().expect("a sliver above the floor is valid");
    let Some((mut backend, initial)) = start(case, kind, &scene) else {
        return;
    };
    let m = run(case, backend.as_mut(), &initial, 90);
    check_energy(case, kind, &m, 0.0, "dissipative: starts at rest");
    check_residual(
        case,
        kind,
        "max |C| edges + contact (m)",
        m.residual,
        0.01,
        "1% of the 1 m edge",
    );
    // Once it lies on the plane the sliver is flattened: gravity pushes
    // every vertex g h² = 2.7e-5 m into the plane per substep, 27 000
    // times the sliver's height, and the contacts' accumulated multipliers
    // hold the vertices on the plane against the volume correction (each
    // iteration releases only the correction's share). So |C| reaches
    // |rest| — the sliver goes flat — but it never inverts (|C| would be
    // 2 |rest|) and never throws a vertex away. Bound: |rest| plus the
    // rounding of the determinant, ε · 56 · Π|e_j| / 3! (docs/bounds.md's
    // measure model, N = 3, k = 3).
    let rest = tet_volume(&initial.positions).abs();
    let edges = [1.0, 1.0, (0.18f64).sqrt()];
    let rounding = kind.epsilon() * 56.0 * edges.iter().product::<f64>() / 6.0;
    check_residual(
        case,
        kind,
        "max |C| volume (m^3)",
        m.measure_residual,
        rest + rounding,
        "flattened on the plane, never inverted: |rest| + determinant rounding",
    );
}

/// A soft 2 × 2 × 2 Kuhn block (48 rigid tetrahedra with rigid edges) whose
/// centre node starts pushed through a face, inverting the tetrahedra
/// around it (rest values from the undisturbed block). The volume
/// constraints must turn them back, not explode.
fn oriented_inverted(kind: Kind) {
    let case = "oriented_inverted";
    let mut b = SceneBuilder::new(3)
        .dt(1.0 / 60.0)
        .substeps(10)
        .iterations(4)
        .gravity_along(1, 9.81);
    let grid = b.soft_block(&BlockSpec {
        cells: vec![2, 2, 2],
        origin: vec![-0.5, 0.1, -0.5],
        spacing: 0.5,
        mass: 0.1,
        compliance: 0.0,
        edge_compliance: Some(0.0),
    });
    b.hyperplane(vec![0.0, 1.0, 0.0], 0.0, 0.5);
    let scene = b.build().expect("valid");
    let plan = Plan::compile(&scene).expect("compiles");
    let mut initial = State::from_scene(&scene);
    // The centre node (1, 1, 1) moves 0.75 m along +x: through the face at
    // x = 0.5 of the cells on its +x side.
    let centre = grid.index(&[1, 1, 1]);
    initial.positions[3 * centre] += 0.75;
    let inverted = count_inverted(&plan, &initial);
    assert!(inverted > 0, "the test must start with inverted tetrahedra");
    let Some(mut backend) =
        load(case, kind, plan.clone(), &initial).unwrap_or_else(|e| panic!("{case}: {e}"))
    else {
        return;
    };
    let m = run(case, backend.as_mut(), &initial, 120);
    // Starting violated: the correction of the displaced node, up to its
    // 0.75 m displacement in one substep, may become kinetic energy.
    let h = plan.h;
    let released = 0.5 * 0.1 * (0.75 / h) * (0.75 / h);
    check_energy(
        case,
        kind,
        &m,
        released,
        "starts violated: ½ m (0.75 m / h)² may be released",
    );
    let left = count_inverted(&plan, &m.last) as f64;
    report(
        case,
        kind,
        "ok",
        "inverted tets at start / end",
        left,
        &format!("0 of {inverted} ({inverted} at the start)"),
    );
    assert_eq!(left, 0.0, "{case}: tetrahedra left inverted");
    // It starts 0.75 m violated, so the residual is judged after the 2 s.
    check_residual(
        case,
        kind,
        "|C| edges + contact after 2 s (m)",
        m.final_residual,
        0.01 * 0.5,
        "1% of the 0.5 m cell edge",
    );
}

/// Elements of the plan's oriented family whose signed volume has the
/// opposite sign of its rest value.
fn count_inverted(plan: &Plan, state: &State) -> usize {
    let family = plan
        .families
        .iter()
        .find(|f| f.kind == FamilyKind::OrientedMeasure)
        .expect("oriented family");
    let mut points = vec![0.0; 12];
    family
        .elements
        .chunks_exact(4)
        .zip(&family.rest)
        .filter(|(element, rest)| {
            for (j, &i) in element.iter().enumerate() {
                points[3 * j..3 * j + 3].copy_from_slice(state.position(i as usize));
            }
            tet_volume(&points) * **rest < 0.0
        })
        .count()
}

/// An oriented rest measure of zero (a collapsed simplex) has no
/// orientation to preserve: a typed refusal, the same for every backend
/// (validation runs before any backend sees the scene).
fn oriented_zero_rest_refused(kind: Kind) {
    let case = "oriented_zero_rest_refused";
    let mut b = SceneBuilder::new(2);
    for p in [[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]] {
        b.particle(Particle::new(p.to_vec(), 1.0));
    }
    b.family(ConstraintFamily::new(
        ConstraintKind::OrientedMeasure,
        0.0,
        vec![vec![0, 1, 2]],
    ));
    let error = Plan::compile(b.scene()).expect_err("a collinear triangle must be refused");
    assert!(
        matches!(error, SceneError::DegenerateRest { .. }),
        "{error:?}"
    );
    report(
        case,
        kind,
        "refused: SceneError::DegenerateRest",
        "-",
        0.0,
        &error.to_string(),
    );
}

/// Two distance elements with rest 0.5 m whose particles start
/// coincident: pair A at rest (∇C does not exist: the element makes no
/// response and stays violated by exactly its rest length — DESIGN: no
/// invented direction), pair B with one particle moving at 1 m/s (after
/// the first prediction the direction exists and the link is restored).
fn coincident_distance(kind: Kind) {
    let case = "coincident_distance";
    let mut b = SceneBuilder::new(3)
        .dt(1.0 / 60.0)
        .substeps(10)
        .iterations(2)
        .gravity_along(1, 9.81);
    b.particle(Particle::new(vec![0.0, 1.0, 0.0], 1.0));
    b.particle(Particle::new(vec![0.0, 1.0, 0.0], 1.0));
    b.particle(Particle::new(vec![2.0, 1.0, 0.0], 1.0));
    b.particle(Particle::new(vec![2.0, 1.0, 0.0], 1.0).with_velocity(vec![1.0, 0.0, 0.0]));
    let mut a = ConstraintFamily::new(ConstraintKind::Distance, 0.0, vec![vec![0, 1]]);
    a.rest = Some(vec![0.5]);
    let mut pair_b = ConstraintFamily::new(ConstraintKind::Distance, 0.0, vec![vec![2, 3]]);
    pair_b.rest = Some(vec![0.5]);
    b.family(a);
    b.family(pair_b);
    let scene = b.build().expect("coincident particles are valid input");
    let Some((mut backend, initial)) = start(case, kind, &scene) else {
        return;
    };
    let steps = 60;
    let mut last = None;
    let mut energy_gain: f64 = f64::NEG_INFINITY;
    let mut energy_scale: f64 = 0.0;
    for step in 0..steps {
        let r = backend
            .step()
            .unwrap_or_else(|e| panic!("{case}: step {step}: {e}"));
        let s = backend.read_state().expect("read_state");
        assert!(
            s.positions
                .iter()
                .chain(&s.velocities)
                .all(|c| c.is_finite())
        );
        let (gain, scale) = energy(backend.plan(), &initial, &s);
        energy_gain = energy_gain.max(gain);
        energy_scale = energy_scale.max(scale);
        last = Some(r);
    }
    let r = last.expect("steps ran");
    let pair_a = r.residuals[0].max_violation;
    let pair_b = r.residuals[1].max_violation;
    // Pair B starts violated by 0.5 m: restoring it in one substep may
    // release ½ (m/2) (0.5 m / h)² (the reduced mass of the pair).
    let h = backend.plan().h;
    let released = 0.5 * 0.5 * (0.5 / h) * (0.5 / h);
    let m = Measured {
        energy_gain,
        energy_scale,
        residual: 0.0,
        measure_residual: 0.0,
        final_residual: 0.0,
        last: initial,
    };
    check_energy(
        case,
        kind,
        &m,
        released,
        "pair B starts 0.5 m short: ½ (m/2) (0.5 m / h)² may be released",
    );
    report(
        case,
        kind,
        "ok",
        "pair A (coincident, at rest) |C| (m)",
        pair_a,
        "= rest 0.5 (no direction exists: no response, by design)",
    );
    assert_eq!(pair_a, 0.5, "{case}: a coincident pair makes no response");
    check_residual(
        case,
        kind,
        "pair B (coincident, moving) |C| at the end (m)",
        pair_b,
        0.005,
        "1% of the 0.5 m rest length",
    );
}

/// Particles exactly on hyperplanes (n·x = offset + radius to the last
/// bit in f64): one on the ground y = 0, one on a 20° incline with
/// μ = 0.6 > tan 20° (static friction holds it), under gravity, 2 s.
/// Each particle is inside the other's half-space (hyperplanes are
/// infinite), so only its own plane touches it.
fn on_hyperplane(kind: Kind) {
    let case = "on_hyperplane";
    let mut b = SceneBuilder::new(3)
        .dt(1.0 / 60.0)
        .substeps(10)
        .gravity_along(1, 9.81);
    b.hyperplane(vec![0.0, 1.0, 0.0], 0.0, 0.5);
    b.particle(Particle::new(vec![5.0, 0.0, 0.2], 1.0));
    let theta: f64 = 20f64.to_radians();
    // A plane through (2, 0, 0) tilted about z, whose particle sits on it
    // at radius 0.1: n·x = offset + r with offset chosen from x itself.
    let normal = vec![theta.sin(), theta.cos(), 0.0];
    let x = vec![2.0, 0.5, 0.0];
    let offset = normal[0] * x[0] + normal[1] * x[1] - 0.1;
    b.hyperplane(normal, offset, 0.6);
    b.particle(Particle::new(x, 1.0).with_radius(0.1));
    let scene = b.build().expect("valid");
    let Some((mut backend, initial)) = start(case, kind, &scene) else {
        return;
    };
    let m = run(case, backend.as_mut(), &initial, 120);
    check_energy(case, kind, &m, 0.0, "resting contact");
    // A contact projection solves its own constraint exactly; what remains
    // is the rounding of n·x at coordinates up to 5 m: 8 ε · 5 m.
    let bound = 8.0 * kind.epsilon() * 5.0;
    check_residual(
        case,
        kind,
        "max penetration (m)",
        m.residual,
        bound,
        "rounding of n·x: 8 ε · 5 m",
    );
    let drift = (0..2)
        .map(|i| {
            m.last
                .position(i)
                .iter()
                .zip(initial.position(i))
                .map(|(a, b)| (a - b).abs())
                .fold(0.0, f64::max)
        })
        .fold(0.0, f64::max);
    // Static friction cancels the tangential motion each substep; gravity
    // pushes at most g h² into the plane per substep, corrected exactly:
    // the particles do not move beyond rounding.
    check_residual(
        case,
        kind,
        "max drift from the start (m)",
        drift,
        1200.0 * 8.0 * kind.epsilon() * 5.0,
        "rounding of n·x per substep, 1200 substeps",
    );
}

/// The rope bridge of `scenes::chain2d` (21 particles, rigid links,
/// ground plane, damping) translated by (d, d).
fn offset_bridge(d: f64) -> Scene {
    let mut scene = hyperpbd::scenes::chain2d();
    for p in &mut scene.particles {
        for c in &mut p.position {
            *c += d;
        }
    }
    for o in &mut scene.obstacles {
        let hyperpbd::Obstacle::Hyperplane { normal, offset, .. } = o else {
            unreachable!("chain2d has only hyperplane obstacles");
        };
        // n = (0, 1): the ground moves up by d with the scene.
        *offset += normal[1] * d;
    }
    scene
}

/// Positions relative to (d, d) of `state`.
fn relative(state: &State, d: f64) -> Vec<f64> {
    state.positions.iter().map(|x| x - d).collect()
}

/// The bridge at offset `d` against the CPU run of the same bridge at the
/// world origin, 60 frames; on gpu-f32 also without the scene-origin
/// remedy, to show what it buys.
fn far_offset(case: &str, kind: Kind, d: f64) {
    let frames = 60;
    let near = offset_bridge(0.0);
    let mut golden = CpuBackend::new(
        Plan::compile(&near).expect("valid"),
        &State::from_scene(&near),
    )
    .expect("cpu");
    for _ in 0..frames {
        golden.step().expect("golden step");
    }
    let golden = golden.read_state().expect("read");
    let scene = offset_bridge(d);
    let Some((mut backend, initial)) = start(case, kind, &scene) else {
        return;
    };
    let m = run(case, backend.as_mut(), &initial, frames);
    check_energy(case, kind, &m, 0.0, "damped bridge");
    let error = hyperpbd::compare::max_abs_diff(&relative(&m.last, d), &golden.positions);
    // The bridge at the origin in this backend's precision, against the
    // same golden run: what the precision costs without any offset.
    let plan = Plan::compile(&scene).expect("valid");
    let model = hyperpbd::compare::ErrorModel::new(
        &plan,
        match kind {
            Kind::GpuF32 => hyperpbd::Precision::F32,
            _ => hyperpbd::Precision::F64,
        },
    );
    // Coordinates of the bridge relative to its own origin are ≤ 2 m; the
    // offset itself is carried exactly in f64 (ε64 · d per rounding).
    let local_scale = 2.0;
    let bound = model.position_bound(local_scale, frames as u64)
        + hyperpbd::compare::ErrorModel::new(&plan, hyperpbd::Precision::F64)
            .position_bound(d + local_scale, frames as u64);
    check_residual(
        case,
        kind,
        "|x − d − x_golden(origin)| (m)",
        error,
        bound,
        "ErrorModel at the scene's own 2 m scale + f64 model at d",
    );
    check_residual(
        case,
        kind,
        "max |C| (m)",
        m.residual,
        0.01 * 0.1,
        "1% of the 0.1 m link",
    );
    if kind == Kind::GpuF32 {
        let Some((adapter, _)) = adapter_or_skip(case, Precision::F32) else {
            return;
        };
        // The reference: the same bridge at the world origin in f32.
        let mut at_origin = GpuBackend::with_adapter(
            &adapter,
            Plan::compile(&near).expect("valid"),
            &State::from_scene(&near),
            Precision::F32,
        )
        .expect("gpu");
        for _ in 0..frames {
            at_origin.step().expect("f32 step at the origin");
        }
        let origin_error = hyperpbd::compare::max_abs_diff(
            &at_origin.read_state().expect("read").positions,
            &golden.positions,
        );
        report(
            case,
            kind,
            "reference: the bridge at the world origin",
            "|x − x_golden| (m)",
            origin_error,
            "not asserted; what f32 costs with no offset at all",
        );
        // Without the remedy: positions stored in world coordinates.
        let mut raw = GpuBackend::with_origin(
            &adapter,
            plan.clone(),
            &initial,
            Precision::F32,
            SceneOrigin::zero(plan.dim),
        )
        .expect("gpu");
        let mut failed = None;
        for f in 0..frames {
            if let Err(e) = raw.step() {
                failed = Some(format!("frame {f}: {e}"));
                break;
            }
        }
        let raw_state = raw.read_state().expect("read");
        let raw_error =
            hyperpbd::compare::max_abs_diff(&relative(&raw_state, d), &golden.positions);
        report(
            case,
            kind,
            "without the scene origin (f32 world coordinates)",
            "|x − d − x_golden(origin)| (m)",
            raw_error,
            &format!(
                "not asserted; ulp({d:e}) = {:.1e} m{}",
                f64::from(ulp32(d as f32)),
                failed.map_or(String::new(), |e| format!("; {e}"))
            ),
        );
    }
}

/// Spacing of f32 values at `x`.
fn ulp32(x: f32) -> f32 {
    f32::from_bits(x.to_bits() + 1) - x
}

fn far_offset_1e3(kind: Kind) {
    far_offset("far_offset_1e3", kind, 1e3);
}

fn far_offset_1e5(kind: Kind) {
    far_offset("far_offset_1e5", kind, 1e5);
}

/// A 10-link rigid chain (0.1 m links, 0.1 kg) released horizontally from
/// a fixed end above a ground plane with friction, at time step `dt`.
fn swinging_chain(dt: f64, substeps: u32, iterations: u32) -> Scene {
    let mut b = SceneBuilder::new(3)
        .dt(dt)
        .substeps(substeps)
        .iterations(iterations)
        .gravity_along(1, 9.81);
    b.chain(&ChainSpec {
        start: vec![0.0, 0.5, 0.0],
        direction: vec![1.0, 0.0, 0.2],
        count: 11,
        spacing: 0.1,
        mass: 0.1,
        compliance: 0.0,
        fix_first: true,
    });
    b.hyperplane(vec![0.0, 1.0, 0.0], 0.0, 0.3);
    b.build().expect("valid")
}

/// dt = 1 s: the chain falls onto the ground and comes to rest, 30 s.
///
/// With one substep, gravity moves every particle g h² = 9.81 m per
/// substep — 100 links — and Gauss–Seidel with a fixed iteration count
/// leaves a steady residual proportional to that drift (measured: 0.40 m
/// at 8 iterations, 0.15 m at 32; bounded and dissipative, but not a
/// rigid chain). The remedy is XPBD's own: substeps, since the drift falls
/// as h². The asserted case is dt = 1 s in 200 substeps × 2 iterations;
/// the single-substep run is reported alongside (finite and dissipative
/// asserted, its residual only reported).
fn dt_one_second(kind: Kind) {
    let case = "dt_one_second";
    let scene = swinging_chain(1.0, 200, 2);
    let Some((mut backend, initial)) = start(case, kind, &scene) else {
        return;
    };
    let m = run(case, backend.as_mut(), &initial, 30);
    check_energy(case, kind, &m, 0.0, "dissipative: starts at rest");
    check_residual(
        case,
        kind,
        "max |C|, 200 substeps (m)",
        m.residual,
        0.001,
        "1% of the 0.1 m link",
    );
    let coarse = swinging_chain(1.0, 1, 8);
    let Some((mut backend, initial)) = start(case, kind, &coarse) else {
        return;
    };
    let m = run(case, backend.as_mut(), &initial, 30);
    check_energy(case, kind, &m, 0.0, "dissipative: starts at rest");
    report(
        case,
        kind,
        "bounded, not rigid",
        "max |C|, 1 substep × 8 iterations (m)",
        m.residual,
        "not asserted: steady Gauss–Seidel residual ∝ g h² = 9.81 m",
    );
}

/// dt = 1e-6 s (1 substep, 2 iterations), 2000 steps = 2 ms: the
/// per-step displacement under gravity (g dt² = 1e-11 m) is far below the
/// f32 spacing of a 1 m coordinate (6e-8 m), so in f32 the chain does not
/// move at all — stable, and wrong by at most the true displacement ½ g t²
/// = 2e-5 m. f64 resolves it.
fn dt_one_microsecond(kind: Kind) {
    let case = "dt_one_microsecond";
    let scene = swinging_chain(1e-6, 1, 2);
    let Some((mut backend, initial)) = start(case, kind, &scene) else {
        return;
    };
    let steps = 2000;
    let m = run(case, backend.as_mut(), &initial, steps);
    check_energy(case, kind, &m, 0.0, "dissipative: starts at rest");
    check_residual(
        case,
        kind,
        "max |C| (m)",
        m.residual,
        0.001,
        "1% of the 0.1 m link",
    );
    // The tip's fall against the CPU golden run (≈ ½ g t² = 1.96e-5 m):
    // f64 backends follow it within the rounding model; f32 cannot
    // represent a 1e-11 m step at a 1 m coordinate and moves by at most
    // the rounding model at its own ε.
    let tip = 10 * 3 + 1;
    let moved = initial.positions[tip] - m.last.positions[tip];
    let golden_fall = if kind == Kind::Cpu {
        moved
    } else {
        let (mut cpu, _) = start(case, Kind::Cpu, &scene).expect("cpu");
        run(case, cpu.as_mut(), &initial, steps).last.positions[tip]
    };
    let golden_fall = if kind == Kind::Cpu {
        golden_fall
    } else {
        initial.positions[tip] - golden_fall
    };
    let plan = Plan::compile(&scene).expect("valid");
    let f64_model = hyperpbd::compare::ErrorModel::new(&plan, hyperpbd::Precision::F64);
    let (bound, why) = match kind {
        Kind::GpuF32 => (
            golden_fall
                + hyperpbd::compare::ErrorModel::new(&plan, hyperpbd::Precision::F32)
                    .position_bound(1.0, steps as u64),
            "f32: the true fall + its rounding model (the fall itself is below ulp)",
        ),
        _ => (
            f64_model.position_bound(1.0, steps as u64),
            "f64 rounding model at |x| ≤ 1 m",
        ),
    };
    check_residual(
        case,
        kind,
        &format!("|tip fall − golden {golden_fall:.3e}| (m)"),
        (moved - golden_fall).abs(),
        bound,
        why,
    );
}

/// One particle 1 m above the ground moving at 1e4 m/s straight at it
/// (radius 0.05, 10 substeps at 60 Hz: 16.7 m per substep, 330 times its
/// height). XPBD path: the plane is a half-space constraint, so the
/// particle is projected back to n·x = radius in the substep it crosses —
/// no tunnelling — and the contact is perfectly inelastic: it ends at
/// rest on the plane. (Barrier path: issue 8.)
fn fast_impact_xpbd(kind: Kind) {
    let case = "fast_impact_xpbd";
    let mut b = SceneBuilder::new(3)
        .dt(1.0 / 60.0)
        .substeps(10)
        .gravity_along(1, 9.81);
    b.hyperplane(vec![0.0, 1.0, 0.0], 0.0, 0.0);
    b.particle(
        Particle::new(vec![0.0, 1.0, 0.0], 1.0)
            .with_radius(0.05)
            .with_velocity(vec![0.0, -1e4, 0.0]),
    );
    let scene = b.build().expect("valid");
    let Some((mut backend, initial)) = start(case, kind, &scene) else {
        return;
    };
    let m = run(case, backend.as_mut(), &initial, 60);
    check_energy(case, kind, &m, 0.0, "inelastic contact");
    // Penetration after the projection: rounding of one n·x at |x| ≤ 17 m
    // (the predicted position before the projection).
    check_residual(
        case,
        kind,
        "max penetration (m)",
        m.residual,
        8.0 * kind.epsilon() * 17.0,
        "rounding of n·x at the 17 m prediction: no tunnelling",
    );
    let y = m.last.positions[1];
    let vy = m.last.velocities[1];
    report(
        case,
        kind,
        "ok",
        "final height (m)",
        y,
        "= radius 0.05 (rests on the plane)",
    );
    report(
        case,
        kind,
        "ok",
        "final normal velocity (m/s)",
        vy,
        "|v| ≤ g h: inelastic, at rest",
    );
    assert!(
        (y - 0.05).abs() <= 8.0 * kind.epsilon() * 17.0,
        "{case}: y = {y}"
    );
    assert!(vy.abs() <= 9.81 / 600.0 * (1.0 + 1e-6), "{case}: vy = {vy}");
}

/// R^8: a 3 × 3 sheet (edges, shear, and its triangles as a squared-area
/// family) and a soft 8-simplex with rigid edges, dropped onto a tilted
/// hyperplane with friction, damped, 2 s, 10 substeps × 4 iterations.
///
/// Measured while writing this: with 1 or 2 iterations the rigid
/// 8-simplex (36 coupled edges in 9 colors) gains energy after it lands
/// (+307 J at 2 iterations, the edges left 3 cm off): Gauss–Seidel stopped
/// that far from convergence turns the unconverged edge corrections into
/// velocity every substep. From 4 iterations on it is dissipative; the
/// README says so.
fn eight_dimensions(kind: Kind) {
    let case = "eight_dimensions";
    let dim = 8;
    let mut b = SceneBuilder::new(dim)
        .dt(1.0 / 60.0)
        .substeps(10)
        .iterations(4)
        .gravity_along(7, 9.81)
        .damping(0.5);
    let mut sheet = GridSpec::cloth(3, 3, 0.25, 0.0);
    sheet.axes = vec![0, 1];
    sheet.origin = vec![0.0, 0.0, 0.1, 0.0, 0.0, 0.0, 0.0, 0.6];
    sheet.mass = 0.1;
    let grid = b.grid(&sheet);
    let mut triangles = Vec::new();
    for i in 0..2 {
        for j in 0..2 {
            let (a, c, d, e) = (
                grid.index(&[i, j]),
                grid.index(&[i + 1, j]),
                grid.index(&[i, j + 1]),
                grid.index(&[i + 1, j + 1]),
            );
            triangles.push(vec![a, c, d]);
            triangles.push(vec![c, e, d]);
        }
    }
    b.family(ConstraintFamily::new(
        ConstraintKind::SimplexMeasure,
        1e-6,
        triangles,
    ));
    let first = b.scene().particles.len();
    for k in 0..=dim {
        let mut x = vec![1.0; dim];
        x[7] = 1.0;
        if k > 0 {
            x[k - 1] += 0.3;
        }
        b.particle(Particle::new(x, 0.05).with_radius(0.02));
    }
    let simplex: Vec<usize> = (first..=first + dim).collect();
    b.family(ConstraintFamily::new(
        ConstraintKind::OrientedMeasure,
        1e-8,
        vec![simplex.clone()],
    ));
    let mut edges = Vec::new();
    for (a, &i) in simplex.iter().enumerate() {
        for &j in &simplex[a + 1..] {
            edges.push(vec![i, j]);
        }
    }
    b.family(ConstraintFamily::new(ConstraintKind::Distance, 0.0, edges));
    let mut normal = vec![0.05; dim];
    normal[7] = 1.0;
    b.hyperplane(normal, 0.0, 0.4);
    let scene = b.build().expect("valid");
    let Some((mut backend, initial)) = start(case, kind, &scene) else {
        return;
    };
    let m = run(case, backend.as_mut(), &initial, 120);
    check_energy(case, kind, &m, 0.0, "dissipative: starts at rest");
    check_residual(
        case,
        kind,
        "max |C| (m)",
        m.residual,
        0.01 * 0.25,
        "1% of the 0.25 m sheet link",
    );
}

/// R^9: the CPU runs it (a falling particle on a plane); the GPU kernels
/// are generated for dimensions 1..=8 and refuse it with a typed
/// `GpuError::Unsupported` — never a fallback.
fn nine_dimensions(kind: Kind) {
    let case = "nine_dimensions";
    let dim = 9;
    let mut b = SceneBuilder::new(dim)
        .dt(1.0 / 60.0)
        .substeps(4)
        .gravity_along(8, 9.81);
    let mut up = vec![0.0; dim];
    up[8] = 1.0;
    b.hyperplane(up, 0.0, 0.3);
    let mut x = vec![0.0; dim];
    x[8] = 0.5;
    b.particle(Particle::new(x, 1.0).with_radius(0.01));
    let scene = b.build().expect("valid");
    let plan = Plan::compile(&scene).expect("valid");
    let initial = State::from_scene(&scene);
    match load(case, kind, plan, &initial) {
        Ok(None) => {}
        Ok(Some(mut backend)) => {
            assert_eq!(kind, Kind::Cpu, "only the CPU runs R^9");
            let m = run(case, backend.as_mut(), &initial, 60);
            check_energy(case, kind, &m, 0.0, "inelastic landing");
            check_residual(
                case,
                kind,
                "max penetration (m)",
                m.residual,
                8.0 * kind.epsilon(),
                "rounding of n·x at |x| ≤ 1 m",
            );
        }
        Err(e) => {
            assert_ne!(kind, Kind::Cpu);
            assert!(
                matches!(e, BackendError::Gpu(GpuError::Unsupported { .. })),
                "{e:?}"
            );
            report(
                case,
                kind,
                "refused: GpuError::Unsupported",
                "-",
                0.0,
                &e.to_string(),
            );
        }
    }
}

/// No particles at all: the plan has no kernels; steps succeed and change
/// nothing.
fn empty_scene(kind: Kind) {
    let case = "empty_scene";
    let scene = SceneBuilder::new(3)
        .gravity_along(1, 9.81)
        .build()
        .expect("valid");
    let Some((mut backend, initial)) = start(case, kind, &scene) else {
        return;
    };
    let m = run(case, backend.as_mut(), &initial, 5);
    assert!(m.last.is_empty());
    report(case, kind, "ok", "particles after 5 steps", 0.0, "0");
}

/// One particle thrown onto a plane with friction: it lands, slides,
/// stops.
fn one_particle(kind: Kind) {
    let case = "one_particle";
    let mut b = SceneBuilder::new(3)
        .dt(1.0 / 60.0)
        .substeps(8)
        .gravity_along(1, 9.81);
    b.hyperplane(vec![0.0, 1.0, 0.0], 0.0, 0.5);
    b.particle(
        Particle::new(vec![0.1, 0.3, -0.2], 0.7)
            .with_velocity(vec![1.5, 0.0, 0.5])
            .with_radius(0.02),
    );
    let scene = b.build().expect("valid");
    let Some((mut backend, initial)) = start(case, kind, &scene) else {
        return;
    };
    let m = run(case, backend.as_mut(), &initial, 90);
    check_energy(case, kind, &m, 0.0, "inelastic landing, friction");
    check_residual(
        case,
        kind,
        "max penetration (m)",
        m.residual,
        8.0 * kind.epsilon() * 1.0,
        "rounding of n·x at |x| ≤ 1 m",
    );
}

/// `write_state` and `read_state` go through the same scene origin: a
/// state written at 1e5 m reads back with the f32 rounding of the *local*
/// coordinates (|x − o| ≤ 2 m: ≤ ulp(2)/2 = 1.2e-7 m), not of 1e5 m
/// (3.9e-3 m).
#[test]
fn f32_state_round_trips_through_the_scene_origin() {
    let Some((adapter, _)) = adapter_or_skip("f32_state_round_trips", Precision::F32) else {
        return;
    };
    let d = 1e5;
    let scene = offset_bridge(d);
    let plan = Plan::compile(&scene).expect("valid");
    let initial = State::from_scene(&scene);
    let mut gpu = GpuBackend::with_adapter(&adapter, plan, &initial, Precision::F32).expect("gpu");
    assert!(!gpu.origin().is_zero(), "a scene at 1e5 gets an origin");
    let mut written = initial.clone();
    for (i, x) in written.positions.iter_mut().enumerate() {
        *x += 1e-3 * (i % 7) as f64;
    }
    gpu.write_state(&written).expect("write");
    let back = gpu.read_state().expect("read");
    let error = hyperpbd::compare::max_abs_diff(&back.positions, &written.positions);
    let bound = f64::from(ulp32(2.0)) / 2.0;
    println!(
        "BOUND | f32 write/read at 1e5 | {error:.3e} | {bound:.3e} | ulp(2 m)/2: local coordinates"
    );
    assert!(error <= bound, "{error:e} > {bound:e}");
}
