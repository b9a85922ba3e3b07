//! Analytic anchors: the CPU golden path against closed forms.
//!
//! Every assertion states its bound and the rationale for it next to the
//! check, and prints `measured / bound`. Bounds are derived from the
//! algorithm in DESIGN.md ("The golden algorithms") and f64 rounding
//! (u = 2^-53 per correctly rounded operation); none is tuned to what the
//! code happens to produce. Run with `cargo test --release --test cpu
//! -- analytic:: --nocapture` to see the measured values.

use crate::common::bound;
use crate::support;

mod damping;
mod free_fall;
mod hanging_chain;
mod incline;
mod patch;
mod pendulum;
mod resting_contact;
mod scenes;

use hyperpbd::builders::ChainSpec;
use hyperpbd::{ConstraintFamily, ConstraintKind, Particle, SceneBuilder, State};
use support::{
    U, all_finite, backend, dot, fit_quadratic, max_abs, norm, scale, state, step, sub, unit,
    zero_crossings,
};

const G: f64 = 9.81;
