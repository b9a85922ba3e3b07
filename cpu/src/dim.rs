//! The dimension as a compile-time constant where that pays, and a runtime
//! value otherwise — so each kernel is written once.
//!
//! A kernel is generic over [`Dim`]; [`with_dim!`] calls it with
//! `Fixed::<N>` for N = 1..=4 (loops over coordinates unroll, slice bounds
//! are known, a coordinate vector is a stack array) and with the plain
//! `usize` for any other N (a heap vector). Both run the same source line
//! by line, so they give bit-identical results.

/// A spatial dimension.
pub trait Dim: Copy + Send + Sync {
    /// A vector of N reals: `[f64; N]` or a `Vec<f64>`.
    type Vector: AsRef<[f64]> + AsMut<[f64]>;

    /// The number of coordinates.
    fn n(self) -> usize;

    /// A zero vector of N reals (kernel scratch).
    fn zeros(self) -> Self::Vector;
}

/// A dimension known at compile time.
#[derive(Debug, Clone, Copy)]
pub struct Fixed<const D: usize>;

impl<const D: usize> Dim for Fixed<D> {
    type Vector = [f64; D];

    #[inline(always)]
    fn n(self) -> usize {
        D
    }

    #[inline(always)]
    fn zeros(self) -> [f64; D] {
        [0.0; D]
    }
}

impl Dim for usize {
    type Vector = Vec<f64>;

    #[inline(always)]
    fn n(self) -> usize {
        self
    }

    fn zeros(self) -> Vec<f64> {
        vec![0.0; self]
    }
}

/// `with_dim!(dim, kernel(args…))` calls `kernel(d, args…)` with `d` a
/// [`Fixed`] dimension for 1..=4 and the runtime `usize` otherwise.
macro_rules! with_dim {
    ($dim:expr, $kernel:ident ( $($arg:expr),* $(,)? )) => {
        match $dim {
            1 => $kernel($crate::dim::Fixed::<1>, $($arg),*),
            2 => $kernel($crate::dim::Fixed::<2>, $($arg),*),
            3 => $kernel($crate::dim::Fixed::<3>, $($arg),*),
            4 => $kernel($crate::dim::Fixed::<4>, $($arg),*),
            n => $kernel(n, $($arg),*),
        }
    };
}
pub(crate) use with_dim;
