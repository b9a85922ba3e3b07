//! Parameter blocks: one per kernel call, written once at load time into
//! one buffer and selected per dispatch by a dynamic offset.
//!
//! Layout of `Params` in `shaders/prelude.wgsl` (r = 4 bytes for f32, 8 for
//! f64):
//! ```text
//! 0..32            count first elem_base slot_base arity call flags family   (u32)
//! 32               alpha_tilde h friction factor                             (real)
//! 32 + 4r          normal[DIM]                                               (real)
//! 32 + (4+DIM) r   gravity[DIM]                                              (real)
//! ```

use crate::Precision;

/// One kernel call's parameters, before encoding.
#[derive(Debug, Clone, Default)]
pub struct Params {
    pub count: u32,
    pub first: u32,
    pub elem_base: u32,
    pub slot_base: u32,
    pub arity: u32,
    pub call: u32,
    pub flags: u32,
    pub family: u32,
    pub alpha_tilde: f64,
    pub h: f64,
    pub friction: f64,
    pub factor: f64,
    pub normal: Vec<f64>,
    pub gravity: Vec<f64>,
}

/// Bytes per real.
pub fn real_size(precision: Precision) -> usize {
    match precision {
        Precision::F32 => 4,
        Precision::F64 => 8,
    }
}

/// Size of the WGSL `Params` struct.
pub fn params_size(dim: usize, precision: Precision) -> usize {
    let r = real_size(precision);
    32 + (4 + 2 * dim) * r
}

/// Appends `values` as reals of `precision`.
pub fn push_reals(out: &mut Vec<u8>, values: &[f64], precision: Precision) {
    match precision {
        Precision::F32 => {
            for &v in values {
                out.extend_from_slice(&(v as f32).to_le_bytes());
            }
        }
        Precision::F64 => {
            for &v in values {
                out.extend_from_slice(&v.to_le_bytes());
            }
        }
    }
}

/// Reads reals of `precision` back as f64.
pub fn read_reals(bytes: &[u8], precision: Precision) -> Vec<f64> {
    match precision {
        Precision::F32 => bytes
            .chunks_exact(4)
            .map(|c| f64::from(f32::from_le_bytes([c[0], c[1], c[2], c[3]])))
            .collect(),
        Precision::F64 => bytes
            .chunks_exact(8)
            .map(|c| f64::from_le_bytes([c[0], c[1], c[2], c[3], c[4], c[5], c[6], c[7]]))
            .collect(),
    }
}

impl Params {
    /// The encoded block.
    pub fn encode(&self, dim: usize, precision: Precision) -> Vec<u8> {
        let mut out = Vec::new();
        for v in [
            self.count,
            self.first,
            self.elem_base,
            self.slot_base,
            self.arity,
            self.call,
            self.flags,
            self.family,
        ] {
            out.extend_from_slice(&v.to_le_bytes());
        }
        push_reals(
            &mut out,
            &[self.alpha_tilde, self.h, self.friction, self.factor],
            precision,
        );
        let mut normal = self.normal.clone();
        normal.resize(dim, 0.0);
        let mut gravity = self.gravity.clone();
        gravity.resize(dim, 0.0);
        push_reals(&mut out, &normal, precision);
        push_reals(&mut out, &gravity, precision);
        out
    }
}
