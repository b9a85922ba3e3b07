//! The one format of a measured value beside its bound:
//!
//! ```text
//! BOUND | name | measured | bound | rationale
//! ```
//! (docs/bounds.md's tables are written from these lines:
//! `cargo test --release -- --nocapture | grep '^BOUND'`).

use std::fmt::Display;

/// Prints one `BOUND` line; each field is formatted by the caller
/// (`format_args!("{x:.3e}")`, a plain number, or words such as `exact`).
pub fn print_bound(
    name: impl Display,
    measured: impl Display,
    bound: impl Display,
    rationale: impl Display,
) {
    println!("BOUND | {name} | {measured} | {bound} | {rationale}");
}

/// Prints the `BOUND` line of `measured` against `limit` (both `{:e}`) and
/// asserts `measured <= limit`.
pub fn check_bound(name: &str, measured: f64, limit: f64, why: &str) {
    print_bound(
        name,
        format_args!("{measured:e}"),
        format_args!("{limit:e}"),
        why,
    );
    assert!(
        measured <= limit,
        "{name}: {measured:e} > {limit:e} ({why})"
    );
}
