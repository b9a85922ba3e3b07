"""The two numbers of the Python package (docs/python.md states them).

1. Overhead of one `sim.step(frames=1)` call over the Rust step, on the
   built-in 20-link chain (chain2d, 21 particles, CPU, 1 thread):
       per_call  = time of K calls of step(frames=1) / K
       rust_step = time of one step(frames=K) call / K    (one crossing for K
                   steps: the Rust step plus a negligible share of one call)
       overhead  = per_call − rust_step
   (GIL release and re-acquire, the mutex, the report dict).
2. Reading positions of a 1M-particle scene (3D, CPU): `sim.positions`,
   next to numpy's own copy of an array of that size (the memcpy floor).

Run: python python/bench/bench.py [--quick]    (best of several repeats)
"""

import argparse
import json
import time

import numpy as np

import hyperpbd as hp


def best(fn, repeats):
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return min(times)


def step_overhead(k, repeats):
    scene = hp.Scene.builtin("chain2d")
    calls = hp.Simulation(scene, backend="cpu", threads=1)
    batch = hp.Simulation(scene, backend="cpu", threads=1)
    calls.step(frames=k)  # warm up, and start both in the same settled regime
    batch.step(frames=k)

    def many_calls():
        for _ in range(k):
            calls.step(frames=1)

    # Interleaved, so that load from other processes hits both alike.
    per_call, rust_step = float("inf"), float("inf")
    for _ in range(repeats):
        per_call = min(per_call, best(many_calls, 1) / k)
        rust_step = min(rust_step, best(lambda: batch.step(frames=k), 1) / k)
    return per_call, rust_step


def million_particles(n):
    rng = np.random.default_rng(1)
    positions = rng.uniform(-1.0, 1.0, size=(n, 3))
    document = {
        "dim": 3,
        "dt": 0.01,
        "gravity": [0.0, -9.81, 0.0],
        "particles": [{"position": p, "mass": 1.0} for p in positions.tolist()],
    }
    return hp.Scene.from_json(json.dumps(document))


def read_positions(n, repeats):
    scene = million_particles(n)
    sim = hp.Simulation(scene, backend="cpu", threads=1)
    sim.step()
    x = sim.positions
    assert x.shape == (n, 3) and x.dtype == np.float64
    read = best(lambda: sim.positions, repeats)
    floor = best(lambda: x.copy(), repeats)
    return read, floor


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer repeats (a smoke run)")
    args = parser.parse_args()
    k, repeats = (2_000, 3) if args.quick else (20_000, 7)
    per_call, rust_step = step_overhead(k, repeats)
    print(
        f"chain2d step(frames=1): {per_call * 1e6:.2f} us per call, Rust step "
        f"{rust_step * 1e6:.2f} us, overhead {(per_call - rust_step) * 1e6:.2f} us "
        f"(best of {repeats}, {k} steps each)"
    )
    n = 1_000_000
    read, floor = read_positions(n, repeats)
    print(
        f"positions of {n} particles (3D): {read * 1e3:.2f} ms "
        f"({n * 3 * 8 / read / 1e9:.2f} GB/s); numpy copy of the same array {floor * 1e3:.2f} ms"
    )


if __name__ == "__main__":
    main()
