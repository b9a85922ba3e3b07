//! WGSL sources: one file per kernel family, composed per (dimension,
//! precision) by prepending a small header.
//!
//! ```text
//! module = header(DIM, real, WORKGROUP, the shared codes of codes.rs) [+ ln_real, exp_real: core::expr::wgsl_support] + prelude.wgsl [+ measure.wgsl, material.wgsl + cholesky.wgsl] + family.wgsl
//! (cholesky.wgsl is composed per square array it factors: `cholesky_over`)
//! (the coupled step: measure, barrier, coupled, coupled_solve, material, symmetric_eigen,
//! material_hessian, coupled_material)
//! ```
//! The header's `WORKGROUP` is [`ShaderFile::workgroup_size`]: entry points
//! declare `@workgroup_size(WORKGROUP)` and the host sizes its dispatches
//! with the same number (`kernel_set.rs`).

use crate::Precision;

/// Largest dimension the GPU kernels are built and tested for. Element
/// gathers use function-local arrays of (N+1)·N reals, so very large N would
/// exhaust registers; the CPU golden path has no such limit.
pub const MAX_GPU_DIM: usize = 8;

const PRELUDE: &str = include_str!("../../shaders/prelude.wgsl");
const RECORD4: &str = include_str!("../../shaders/record4.wgsl");
const RECORDS: &str = include_str!("../../shaders/records.wgsl");
const MEASURE: &str = include_str!("../../shaders/measure.wgsl");
const MATERIAL: &str = include_str!("../../shaders/material.wgsl");
const CHOLESKY: &str = include_str!("../../shaders/cholesky.wgsl");
const STEP: &str = include_str!("../../shaders/step.wgsl");
const INTEGRATE: &str = include_str!("../../shaders/integrate.wgsl");
const PROJECT: &str = include_str!("../../shaders/project.wgsl");
const PRIMAL: &str = include_str!("../../shaders/primal.wgsl");
const PRIMAL_MATERIAL: &str = include_str!("../../shaders/primal_material.wgsl");
const PRIMAL_OFF: &str = include_str!("../../shaders/primal_off.wgsl");
const FRICTION: &str = include_str!("../../shaders/friction.wgsl");
const MOTION: &str = include_str!("../../shaders/motion.wgsl");
const RESIDUAL: &str = include_str!("../../shaders/residual.wgsl");
const GUARD: &str = include_str!("../../shaders/guard.wgsl");
const CONTACT: &str = include_str!("../../shaders/contact.wgsl");
const SCAN: &str = include_str!("../../shaders/scan.wgsl");
const GRID: &str = include_str!("../../shaders/grid.wgsl");
const COLLIDE: &str = include_str!("../../shaders/collide.wgsl");
const BARRIER: &str = include_str!("../../shaders/barrier.wgsl");
const CLOSEST_POINT: &str = include_str!("../../shaders/closest_point.wgsl");
const SIMPLEX_WALK: &str = include_str!("../../shaders/simplex_walk.wgsl");
const MESH_CONTACT: &str = include_str!("../../shaders/mesh_contact.wgsl");
const MESH_OFF: &str = include_str!("../../shaders/mesh_off.wgsl");
const INCREMENTAL_POTENTIAL: &str = include_str!("../../shaders/incremental_potential.wgsl");
const COUPLED: &str = include_str!("../../shaders/coupled.wgsl");
const COUPLED_PARTICLES: &str = include_str!("../../shaders/coupled_particles.wgsl");
const COUPLED_SOLVE: &str = include_str!("../../shaders/coupled_solve.wgsl");
const SYMMETRIC_EIGEN: &str = include_str!("../../shaders/symmetric_eigen.wgsl");
const MATERIAL_HESSIAN: &str = include_str!("../../shaders/material_hessian.wgsl");
const COUPLED_MATERIAL: &str = include_str!("../../shaders/coupled_material.wgsl");
const EXPORT: &str = include_str!("../../shaders/export_positions.wgsl");

