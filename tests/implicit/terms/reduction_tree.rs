//! The block reduction tree (sum, max, dot) against a recursive reference.

use super::*;

/// The halving tree of one block, written recursively (reference).
fn halving(mut s: Vec<f64>, op: fn(f64, f64) -> f64) -> f64 {
    if s.len() == 1 {
        return s[0];
    }
    let half = s.len() / 2;
    let next: Vec<f64> = (0..half).map(|t| op(s[t], s[t + half])).collect();
    s.truncate(0);
    halving(next, op)
}

fn reference_tree(values: &[f64], pad: f64, op: fn(f64, f64) -> f64) -> f64 {
    if values.is_empty() {
        return pad;
    }
    let partials: Vec<f64> = values
        .chunks(64)
        .map(|c| {
            let mut s = c.to_vec();
            s.resize(64, pad);
            halving(s, op)
        })
        .collect();
    if partials.len() == 1 {
        partials[0]
    } else {
        reference_tree(&partials, pad, op)
    }
}

#[test]
fn block_reduction_tree_is_the_documented_one() {
    let mut rng = Lcg(1606);
    let mut scratch = Vec::new();
    for n in [
        0, 1, 2, 63, 64, 65, 127, 128, 129, 4095, 4096, 4097, 300_001,
    ] {
        let values: Vec<f64> = (0..n).map(|_| rng.next() * 10f64.powi(n % 7)).collect();
        let sum = block_tree_sum(&values, &mut scratch);
        assert_eq!(
            sum.to_bits(),
            reference_tree(&values, 0.0, |a, b| a + b).to_bits(),
            "n = {n}"
        );
        let abs: Vec<f64> = values.iter().map(|v| v.abs()).collect();
        let max = block_tree_max(&abs, &mut scratch);
        assert_eq!(max, abs.iter().fold(0.0f64, |m, v| m.max(*v)));
        let levels = (n.max(2) as f64).log2().ceil() + 6.0;
        let exact: f64 = values.iter().map(|v| v.abs()).sum();
        let naive: f64 = values.iter().sum();
        assert!(
            (sum - naive).abs() <= 2.0 * levels * EPS * exact + 1e-300,
            "n = {n}"
        );
    }
    let a: Vec<f64> = (0..30).map(|i| i as f64).collect();
    let dot = tree_dot(&a, &a, 3, &mut Vec::new(), &mut scratch);
    assert_eq!(dot, (0..30).map(|i| (i * i) as f64).sum::<f64>());
}
