//! Reals of a kernel's precision as device bytes and back (r = 4 bytes
//! for f32, 8 for f64, little endian).

use crate::Precision;

/// Bytes per real.
pub fn real_size(precision: Precision) -> usize {
    match precision {
        Precision::F32 => 4,
        Precision::F64 => 8,
    }
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
