//! The floating-point precision a backend computes in.
//!
//! ```text
//! F32   ε = 2^-23 (f32::EPSILON)   GPU kernels, every adapter
//! F64   ε = 2^-52 (f64::EPSILON)   the CPU golden path; GPU kernels where
//!                                  the adapter offers SHADER_F64
//! ```
//! One type for the whole workspace: the GPU backend picks its kernels and
//! device features by it, the differential error models take their ε from
//! it.

use std::fmt;
use std::str::FromStr;

/// The precision kernels run in.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Precision {
    /// `f32` storage and arithmetic.
    F32,
    /// `f64` storage and arithmetic.
    F64,
}

impl Precision {
    /// Machine epsilon ε of this precision (the spacing of floats at 1).
    pub fn epsilon(self) -> f64 {
        match self {
            Precision::F32 => f64::from(f32::EPSILON),
            Precision::F64 => f64::EPSILON,
        }
    }

    /// `"f32"` or `"f64"`, as written in WGSL and in reports.
    pub fn as_str(self) -> &'static str {
        match self {
            Precision::F32 => "f32",
            Precision::F64 => "f64",
        }
    }
}

impl fmt::Display for Precision {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

impl FromStr for Precision {
    type Err = String;

    /// `f32` or `f64`.
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "f32" => Ok(Precision::F32),
            "f64" => Ok(Precision::F64),
            _ => Err(format!("unknown precision {s:?}; precisions: f32, f64")),
        }
    }
}
