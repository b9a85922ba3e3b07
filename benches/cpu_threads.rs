//! Temporary baseline harness (replaced below).
use hyperpbd::{Backend, CpuBackend, Plan, State, scenes};
use std::time::Instant;

fn main() {
    for n in [32usize, 64, 128, 256, 512] {
        let scene = scenes::peer_cloth(n);
        let plan = Plan::compile(&scene).unwrap();
        let mut b = CpuBackend::new(plan, &State::from_scene(&scene)).unwrap();
        for _ in 0..5 {
            b.step().unwrap();
        }
        let frames = (2_000_000 / (n * n)).clamp(5, 400);
        let mut best = f64::MAX;
        for _ in 0..5 {
            let t = Instant::now();
            for _ in 0..frames {
                b.step().unwrap();
            }
            best = best.min(t.elapsed().as_secs_f64() / frames as f64);
        }
        println!("peer_cloth {n}: {:.3} ms/frame", best * 1e3);
    }
}
