//! The test data and the host reference each candidate is checked against.

use super::*;
/// Deterministic jitter in [−0.5, 0.5).
pub(crate) fn jitter(k: usize) -> f64 {
    let mut s = (k as u32)
        .wrapping_mul(747_796_405)
        .wrapping_add(2_891_336_453);
    s = ((s >> ((s >> 28) + 4)) ^ s).wrapping_mul(277_803_737);
    s = (s >> 22) ^ s;
    f64::from(s) / f64::from(u32::MAX) - 0.5
}

/// Initial data: a jittered 256² grid, velocities, every 97th particle
/// fixed, one colour of horizontal edges.
pub(crate) struct Data {
    pub(crate) x: Vec<f64>,
    pub(crate) v: Vec<f64>,
    pub(crate) w: Vec<f64>,
    pub(crate) s: Vec<f64>,
    pub(crate) edges: Vec<u32>,
    pub(crate) rest: Vec<f64>,
}

pub(crate) fn data() -> Data {
    let spacing = 1.0 / (SIDE - 1) as f64;
    let mut x = vec![0.0; 3 * N];
    let mut v = vec![0.0; 3 * N];
    for i in 0..N {
        let (r, c) = (i / SIDE, i % SIDE);
        x[3 * i] = c as f64 * spacing + 0.1 * spacing * jitter(3 * i);
        x[3 * i + 1] = 1.0 + 0.1 * spacing * jitter(3 * i + 1);
        x[3 * i + 2] = r as f64 * spacing + 0.1 * spacing * jitter(3 * i + 2);
        for a in 0..3 {
            v[3 * i + a] = jitter(7 * i + a + 11);
        }
    }
    let w = (0..N)
        .map(|i| {
            if i % 97 == 0 {
                0.0
            } else {
                1.0 + 0.5 * jitter(5 * i)
            }
        })
        .collect();
    let s = vec![1.0; N];
    let mut edges = Vec::with_capacity(2 * EDGES);
    for r in 0..SIDE {
        for c in (0..SIDE).step_by(2) {
            edges.push((r * SIDE + c) as u32);
            edges.push((r * SIDE + c + 1) as u32);
        }
    }
    let rest = vec![spacing; EDGES];
    Data {
        x,
        v,
        w,
        s,
        edges,
        rest,
    }
}

/// Rounds through the precision (f32 data is f32 from the start).
pub(crate) fn round(values: &[f64], precision: Precision) -> Vec<f64> {
    match precision {
        Precision::F32 => values.iter().map(|&v| f64::from(v as f32)).collect(),
        Precision::F64 => values.to_vec(),
    }
}

/// The host reference of one call (in the precision's arithmetic).
pub(crate) fn reference(
    kernel: Kernel,
    precision: Precision,
    d: &Data,
) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    macro_rules! run {
        ($t:ty) => {{
            let r = |v: f64| v as $t;
            let x0: Vec<$t> = d.x.iter().map(|&v| r(v)).collect();
            let mut x = x0.clone();
            let mut v: Vec<$t> = d.v.iter().map(|&v| r(v)).collect();
            let mut p = vec![0.0 as $t; 3 * N];
            let h = r(H);
            match kernel {
                Kernel::Copy => p.copy_from_slice(&x),
                Kernel::Predict => {
                    p.copy_from_slice(&x);
                    for i in (0..N).filter(|&i| d.w[i] != 0.0) {
                        for a in 0..3 {
                            v[3 * i + a] += h * (r(d.s[i]) * r(G[a]));
                            x[3 * i + a] += h * v[3 * i + a];
                        }
                    }
                }
                Kernel::Velocity => {
                    // p = x0, x = x0 + jitter: v = (x − p) / h.
                    p.copy_from_slice(&x);
                    for k in 0..3 * N {
                        x[k] += r(1e-3 * jitter(k + 5));
                    }
                    for i in (0..N).filter(|&i| d.w[i] != 0.0) {
                        for a in 0..3 {
                            v[3 * i + a] = (x[3 * i + a] - p[3 * i + a]) / h;
                        }
                    }
                }
                Kernel::Project => {
                    let w: Vec<$t> = d.w.iter().map(|&v| r(v)).collect();
                    for e in 0..EDGES {
                        let (i, j) = (d.edges[2 * e] as usize, d.edges[2 * e + 1] as usize);
                        let mut dv = [0.0 as $t; 3];
                        for a in 0..3 {
                            dv[a] = x[3 * j + a] - x[3 * i + a];
                        }
                        let len = (dv[0] * dv[0] + dv[1] * dv[1] + dv[2] * dv[2]).sqrt();
                        let wsum = w[i] + w[j];
                        if len.is_nan() || len <= 0.0 || wsum == 0.0 {
                            continue;
                        }
                        let alpha = r(1e-7) / (h * h);
                        let dl = (-(len - r(d.rest[e])) - alpha * 0.0) / (wsum + alpha);
                        let inv = 1.0 / len;
                        for a in 0..3 {
                            let unit = dv[a] * inv;
                            if w[i] != 0.0 {
                                x[3 * i + a] += w[i] * -unit * dl;
                            }
                            if w[j] != 0.0 {
                                x[3 * j + a] += w[j] * unit * dl;
                            }
                        }
                    }
                }
            }
            let back = |v: &[$t]| v.iter().map(|&c| c as f64).collect::<Vec<f64>>();
            (back(&x), back(&v), back(&p))
        }};
    }
    match precision {
        Precision::F32 => run!(f32),
        Precision::F64 => run!(f64),
    }
}

pub(crate) fn reals(values: &[f64], precision: Precision) -> Vec<u8> {
    let mut out = Vec::new();
    hyperpbd::gpu::push_reals(&mut out, values, precision);
    out
}

pub(crate) fn from_reals(bytes: &[u8], precision: Precision) -> Vec<f64> {
    hyperpbd::gpu::read_reals(bytes, precision)
}
