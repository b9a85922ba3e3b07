//! The linear patch test on the XPBD path: how far the interior settles
//! from the exact equilibrium F X, and XPBD's primal residual at that fixed
//! point (docs/equilibria.md). Prints markdown tables.
//!
//! ```text
//! cargo run --release --example patch_residual
//! ```
//! Per case: 2 s (120 frames of 1/60 s) from the interior at X (the
//! boundary on F X), at rest, then
//! - offset   max over interior nodes of |x_i − F X_i|
//! - |q|/h²   max over interior nodes of |∇C(x)ᵀλ|_i / h²: the net constraint
//!   force XPBD's last substep applied at a node, in newtons (λ is
//!   force · h²); at backward Euler's fixed point it equals
//!   m (x − x~)/h², which is ≈ 0 at rest
//! - m|v|/h   max over interior nodes of m_i |v_i| / h: the inertial term's
//!   size (x − x~ ≈ −h v at rest), in newtons
//! - |∇W|     max over interior nodes of the elastic force of the same
//!   elements at x (what backward Euler balances), in newtons
//! - ms/frame wall time of one frame (one thread)
//! - with "primal_residual": the same offset and time with the update that
//!   carries the residual (`cpu/src/consistent.rs`), from the same start
//!
//! and the cost of that update on the 128² cloth (distance links, one
//! thread): median ms per step of the two updates, interleaved.

use hyperpbd::builders::{Patch, PatchSpec};
use hyperpbd::{
    Backend, ConstraintKind, CpuBackend, Plan, Solver, XpbdSettings, constraint_force,
    elastic_force,
};
use std::time::Instant;

const FRAMES: usize = 120;

struct Case {
    dim: usize,
    law: ConstraintKind,
    substeps: u32,
    iterations: u32,
    youngs: f64,
}

struct Row {
    /// Offset and ms/frame of the update with the primal residual.
    carried: (f64, f64),
    offset: f64,
    force: f64,
    inertia: f64,
    elastic: f64,
    ms: f64,
}

fn law_name(law: ConstraintKind) -> &'static str {
    match law {
        ConstraintKind::NeoHookean => "Neo-Hookean",
        _ => "StVK",
    }
}

fn patch(case: &Case, implicit: bool) -> Patch {
    let mut spec = PatchSpec::stressed(case.dim, case.law);
    spec.youngs_modulus = case.youngs;
    if implicit {
        let mut patch = Patch::new(&spec, 1.0 / 60.0, 1, 1);
        patch.use_implicit_path();
        return patch;
    }
    Patch::new(&spec, 1.0 / 60.0, case.substeps, case.iterations)
}

fn norm_at(v: &[f64], i: usize, dim: usize) -> f64 {
    v[i * dim..(i + 1) * dim]
        .iter()
        .map(|a| a * a)
        .sum::<f64>()
        .sqrt()
}

/// Offset from F X and ms/frame after FRAMES frames from X at rest (the
/// boundary on F X).
fn settle(patch: &Patch) -> (f64, f64, CpuBackend, Plan) {
    let plan = Plan::compile(&patch.scene).expect("patch compiles");
    let mut cpu = CpuBackend::with_threads(plan.clone(), &patch.state(false), 1).expect("loads");
    let start = Instant::now();
    for frame in 0..FRAMES {
        cpu.step().unwrap_or_else(|e| panic!("frame {frame}: {e}"));
    }
    let ms = start.elapsed().as_secs_f64() * 1e3 / FRAMES as f64;
    let state = cpu.read_state().expect("state");
    (patch.interior_error(&state.positions), ms, cpu, plan)
}

fn run(case: &Case, implicit: bool) -> Row {
    let carried = if implicit {
        (f64::NAN, f64::NAN)
    } else {
        let mut patch = patch(case, false);
        patch.scene.solver = Solver::Xpbd(XpbdSettings {
            primal_residual: true,
        });
        let (offset, ms, _, _) = settle(&patch);
        (offset, ms)
    };
    let patch = patch(case, implicit);
    let (offset, ms, mut cpu, plan) = settle(&patch);
    let (dim, h) = (plan.dim, plan.h);
    let state = cpu.read_state().expect("state");
    let interior: Vec<usize> = (0..patch.boundary.len())
        .filter(|&i| !patch.boundary[i])
        .collect();
    let max_over = |v: &[f64], scale: &dyn Fn(usize) -> f64| {
        interior
            .iter()
            .map(|&i| norm_at(v, i, dim) * scale(i))
            .fold(0.0, f64::max)
    };
    let inertia = max_over(&state.velocities, &|i| 1.0 / (plan.inverse_mass[i] * h));
    let (force, elastic) = if implicit {
        (f64::NAN, f64::NAN)
    } else {
        let lambda: Vec<&[f64]> = (0..plan.families.len())
            .map(|f| cpu.multipliers(f).expect("family"))
            .collect();
        let q = constraint_force(&plan, &state.positions, &lambda).expect("finite");
        let elastic = elastic_force(&plan, &state.positions).expect("not refused");
        (
            max_over(&q, &|_| 1.0 / (h * h)),
            max_over(&elastic, &|_| 1.0),
        )
    };
    Row {
        carried,
        offset,
        force,
        inertia,
        elastic,
        ms,
    }
}

