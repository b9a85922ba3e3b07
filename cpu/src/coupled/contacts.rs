//! The coupled step's contact impulses at its accepted iterate, beyond the
//! obstacle barriers (`contact_forces.rs`): lagged plane friction and the
//! ball–ball barriers and pair friction of its elements.
//!
//! ```text
//! plane lag (particle i, plane o):  J_i += −∇D(x_i) h    (D the lagged friction energy),
//!                                   also on o
//! ball / pair-friction element e:   J_k += −∇_k E_e(x) h for each member k
//! ```
//! The records hold every element at the accepted iterate: the minimiser
//! evaluates them there last (`mod.rs`, step 5 or before the line search).

use super::Workspace;
use hyperpbd_core::implicit::obstacle_friction;
use hyperpbd_core::{ContactForces, IncrementalPotentialPlan, Plan};

/// Adds the lagged plane friction's and the contact elements' impulses of
/// the substep that `ws` just minimised (accepted iterate `x`).
pub(crate) fn contact_impulses(
    plan: &Plan,
    ip: &IncrementalPotentialPlan,
    ws: &Workspace,
    x: &[f64],
    impulses: &mut ContactForces,
) {
    let Some(coupled) = &ip.coupled else {
        return;
    };
    let (n, h) = (plan.dim, plan.h);
    let slip_length = coupled.slip_velocity * h;
    let particles = &ws.particles;
    let (mut gradient, mut slip, mut j) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
    for lag in &particles.lags {
        let i = lag.particle;
        let normal = &ip.obstacles.plane_normals[lag.plane * n..(lag.plane + 1) * n];
        obstacle_friction(
            normal,
            lag.force_limit,
            slip_length,
            &x[i * n..(i + 1) * n],
            &particles.start[i * n..(i + 1) * n],
            &mut gradient,
            &mut slip,
        );
        for a in 0..n {
            j[a] = -gradient[a] * h;
        }
        let o = ip.obstacles.plane_source[lag.plane] as usize;
        impulses.add_obstacle_impulse(o, i, &j);
    }
    ws.elements.contact_gradients(n, |k, gradient| {
        for a in 0..n {
            j[a] = -gradient[a] * h;
        }
        impulses.add_particle_impulse(k, &j);
    });
}