/// A kernel family: one WGSL file and its entry points.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ShaderFile {
    /// The XPBD step: `step.wgsl` (bindings, call blocks, the schedule
    /// runners) composed with the kernels' own files — `integrate.wgsl`
    /// (predict, velocity, damping), `project.wgsl` (every constraint kind),
    /// `primal.wgsl` and `primal_material.wgsl` (the update that carries
    /// the primal residual, with `symmetric_eigen.wgsl` and
    /// `material_hessian.wgsl`),
    /// `friction.wgsl` (dynamic Coulomb friction), `motion.wgsl` (pins
    /// and moving hyperplanes), `residual.wgsl`
    /// (constraint violation and its reduction), `guard.wgsl` (the
    /// read-only guards) — after `ln_f32.wgsl` / `ln_f64.wgsl`,
    /// `measure.wgsl` and `material.wgsl` (the material energy constraint).
    Step,
    /// `scan.wgsl` (after `contact.wgsl`): exclusive prefix sum of the
    /// broadphase's hash-bucket counters.
    Scan,
    /// `grid.wgsl` (after `contact.wgsl`): boxes, hashed grid and every
    /// particle's sorted contact list (broadphase).
    Grid,
    /// `collide.wgsl` (after `contact.wgsl`): one gather-Jacobi iteration
    /// of particle contact and the contact report.
    Collide,
    /// `barrier.wgsl` (+ `ln_f32.wgsl` / `ln_f64.wgsl`): per-particle
    /// barrier evaluation and step filter (incremental-potential path).
    Barrier,
    /// `incremental_potential.wgsl` after `barrier.wgsl`: the whole
    /// incremental-potential substep (predict, gradient and residual,
    /// tree reduction, filtered Newton, velocity).
    IncrementalPotential,
    /// `coupled.wgsl` (element passes), `coupled_particles.wgsl` (particle
    /// passes) and `coupled_solve.wgsl`
    /// (PCG vectors, line search, certified filter, updates, block-tree
    /// reductions) after `measure.wgsl` and `barrier.wgsl`, then
    /// `coupled_material.wgsl` (material elements) after `material.wgsl`,
    /// `symmetric_eigen.wgsl` (Jacobi, PSD projection) and
    /// `material_hessian.wgsl`: the coupled implicit step.
    Coupled,
    /// `export_positions.wgsl` alone: positions out to a caller's vertex
    /// buffer (world coordinates, f32, projected to 3 axes).
    Export,
}

impl ShaderFile {
    /// Every kernel family.
    pub const ALL: [ShaderFile; 8] = [
        ShaderFile::Step,
        ShaderFile::Scan,
        ShaderFile::Grid,
        ShaderFile::Collide,
        ShaderFile::Barrier,
        ShaderFile::IncrementalPotential,
        ShaderFile::Coupled,
        ShaderFile::Export,
    ];

