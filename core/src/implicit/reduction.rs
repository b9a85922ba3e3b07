//! The one reduction tree of the implicit path: pairwise halving inside
//! fixed-size blocks, level by level — what one GPU workgroup of
//! [`REDUCTION_BLOCK`] invocations does in shared memory, written out so
//! the CPU computes the same bits.
//!
//! ```text
//! B = REDUCTION_BLOCK (64, a power of two)
//! level:  values v_0 … v_{n−1}  →  partials P_0 … P_{⌈n/B⌉−1}
//!   block b:  s[t] = v_{bB + t}  (t < B; s[t] = pad past n)
//!             for stride = B/2, B/4, …, 1:  for t < stride:  s[t] = s[t] ⊕ s[t + stride]
//!             P_b = s[0]
//! repeat on the partials until one value remains;  n = 0 → pad
//! sum: ⊕ = +, pad = +0.0           max: ⊕ = max, pad = 0.0 (for values ≥ 0)
//! dot product of two per-particle vectors (N components each):
//!   term_i = 0;  term_i += a[i N + c] b[i N + c]   (c ascending);   sum over i as above
//! ```
//! One level is one dispatch of ⌈n/B⌉ workgroups; n = 10⁶ takes 4 levels.
//! The tree depends only on n, never on threads or scheduling.

/// Values per block (a GPU workgroup).
pub const REDUCTION_BLOCK: usize = 64;

/// One level-by-level block reduction of `values` (see the module docs);
/// `scratch` holds the partials.
fn block_tree(values: &[f64], scratch: &mut Vec<f64>, pad: f64, op: fn(f64, f64) -> f64) -> f64 {
    if values.is_empty() {
        return pad;
    }
    scratch.clear();
    scratch.extend_from_slice(values);
    let mut block = [0.0f64; REDUCTION_BLOCK];
    let mut n = scratch.len();
    loop {
        let blocks = n.div_ceil(REDUCTION_BLOCK);
        for b in 0..blocks {
            for t in 0..REDUCTION_BLOCK {
                let i = b * REDUCTION_BLOCK + t;
                block[t] = if i < n { scratch[i] } else { pad };
            }
            let mut stride = REDUCTION_BLOCK / 2;
            while stride > 0 {
                for t in 0..stride {
                    block[t] = op(block[t], block[t + stride]);
                }
                stride /= 2;
            }
            scratch[b] = block[0];
        }
        n = blocks;
        if n == 1 {
            return scratch[0];
        }
    }
}

fn add(a: f64, b: f64) -> f64 {
    a + b
}

fn maximum(a: f64, b: f64) -> f64 {
    a.max(b)
}

/// Σ values by the block tree (0 for none).
pub fn block_tree_sum(values: &[f64], scratch: &mut Vec<f64>) -> f64 {
    block_tree(values, scratch, 0.0, add)
}

/// max values by the block tree, for values ≥ 0 (0 for none).
pub fn block_tree_max(values: &[f64], scratch: &mut Vec<f64>) -> f64 {
    block_tree(values, scratch, 0.0, maximum)
}

/// a·b for vectors of `dim` components per particle: per-particle terms in
/// component order (into `terms`), then [`block_tree_sum`].
pub fn tree_dot(
    a: &[f64],
    b: &[f64],
    dim: usize,
    terms: &mut Vec<f64>,
    scratch: &mut Vec<f64>,
) -> f64 {
    let count = a.len() / dim;
    terms.clear();
    for i in 0..count {
        let mut s = 0.0;
        for c in 0..dim {
            s += a[i * dim + c] * b[i * dim + c];
        }
        terms.push(s);
    }
    block_tree_sum(terms, scratch)
}
