//! `hyperpbd plan` (and the demo's header): a compiled plan in words.
//!
//! ```text
//! dim, particles (dynamic / fixed), dt, substeps, iterations, h
//! stages per substep         predict -> project -> velocity -> …
//! predict terms              gravity on/off, external force on/off
//! family i LABEL KIND        elements, compliance, colours [sizes], friction
//! incremental potential      κ, d^, criterion ≤ tolerance, budget, obstacles
//! damping, particle contacts when the plan has them
//! guards, adaptive           when the scene has them
//! kernel calls per step      per stage;  constraint projections per step
//! ```

use hyperpbd::{FamilyKind, Plan};
use std::fmt::Write;

/// The plan in words: stages, families, colors, counts.
pub fn describe(plan: &Plan) -> String {
    let mut s = String::new();
    let dynamic = plan.inverse_mass.iter().filter(|&&w| w > 0.0).count();
    let _ = writeln!(
        s,
        "dim {}  particles {} ({} dynamic, {} fixed)  dt {}  substeps {}  iterations {}  h {:e}",
        plan.dim,
        plan.particle_count(),
        dynamic,
        plan.particle_count() - dynamic,
        plan.dt,
        plan.substeps,
        plan.iterations,
        plan.h
    );
    let names: Vec<&str> = plan.stages.iter().map(|s| s.as_str()).collect();
    let _ = writeln!(
        s,
        "stages per substep: {}",
        if names.is_empty() {
            "(none: nothing moves)".to_string()
        } else {
            names.join(" -> ")
        }
    );
    let _ = writeln!(
        s,
        "predict terms: gravity {}, external force {}",
        on_off(plan.predict.gravity),
        on_off(plan.predict.force)
    );
    for (i, f) in plan.families.iter().enumerate() {
        let sizes: Vec<String> = (0..f.color_count())
            .map(|c| f.color(c).len().to_string())
            .collect();
        let _ = write!(
            s,
            "family {i} {} {}: {} elements, compliance {:e}, {} colors [{}]",
            f.label,
            f.kind.name(),
            f.len(),
            f.compliance,
            f.color_count(),
            sizes.join(", ")
        );
        if let FamilyKind::HyperplaneContact { friction, .. } = f.kind {
            let _ = write!(s, ", friction {friction}");
        }
        if let FamilyKind::Material { material, .. } = &f.kind {
            let _ = write!(
                s,
                ", Lamé μ {:e} λ {:e}",
                material.lame.mu, material.lame.lambda
            );
        }
        if let FamilyKind::Expression(kind) = &f.kind {
            let stats = kind.stats();
            let hessian = stats
                .hessian_ops
                .map_or("over the limits".to_string(), |ops| ops.to_string());
            let _ = write!(
                s,
                ", relation {}, arity {}: {} ops (value), {} ops (value + ∇C, {} entries), \
                 {hessian} ops (+ ∇²C, {} entries)",
                kind.relation.as_str(),
                kind.arity,
                stats.value_ops,
                stats.gradient_ops,
                stats.gradient_size,
                stats.hessian_size
            );
            if kind.element_constants > 0 {
                let _ = write!(s, ", {} constants per element", kind.element_constants);
            }
        }
        s.push('\n');
    }
    for m in &plan.lumped_mass {
        let _ = writeln!(
            s,
            "lumped mass {}: density {}, element total {}, vertex total {}",
            m.label, m.density, m.element_total, m.vertex_total
        );
    }
    if let Some(ip) = plan.incremental_potential() {
        let _ = writeln!(
            s,
            "incremental potential: κ {:e}, d^ {:e}, {} ≤ {:e}, max {} iterations, {} planes, {} simplices",
            ip.law.stiffness,
            ip.law.activation_distance,
            ip.convergence.as_str(),
            ip.convergence.tolerance(),
            ip.max_iterations,
            ip.obstacles.plane_count(),
            ip.obstacles.simplex_count()
        );
    }
    if let Some((rate, factor)) = plan.damping {
        let _ = writeln!(s, "damping: rate {rate} 1/s, factor {factor} per substep");
    }
    if let Some(c) = plan.contacts {
        let _ = writeln!(
            s,
            "particle contacts: friction {}, margin {}, sort-and-sweep + gather-Jacobi",
            c.friction, c.margin
        );
    }
    if let Some(g) = &plan.guards {
        let mut checks = Vec::new();
        if g.orientation {
            checks.push("orientation".to_string());
        }
        if let Some(r) = g.min_measure_ratio {
            checks.push(format!("min_measure_ratio {r}"));
        }
        if let Some(v) = g.max_speed {
            checks.push(format!("max_speed {v}"));
        }
        let _ = write!(s, "guards: {} after every substep", checks.join(", "));
        if let Some(a) = plan.adaptive {
            let k = a.max_subdivisions;
            let _ = write!(
                s,
                "; adaptive: a rejected step retried with up to {} substeps (2^{k} times)",
                u64::from(plan.substeps) << k
            );
        }
        s.push('\n');
    }
    let counts: Vec<String> = plan
        .kernel_counts()
        .iter()
        .map(|(stage, n)| format!("{stage} {n}"))
        .collect();
    let _ = writeln!(s, "kernel calls per step: {}", counts.join(", "));
    let _ = writeln!(
        s,
        "constraint projections per step: {}",
        plan.projections_per_step()
    );
    s
}

fn on_off(b: bool) -> &'static str {
    if b { "on" } else { "off" }
}