fn print_rows(title: &str, cases: &[(String, Case)]) {
    println!("\n**{title}**\n");
    println!(
        "| case | offset (m) | ‖∇Cᵀλ‖/h² (N) | m‖v‖/h (N) | ‖∇W‖ (N) | ms/frame | primal_residual: offset (m) | ms/frame |"
    );
    println!("|---|---:|---:|---:|---:|---:|---:|---:|");
    for (name, case) in cases {
        let r = run(case, false);
        println!(
            "| {name} | {:.2e} | {:.2e} | {:.1e} | {:.2e} | {:.2} | {:.1e} | {:.2} |",
            r.offset, r.force, r.inertia, r.elastic, r.ms, r.carried.0, r.carried.1
        );
    }
}

fn base(dim: usize, law: ConstraintKind) -> Case {
    Case {
        dim,
        law,
        substeps: 10,
        iterations: 10,
        youngs: 1e5,
    }
}

/// Median ms per step of the 128² peer cloth with the standard update and
/// with the primal residual, interleaved (one thread), for `iterations`
/// per substep (None: as authored).
fn cloth_cost(iterations: Option<u32>) {
    let mut scene = hyperpbd::scenes::peer_cloth(128);
    if let Some(k) = iterations {
        scene.iterations = k;
    }
    let mut carried = scene.clone();
    carried.solver = Solver::Xpbd(XpbdSettings {
        primal_residual: true,
    });
    let load = |s: &hyperpbd::Scene| {
        let plan = Plan::compile(s).expect("compiles");
        CpuBackend::with_threads(plan, &hyperpbd::State::from_scene(s), 1).expect("cpu")
    };
    let (mut a, mut b) = (load(&scene), load(&carried));
    let (mut ta, mut tb) = (Vec::new(), Vec::new());
    for round in 0..16 {
        let t = Instant::now();
        a.step().expect("standard step");
        let t_a = t.elapsed().as_secs_f64() * 1e3;
        let t = Instant::now();
        b.step().expect("primal-residual step");
        let t_b = t.elapsed().as_secs_f64() * 1e3;
        if round > 0 {
            ta.push(t_a);
            tb.push(t_b);
        }
    }
    let median = |mut v: Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    let (ma, mb) = (median(ta), median(tb));
    println!(
        "| {} × {} | {ma:.1} | {mb:.1} | {:.2} |",
        scene.substeps,
        scene.iterations,
        mb / ma
    );
}

fn main() {
    let mut laws = Vec::new();
    for dim in [2, 3, 4] {
        for law in [ConstraintKind::Stvk, ConstraintKind::NeoHookean] {
            laws.push((format!("{dim}D {}", law_name(law)), base(dim, law)));
        }
    }
    print_rows("XPBD, 10 substeps × 10 iterations, E = 1e5 Pa", &laws);
    let sweep = |f: &dyn Fn(&mut Case) -> String| {
        let mut c = base(2, ConstraintKind::Stvk);
        let name = f(&mut c);
        (name, c)
    };
    let iterations: Vec<(String, Case)> = [10, 100, 400]
        .into_iter()
        .map(|k| {
            sweep(&|c: &mut Case| {
                c.iterations = k;
                format!("2D StVK, 10 × {k}")
            })
        })
        .collect();
    print_rows("Iterations (2D StVK, 10 substeps)", &iterations);
    let substeps: Vec<(String, Case)> = [10, 30, 100]
        .into_iter()
        .map(|s| {
            sweep(&|c: &mut Case| {
                c.substeps = s;
                format!("2D StVK, {s} × 10")
            })
        })
        .collect();
    print_rows("Substeps (2D StVK, 10 iterations)", &substeps);
    let stiffness: Vec<(String, Case)> = [1e3, 1e4, 1e5]
        .into_iter()
        .map(|e| {
            sweep(&|c: &mut Case| {
                c.youngs = e;
                format!("2D StVK, E = {e:.0e}")
            })
        })
        .collect();
    print_rows("Stiffness (2D StVK, 10 × 10)", &stiffness);
    println!(
        "\n**Cost on the 128² peer cloth (CPU, one thread; median of 15 interleaved steps)**\n"
    );
    println!("| substeps × iterations | standard (ms/step) | primal_residual (ms/step) | ratio |");
    println!("|---|---:|---:|---:|");
    cloth_cost(None);
    cloth_cost(Some(10));
    println!("\n**The incremental-potential path (one minimisation per frame, no damping)**\n");
    println!("| case | offset (m) | ms/frame |");
    println!("|---|---:|---:|");
    for (name, case) in &laws {
        let r = run(case, true);
        println!("| {name} | {:.2e} | {:.2} |", r.offset, r.ms);
    }
}
