//! Whole steps, CPU golden path vs GPU, frame by frame: the loop of
//! `tests/gpu/differential.rs` and `tests/gpu/coverage/`.
//!
//! Every frame, the golden path is restarted from the GPU's own state of
//! the previous frame and both run the same frame; the difference is that
//! one frame's rounding, held to the per-frame model of
//! `hyperpbd_verify::compare_frame::FrameErrorModel`. f64 on lavapipe is also run
//! from the start on a second CPU backend and asserted bit-identical to it,
//! reports included ([`super::exact`]). After the last frame one line per
//! metric is printed:
//!
//! ```text
//! BOUND | scene | metric | frames | measured | bound | precision
//! ```
//! with measured and bound of the frame with the largest measured / bound
//! (every frame is asserted against its own bound).
//!
//! ```text
//! position   FrameErrorModel: double sum over the frame's S substeps of the
//!            fresh error. Plans with a family coupling particles: u X c +
//!            u h V + J_k + M_k (u = ε/2, X the largest |device coordinate|,
//!            c the roundings landing on a coordinate per substep, J_k the
//!            static-friction jump allowance μ w λ, M_k the material
//!            elements' conditioning, docs/materials.md §7). Independent
//!            particles: σ (u max_i b(X_i) c_i,k + u h V) + J_k (X_i particle
//!            i's largest |device coordinate| on the moved axes, b its
//!            binade, c_i,k the roundings landing on it in substep k, σ the
//!            Euclidean factor where a plane mixes axes)
//! velocity   the same model's velocity sum (e_v ← e_v + q + r_k / h)
//! residual   per family, |r_gpu − r_cpu| where r = max_e |C_e| (max(0, −C)
//!            for contacts). max is 1-Lipschitz, so it is at most
//!            max_e |C_e(x_gpu) − C_e(x_cpu)| + the GPU's own rounding of C:
//!              ≤ max_e Σ_j |∇_j C_e| · √N · P  +  ε · r_C · M
//!            P: the position bound (per coordinate, so √N per point);
//!            Σ_j |∇_j C| = 2 (distance), 1 (contact), computed at the CPU
//!            state for measures; r_C the roundings of evaluating C and M
//!            its magnitude scale: distance (2N + 4)·2X; contact (2N + 3)·
//!            (X + rest); measures (4N + 8k + 20)·Π|e_j|²/(k!)² or Π|e_j|/N!
//!            (Hadamard: an elimination determinant rounds relative to it);
//!            materials |r(x_gpu) − r_cpu| + max_e δC_e(x_gpu): r evaluated in
//!            f64 at the GPU's state plus the device's evaluation error of
//!            C = √(2W) (hyperpbd_verify::compare_material; C is a cone at rest,
//!            so no Lipschitz constant at one state bounds it)
//! contacts   active contacts (λ > 0 in the last substep): equal in f64
//!            (bound 0). In f32 a contact whose λ is within rounding of 0 may
//!            flip; the largest difference over the frames is printed with
//!            bound "-" and not asserted.
//! kernels    kernel calls per stage: equal on both backends and equal to
//!            Plan::kernel_counts() (asserted every frame).
//! ```

use super::bound::print_bound;
use super::exact::{assert_f32_reference_step, bits, f32_identical, f64_identical};
use super::gpu::adapter_or_skip;
use hyperpbd::geometry::{Scratch, factorial, oriented_measure, simplex_squared_measure};
use hyperpbd::{Backend, CpuBackend, F32Reference, FamilyKind, Plan, Scene, State, StepReport};
use hyperpbd_gpu::{AdapterSummary, GpuBackend, Precision, SceneOrigin};
use hyperpbd_verify::compare::{Divergence, DivergenceModel, Frame, max_abs_diff};
use hyperpbd_verify::compare_frame::FrameErrorModel;

