//! Broadphase: axis-aligned boxes and the candidate pairs whose boxes
//! overlap.
//!
//! ```text
//! boxes     particle i:  [x_i − (r_i + m), x_i + (r_i + m)]        (static)
//!                        [min(x_i, y_i) − (r_i + m), max(x_i, y_i) + (r_i + m)]
//!                                         (swept: start x, predicted end y)
//!           simplex s:   [min_v x_v − m, max_v x_v + m]
//! overlap   closed intervals on every axis: min_i ≤ max_j and min_j ≤ max_i
//! pairs     (i, j) with i < j, sorted lexicographically (canonical order)
//! ```
//! Three searches produce the pair list: [`exhaustive_pairs`] (the O(n²)
//! reference and oracle), [`sweep_pairs`] (sort-and-sweep along one axis)
//! and [`grid_pairs`] (a uniform grid queried box by box, which the CPU
//! backend runs on every core). They return identical lists on the same
//! boxes; the GPU sweep (crate `hyperpbd-gpu`) runs the sort-and-sweep
//! rule with the same keys and is held to the same equality.

mod aabb;
mod exhaustive;
mod grid;
mod keys;
mod lists;
mod sweep;

pub use aabb::{Aabbs, swept_boxes};
pub use exhaustive::exhaustive_pairs;
pub use grid::{BoxGrid, grid_pairs};
pub use keys::{F32_MIN_NORMAL, key_down, key_up, sortable_bits};
pub use lists::{contact_lists, contact_lists_into};
pub use sweep::{sweep_axis, sweep_pairs};

/// A candidate pair (i, j), i < j.
pub type Pair = [u32; 2];