    /// File name under `shaders/`.
    pub fn file_name(self) -> &'static str {
        match self {
            ShaderFile::Step => "step.wgsl",
            ShaderFile::Scan => "scan.wgsl",
            ShaderFile::Grid => "grid.wgsl",
            ShaderFile::Collide => "collide.wgsl",
            ShaderFile::Barrier => "barrier.wgsl",
            ShaderFile::IncrementalPotential => "incremental_potential.wgsl",
            ShaderFile::Coupled => "coupled.wgsl",
            ShaderFile::Export => "export_positions.wgsl",
        }
    }

    /// Entry points defined by the file.
    pub fn entry_points(self) -> &'static [&'static str] {
        match self {
            ShaderFile::Step => &[
                "particles",
                "step_small",
                "project",
                "residual",
                "reduce",
                "residual_lanes",
                "guard",
            ],
            ShaderFile::Scan => &["scan_reduce", "scan_top", "scan_apply"],
            ShaderFile::Grid => &[
                "boxes_and_bounds",
                "grid_frame",
                "bin_count",
                "bin_fill",
                "neighbours",
            ],
            ShaderFile::Collide => &[
                "contact_snapshot",
                "collide",
                "contact_report",
                "contact_report_final",
            ],
            ShaderFile::Barrier => &["evaluate", "filter_fraction", "ln_check"],
            ShaderFile::IncrementalPotential => &[
                "evaluate",
                "filter_fraction",
                "ln_check",
                "ip_predict",
                "ip_gradient",
                "ip_reduce_sum",
                "ip_reduce_max",
                "ip_newton",
                "ip_velocity",
                "ip_decide",
            ],
            ShaderFile::Coupled => &[
                "evaluate",
                "filter_fraction",
                "ln_check",
                "cp_elements",
                "cp_element_changes",
                "cp_slots",
                "cp_start",
                "cp_gradient",
                "cp_particle_curvature",
                "cp_cg_residual",
                "cp_cg_turn",
                "cp_cg_alpha",
                "cp_cg_beta",
                "cp_slope",
                "cp_trial",
                "cp_particle_changes",
                "cp_filter_particles",
                "cp_filter_pairs",
                "cp_set_x",
                "cp_finish",
                "cp_reduce",
                "cp_material_elements",
                "cp_material_changes",
                "cp_material_frames",
                "cp_material_slots",
            ],
            ShaderFile::Export => &["export_positions"],
        }
    }

    /// Workgroup size of every entry point of the file: 64 for the step
    /// and contact kernels (64 and 256 measure within noise of each other
    /// on lavapipe, docs/performance.md; 64 spreads a small dispatch over
    /// more of a GPU's multiprocessors), 256 for the scan (a block of
    /// 8 × 256 counters). [`compose`] writes it into the header.
    pub fn workgroup_size(self) -> u32 {
        match self {
            ShaderFile::Scan => 256,
            _ => 64,
        }
    }

    fn body(self) -> &'static [&'static str] {
        match self {
            ShaderFile::Step => &[
                PRELUDE, MEASURE, MATERIAL, STEP, INTEGRATE, PROJECT, FRICTION, MOTION, RESIDUAL,
                GUARD,
            ],
            ShaderFile::Scan => &[PRELUDE, CONTACT, SCAN],
            ShaderFile::Grid => &[PRELUDE, CONTACT, GRID],
            ShaderFile::Collide => &[PRELUDE, CONTACT, COLLIDE],
            ShaderFile::Barrier => &[BARRIER, CLOSEST_POINT, SIMPLEX_WALK],
            ShaderFile::IncrementalPotential => {
                &[BARRIER, CLOSEST_POINT, SIMPLEX_WALK, INCREMENTAL_POTENTIAL]
            }
            ShaderFile::Coupled => &[
                MEASURE,
                BARRIER,
                CLOSEST_POINT,
                SIMPLEX_WALK,
                COUPLED,
                COUPLED_PARTICLES,
                COUPLED_SOLVE,
                MATERIAL,
                SYMMETRIC_EIGEN,
                MATERIAL_HESSIAN,
                COUPLED_MATERIAL,
            ],
            ShaderFile::Export => &[EXPORT],
        }
    }
}

/// The complete WGSL module of `file` for dimension `dim` and `precision`
/// (the step module without expression families).
pub fn compose(file: ShaderFile, dim: usize, precision: Precision) -> String {
    compose_with(file, dim, precision, None)
}