/// Evaluation scale and gradient sum of every element of a measure family.
fn measure_scales(plan: &Plan, family: usize, state: &State) -> (f64, f64) {
    let f = &plan.families[family];
    let dim = plan.dim;
    let mut scratch = Scratch::new();
    let mut points = vec![0.0; f.arity * dim];
    let mut grad = vec![0.0; f.arity * dim];
    let (mut g_max, mut m_max) = (0.0f64, 0.0f64);
    for e in 0..f.len() {
        let ids = &f.elements[e * f.arity..(e + 1) * f.arity];
        for (j, &i) in ids.iter().enumerate() {
            points[j * dim..(j + 1) * dim].copy_from_slice(state.position(i as usize));
        }
        let edge_norms: f64 = (1..f.arity)
            .map(|j| {
                (0..dim)
                    .map(|a| (points[j * dim + a] - points[a]).powi(2))
                    .sum::<f64>()
                    .sqrt()
            })
            .product();
        let m = match f.kind {
            FamilyKind::SimplexMeasure { k } => {
                simplex_squared_measure(&points, dim, &mut grad, &mut scratch);
                edge_norms * edge_norms / (factorial(k) * factorial(k))
            }
            _ => {
                oriented_measure(&points, dim, &mut grad, &mut scratch);
                edge_norms / factorial(dim)
            }
        };
        let g: f64 = grad
            .chunks_exact(dim)
            .map(|gj| gj.iter().map(|c| c * c).sum::<f64>().sqrt())
            .sum();
        g_max = g_max.max(g);
        m_max = m_max.max(m);
    }
    (g_max, m_max)
}

/// Bound on |r_gpu − r_cpu| of family `family` (see the module docs).
fn residual_bound(
    plan: &Plan,
    family: usize,
    cpu: &State,
    position_bound: f64,
    eps: f64,
    x: f64,
) -> f64 {
    let n = plan.dim as f64;
    let Some(f) = plan.families.get(family) else {
        // Particle contact (the residual after the families): the overlap
        // max(0, r_i + r_j − |x_j − x_i|) is 1-Lipschitz in |x_j − x_i|,
        // as a distance.
        return 2.0 * n.sqrt() * position_bound + eps * (2.0 * n + 4.0) * 2.0 * x;
    };
    let rest = f.rest.iter().fold(0.0f64, |m, r| m.max(r.abs()));
    match f.kind {
        // A tether's violation max(0, |d| − rest) is 1-Lipschitz in |d| − rest:
        // the distance bound.
        FamilyKind::Distance | FamilyKind::Tether => {
            2.0 * n.sqrt() * position_bound + eps * (2.0 * n + 4.0) * 2.0 * x
        }
        FamilyKind::HyperplaneContact { .. } => {
            n.sqrt() * position_bound + eps * (2.0 * n + 3.0) * (x + rest)
        }
        FamilyKind::SimplexMeasure { k } => {
            let (g, m) = measure_scales(plan, family, cpu);
            g * n.sqrt() * position_bound + eps * (4.0 * n + 8.0 * k as f64 + 20.0) * m
        }
        FamilyKind::OrientedMeasure => {
            let (g, m) = measure_scales(plan, family, cpu);
            g * n.sqrt() * position_bound + eps * (12.0 * n + 20.0) * m
        }
        // Evaluated, not propagated: C = √(2W) is a cone at rest, so no
        // Lipschitz constant at one state bounds it nearby; the exact
        // residual at the GPU's state is the golden path's function there.
        FamilyKind::Material { .. } => unreachable!("material_residual_bound"),
        // No differential scene has an expression family: those are held
        // bit for bit by tests/gpu/expressions.rs instead of by a bound.
        FamilyKind::Expression(_) => unreachable!("no differential scene has an expression family"),
        // The GPU backends refuse mesh contacts (tests/gpu/xpbd_mesh.rs).
        FamilyKind::MeshContact { .. } => unreachable!("no differential scene has a mesh contact"),
    }
}

/// Bound on |r_gpu − r_cpu| of material family `family`: |r(x_gpu) −
/// r_cpu| (r evaluated in f64 at the GPU's state, the position rows bound
/// how far that state is) + max_e δC_e at the GPU's state, the device's
/// evaluation error of C = √(2W) (`compare_material::constraint_error`).
fn material_residual_bound(
    plan: &Plan,
    family: usize,
    gpu: &State,
    cpu_residual: f64,
    precision: Precision,
) -> f64 {
    let rounding = hyperpbd_verify::compare_material::Rounding::of(precision);
    let (at_gpu, error) = hyperpbd_verify::compare_material::residual_error(
        &plan.families[family],
        &gpu.positions,
        plan.dim,
        rounding,
    );
    (at_gpu - cpu_residual).abs() + error
}

pub fn print_row(
    scene: &str,
    metric: &str,
    frames: u64,
    measured: String,
    bound: String,
    p: Precision,
) {
    print_bound(
        format_args!("{scene} | {metric} | {frames}"),
        format_args!("{measured}"),
        format_args!("{bound}"),
        format_args!("{p}"),
    );
}

