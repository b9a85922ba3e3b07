//! The coupled step's contact impulses at its accepted iterate, beyond the
//! obstacle barriers (`contact_forces.rs`): lagged obstacle friction and the
//! ball–ball barriers and pair friction of its elements.
//!
//! ```text
//! obstacle lag (particle i, plane or simplex slot o):  J_i += −∇D(x_i) h
//!                                   (D the lagged friction energy), also on o's authored obstacle
//! ball / pair-friction element e:   J_k += −∇_k E_e(x) h for each member k
//! ```
//! The records hold every element at the accepted iterate: the minimiser
//! evaluates them there last (`mod.rs`, step 5 or before the line search).

use super::Workspace;
use hyperpbd_core::implicit::obstacle_friction;
use hyperpbd_core::{ContactForces, IncrementalPotentialPlan, Plan};

/// Adds the lagged obstacle friction's and the contact elements' impulses of
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
    for (l, lag) in particles.lags.iter().enumerate() {
        let i = lag.particle;
        let normal = particles.lag_normal(l, n);
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
        let o = ip.obstacles.source(lag.obstacle) as usize;
        impulses.add_obstacle_impulse(o, i, &j);
    }
    ws.elements.contact_gradients(n, |k, gradient| {
        for a in 0..n {
            j[a] = -gradient[a] * h;
        }
        impulses.add_particle_impulse(k, &j);
    });
}