/// [`compose`], the step module followed by `generated` (a plan's
/// expression families, `xpbd/expression.rs`; `None`: none), or the
/// coupled module followed by its expression springs
/// (`coupled/expression.rs`).
pub(crate) fn compose_with(
    file: ShaderFile,
    dim: usize,
    precision: Precision,
    generated: Option<&str>,
) -> String {
    let real_max = match precision {
        Precision::F32 => "3.4028234663852886e38",
        Precision::F64 => "1.7976931348623157e308",
    };
    let mut source = format!(
        "// {file} for DIM = {dim}, real = {precision} (generated header)\n\
         alias real = {precision};\n\
         const DIM: u32 = {dim}u;\n\
         const POINTS: u32 = {points}u;\n\
         const MAT: u32 = {mat}u;\n\
         const MINOR: u32 = {minor}u;\n\
         const REAL_MAX: real = {real_max};\n\
         const REAL_EPSILON: real = {real_epsilon:e};\n\
         const WORKGROUP: u32 = {workgroup}u;\n\
         const VEC: u32 = {vec}u;\n\n{codes}\n",
        file = file.file_name(),
        real_epsilon = precision.epsilon(),
        points = (dim + 1) * dim,
        // A coupled module with expression families keeps their dense
        // (arity·N)² blocks (arity ≤ N + 1) in the HESS = MAT² arrays.
        mat = if file == ShaderFile::Coupled && generated.is_some() {
            (dim + 1) * dim
        } else {
            dim * dim
        },
        minor = (dim.saturating_sub(1) * dim.saturating_sub(1)).max(1),
        workgroup = file.workgroup_size(),
        vec = crate::layout::record_words(dim),
        codes = crate::codes::wgsl_header(),
    );
    if matches!(
        file,
        ShaderFile::Step
            | ShaderFile::Barrier
            | ShaderFile::IncrementalPotential
            | ShaderFile::Coupled
    ) {
        // ln_real and exp_real, their constants written from core's tables
        // (expressions call both; the barrier and material kernels ln).
        source.push_str(&hyperpbd_core::expr::wgsl_support(precision));
        source.push('\n');
    }
    for &part in file.body() {
        source.push_str(part);
        source.push('\n');
        if std::ptr::eq(part, MATERIAL) {
            source.push_str(&cholesky_over("material_cholesky", "array<real, MAT>"));
            source.push('\n');
        }
        if std::ptr::eq(part, PRELUDE) {
            // The record accessors of this dimension (prelude.wgsl).
            source.push_str(if crate::layout::record_words(dim) == 1 {
                RECORD4
            } else {
                RECORDS
            });
            source.push('\n');
        }
    }
    if file == ShaderFile::Coupled {
        match generated {
            Some(generated) => source.push_str(generated),
            None => source.push_str(&crate::coupled::expression::generated_for(
                &[],
                dim,
                precision,
            )),
        }
    }
    if file == ShaderFile::Step {
        match generated {
            Some(generated) => source.push_str(generated),
            None => {
                source.push_str(&crate::xpbd::expression::generated_for(
                    &[],
                    dim,
                    precision,
                    false,
                ));
                source.push_str(&primal_source(false, false));
                source.push_str(&mesh_source(false));
            }
        }
    }
    source
}

/// Parses and validates a composed module with naga (no GPU needed).
pub fn validate(
    source: &str,
    precision: Precision,
) -> Result<(naga::Module, naga::valid::ModuleInfo), String> {
    let module = naga::front::wgsl::parse_str(source).map_err(|e| e.emit_to_string(source))?;
    let mut capabilities = naga::valid::Capabilities::default();
    if precision == Precision::F64 {
        capabilities |= naga::valid::Capabilities::FLOAT64;
    }
    let info = naga::valid::Validator::new(naga::valid::ValidationFlags::all(), capabilities)
        .validate(&module)
        .map_err(|e| e.emit_to_string(source))?;
    Ok((module, info))
}

/// The step module's simplex-mesh contact (`meshes`: the plan has mesh
/// families): `mesh_contact.wgsl` with the closest point and the
/// hierarchy walk it reads, else the stand-ins of `mesh_off.wgsl` (no
/// mesh bindings).
pub(crate) fn mesh_source(meshes: bool) -> String {
    match meshes {
        true => [MESH_CONTACT, CLOSEST_POINT, SIMPLEX_WALK].join("\n"),
        false => MESH_OFF.to_string(),
    }
}

/// The step module's part of the update that carries the primal residual
/// (`primal`: the plan uses it; `materials`: it has material families):
/// `primal.wgsl`, with `symmetric_eigen.wgsl`, `material_hessian.wgsl` and
/// `primal_material.wgsl` for materials; else the stand-ins of
/// `primal_off.wgsl` (and a failing `primal_material_element`), so a
/// plan's pipelines compile only what its calls can reach.
pub(crate) fn primal_source(primal: bool, materials: bool) -> String {
    let mut s = String::from(if primal { PRIMAL } else { PRIMAL_OFF });
    if primal && materials {
        for part in [SYMMETRIC_EIGEN, MATERIAL_HESSIAN, PRIMAL_MATERIAL] {
            s.push('\n');
            s.push_str(part);
        }
        s.push('\n');
        s.push_str(&cholesky_over("primal_cholesky", "array<real, SYS>"));
    } else {
        s.push_str("\nfn primal_material_element(t: u32) {\n    fail(call.first + t);\n}\n");
    }
    s
}

/// `cholesky.wgsl` as the function `name` over `array` (a square array
/// type of the module, e.g. `array<real, MAT>`): the one Cholesky of the
/// kernels, composed once per array it factors.
fn cholesky_over(name: &str, array: &str) -> String {
    CHOLESKY
        .replace("CHOLESKY_ARRAY", array)
        .replace("CHOLESKY_NAME", name)
}