/// (metric, measured, bound) of the frame with the largest measured / bound;
/// a NaN bound: exact (bit-identical to its reference), the largest
/// measured.
#[derive(Default)]
struct Rows(Vec<(String, f64, f64)>);

impl Rows {
    fn record_exact(&mut self, metric: String, measured: f64) {
        match self.0.iter_mut().find(|r| r.0 == metric) {
            Some(r) => r.1 = r.1.max(measured),
            None => self.0.push((metric, measured, f64::NAN)),
        }
    }

    fn record(&mut self, metric: String, measured: f64, bound: f64) {
        let ratio = |m: f64, b: f64| {
            if b > 0.0 {
                m / b
            } else if m > 0.0 {
                f64::INFINITY
            } else {
                0.0
            }
        };
        match self.0.iter_mut().find(|r| r.0 == metric) {
            Some(r) => {
                if ratio(measured, bound) > ratio(r.1, r.2) || (r.1 == 0.0 && bound > r.2) {
                    (r.1, r.2) = (measured, bound);
                }
            }
            None => self.0.push((metric, measured, bound)),
        }
    }
}

/// Runs `scene` `frames` frames on the GPU at `precision`, each frame also
/// on the CPU from the GPU's previous state, asserting every bound after
/// every frame; on lavapipe in f64 also against the CPU run from the start,
/// bit for bit. Prints the final rows; returns the GPU's last state.
pub fn differential(
    adapter: &wgpu::Adapter,
    summary: &AdapterSummary,
    name: &str,
    scene: &Scene,
    frames: u64,
    precision: Precision,
) -> State {
    let plan = Plan::compile(scene).expect("scene compiles");
    let state = State::from_scene(scene);
    let mut shadow = CpuBackend::new(plan.clone(), &state).expect("CPU backend");
    let mut golden = CpuBackend::new(plan.clone(), &state).expect("CPU backend");
    let mut gpu = GpuBackend::with_adapter(adapter, plan.clone(), &state, precision)
        .unwrap_or_else(|e| panic!("{name} {precision}: GPU backend: {e}"));
    let origin = SceneOrigin::for_state(plan.dim, &state.positions, precision);
    let mut model = FrameErrorModel::new(&plan, precision, origin.as_slice()).expect("frame model");
    let exact = precision == Precision::F64 && f64_identical(summary);
    // f32 on llvmpipe: the f32 reference from the start, bit for bit
    // (plans it runs; the others keep the model alone).
    let mut reference = (precision == Precision::F32 && f32_identical(summary))
        .then(|| F32Reference::new(plan.clone(), &state, origin.as_slice()).ok())
        .flatten();
    let eps = precision.epsilon();
    let counts = plan.kernel_counts();
    let mut rows = Rows::default();
    let mut contacts = (0, 0, 0);
    let mut last = state.clone();
    for frame in 1..=frames {
        let start = gpu.read_state().expect("GPU read_state");
        shadow.write_state(&start).expect("CPU write_state");
        let rc: StepReport = shadow
            .step()
            .unwrap_or_else(|e| panic!("{name}: CPU step {frame}: {e}"));
        let rg = gpu
            .step()
            .unwrap_or_else(|e| panic!("{name} {precision}: GPU step {frame}: {e}"));
        assert_eq!(
            rc.kernel_calls, counts,
            "{name}: CPU kernel calls vs the plan"
        );
        assert_eq!(
            rg.kernel_calls, counts,
            "{name} {precision}: GPU kernel calls vs the plan"
        );
        let sc = shadow.read_state().expect("CPU read_state");
        let sg = gpu.read_state().expect("GPU read_state");
        assert_eq!(sc.len(), sg.len());
        last.clone_from(&sg);
        if let Some(r) = reference.as_mut() {
            assert_f32_reference_step(name, frame, r, &rg, &sg);
        }
        if exact {
            let report = golden.step().expect("CPU step");
            let from_start = golden.read_state().expect("CPU read_state");
            assert!(
                bits(&from_start) == bits(&sg),
                "{name} f64 frame {frame}: the GPU on llvmpipe is not bit-identical to the golden \
                 path run from the start: max |dx| {:e}, max |dv| {:e}",
                max_abs_diff(&from_start.positions, &sg.positions),
                max_abs_diff(&from_start.velocities, &sg.velocities)
            );
            // Equal but for the CPU's thread count (who computed, not what).
            let report = StepReport {
                threads: rg.threads,
                ..report
            };
            assert_eq!(report, rg, "{name} f64 frame {frame}: reports");
        }
        let bounds = model
            .frame_bounds(Frame {
                start: &start,
                golden: (&rc, &sc),
                other: (&rg, &sg),
            })
            .expect("frame bounds");
        let d = Divergence::new(frame, &sc, &sg, bounds);
        assert!(
            d.within(),
            "{name} {precision} frame {frame}: position {:e} (bound {:e}), velocity {:e} (bound {:e}) \
             in one frame from the GPU's previous state",
            d.position,
            d.position_bound,
            d.velocity,
            d.velocity_bound,
        );
        if reference.is_some() {
            // Identical to its reference: this frame's error is the
            // reference's own, the rows say `exact`; the model's bound
            // (other adapters) is asserted and printed beside.
            rows.record_exact("position".into(), d.position);
            rows.record_exact("velocity".into(), d.velocity);
            rows.record("position model".into(), d.position, d.position_bound);
            rows.record("velocity model".into(), d.velocity, d.velocity_bound);
        } else {
            rows.record("position".into(), d.position, d.position_bound);
            rows.record("velocity".into(), d.velocity, d.velocity_bound);
        }
        let scale = model.device_scale(&[&start, &sc, &sg]);
        assert_eq!(rc.residuals.len(), rg.residuals.len());
        for (family, (a, b)) in rc.residuals.iter().zip(&rg.residuals).enumerate() {
            assert_eq!(a.label, b.label);
            let measured = (a.max_violation - b.max_violation).abs();
            let bound = match plan.families.get(family) {
                Some(f) if exact && matches!(f.kind, FamilyKind::Material { .. }) => 0.0,
                Some(f) if matches!(f.kind, FamilyKind::Material { .. }) => {
                    material_residual_bound(&plan, family, &sg, a.max_violation, precision)
                }
                _ => residual_bound(&plan, family, &sc, d.position_bound, eps, scale),
            };
            assert!(
                measured <= bound,
                "{name} {precision} frame {frame}: residual of {} differs by {measured:e} \
                 (cpu {:e}, gpu {:e}) > bound {bound:e}",
                a.label,
                a.max_violation,
                b.max_violation
            );
            let kind = plan
                .families
                .get(family)
                .map_or("particle_contact", |f| f.kind.name());
            let metric = format!("residual {} {kind}", a.label);
            if reference.is_some() {
                rows.record_exact(metric.clone(), measured);
                rows.record(format!("{metric} model"), measured, bound);
            } else {
                rows.record(metric, measured, bound);
            }
        }
        if precision == Precision::F64 {
            assert_eq!(
                rc.active_contacts, rg.active_contacts,
                "{name} f64 frame {frame}: active contacts"
            );
        }
        let flips = rc.active_contacts.abs_diff(rg.active_contacts);
        contacts.0 = contacts.0.max(flips);
        contacts.1 = rc.active_contacts;
        contacts.2 = contacts.2.max(rc.active_contacts);
    }
    println!(
        "MODEL | {name} | roundings/substep {} | velocity roundings/substep {} | substeps/frame {} | h {:.4e} | {precision}",
        model.position_roundings, model.velocity_roundings, plan.substeps, plan.h
    );
    let show_bound = |bound: f64| {
        if exact || bound.is_nan() {
            "exact".to_string()
        } else {
            format!("{bound:.3e}")
        }
    };
    for (metric, measured, bound) in rows.0 {
        print_row(
            name,
            &metric,
            frames,
            format!("{measured:.3e}"),
            show_bound(bound),
            precision,
        );
    }
    if plan.families.iter().any(|f| f.kind.is_inequality()) {
        let bound = if precision == Precision::F64 {
            "0"
        } else {
            "-"
        };
        print_row(
            name,
            &format!(
                "active contacts (cpu: {} at end, {} max)",
                contacts.1, contacts.2
            ),
            frames,
            contacts.0.to_string(),
            bound.into(),
            precision,
        );
    }
    last
}

/// Runs one scene at both precisions with one adapter per precision.
pub fn both(test: &str, name: &str, scene: &Scene, frames: u64) {
    for precision in [Precision::F32, Precision::F64] {
        let Some((adapter, summary)) = adapter_or_skip(test, precision) else {
            return;
        };
        differential(&adapter, &summary, name, scene, frames, precision);
    }
}
