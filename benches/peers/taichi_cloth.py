"""The peer cloth in Taichi: a hand-written XPBD cloth kernel to time the
hyperpbd CPU golden path against (not part of CI; needs `pip install taichi`).

Same scene as `hyperpbd::scenes::peer_cloth(n)` (src/scenes/peer_cloth.rs):
n x n nodes, 1 m square in the x-z plane at y = 1, mass 1/n^2, the two far
corners fixed, the structural edges in four independent sets (horizontal
even/odd, vertical even/odd) projected in that Gauss-Seidel order with
compliance 0, dt 1/60, 10 substeps x 1 iteration, gravity 9.81 along -y.
Same arithmetic per edge as the golden path (d = x_j - x_i, |d|,
dl = -(|d| - rest) / (w_i + w_j), x_i -= w_i d/|d| dl, x_j += w_j d/|d| dl).

Compliance 0 makes the XPBD update the PBD one, so this peer keeps no
multipliers, and it stores positions as a 2D field (node (a, b) at [a, b])
so no index arithmetic is spent on edges: both advantages the golden path
does not take. Two schedules, the fastest of each kind:

  --threads 1   the whole frame in one kernel with the substep loop
                serialized (no per-substep launch), on one CPU thread
  otherwise     one kernel per substep, each stage a top-level loop that
                Taichi runs in parallel on ti.cpu (the substeps must be
                separate launches for the stages to parallelize)

    python3 benches/peers/taichi_cloth.py --n 128 --threads 1
    python3 benches/peers/taichi_cloth.py --n 128            # all cores

Prints ms per frame: the median and the best of --repeats batches of
--frames frames, after a warm-up that includes the JIT compilation; then
the best single frame of --frames frames timed one by one.
"""

import argparse
import time

import taichi as ti


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--n", type=int, default=128)
    parser.add_argument("--threads", type=int, default=0, help="0: all cores")
    parser.add_argument("--fp", choices=["f64", "f32"], default="f64")
    parser.add_argument("--frames", type=int, default=200)
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()

    fp = ti.f64 if args.fp == "f64" else ti.f32
    init = dict(arch=ti.cpu, default_fp=fp)
    if args.threads > 0:
        init["cpu_max_num_threads"] = args.threads
    ti.init(**init)

    n = args.n
    substeps = 10
    h = (1.0 / 60.0) / substeps
    spacing = 1.0 / (n - 1)

    x = ti.Vector.field(3, dtype=fp, shape=(n, n))
    p = ti.Vector.field(3, dtype=fp, shape=(n, n))
    v = ti.Vector.field(3, dtype=fp, shape=(n, n))
    w = ti.field(dtype=fp, shape=(n, n))
    # Rest lengths from the initial positions, as the golden path computes them.
    rest_h = ti.field(dtype=fp, shape=(n - 1, n))
    rest_v = ti.field(dtype=fp, shape=(n, n - 1))

    @ti.kernel
    def initialise():
        for a, b in x:
            x[a, b] = ti.Vector([a * spacing - 0.5, 1.0, b * spacing - 0.5])
            v[a, b] = ti.Vector([0.0, 0.0, 0.0])
            w[a, b] = 1.0 * n * n
            if b == n - 1 and (a == 0 or a == n - 1):
                w[a, b] = 0.0
        for a, b in rest_h:
            rest_h[a, b] = (x[a + 1, b] - x[a, b]).norm()
        for a, b in rest_v:
            rest_v[a, b] = (x[a, b + 1] - x[a, b]).norm()

    @ti.func
    def project(ia, ib, ja, jb, rest):
        wi = w[ia, ib]
        wj = w[ja, jb]
        d = x[ja, jb] - x[ia, ib]
        length = d.norm()
        wsum = wi + wj
        if length > 0.0 and wsum > 0.0:
            dl = -(length - rest) / wsum
            unit = d / length
            # Plain stores, not `+=` (which Taichi turns into atomic adds):
            # edges of one set share no node.
            x[ia, ib] = x[ia, ib] + wi * -unit * dl
            x[ja, jb] = x[ja, jb] + wj * unit * dl

    @ti.func
    def predict(a, b):
        p[a, b] = x[a, b]
        if w[a, b] > 0.0:
            v[a, b][1] = v[a, b][1] + h * -9.81
            x[a, b] = x[a, b] + h * v[a, b]

    @ti.func
    def velocity(a, b):
        if w[a, b] > 0.0:
            v[a, b] = (x[a, b] - p[a, b]) / h

    @ti.func
    def stages():
        for a, b in ti.ndrange(n, n):
            predict(a, b)
        for k, b in ti.ndrange(n // 2, n):
            project(2 * k, b, 2 * k + 1, b, rest_h[2 * k, b])
        for k, b in ti.ndrange((n - 1) // 2, n):
            project(2 * k + 1, b, 2 * k + 2, b, rest_h[2 * k + 1, b])
        for a, k in ti.ndrange(n, n // 2):
            project(a, 2 * k, a, 2 * k + 1, rest_v[a, 2 * k])
        for a, k in ti.ndrange(n, (n - 1) // 2):
            project(a, 2 * k + 1, a, 2 * k + 2, rest_v[a, 2 * k + 1])
        for a, b in ti.ndrange(n, n):
            velocity(a, b)

    @ti.kernel
    def substep():
        stages()

    @ti.kernel
    def serial_frame():
        ti.loop_config(serialize=True)
        for _ in range(substeps):
            stages()

    def frame():
        if args.threads == 1:
            serial_frame()
        else:
            for _ in range(substeps):
                substep()

    initialise()
    for _ in range(20):
        frame()
    ti.sync()
    batches = []
    for _ in range(args.repeats):
        start = time.perf_counter()
        for _ in range(args.frames):
            frame()
        ti.sync()
        batches.append((time.perf_counter() - start) / args.frames)
    best = min(batches)
    median = sorted(batches)[len(batches) // 2]
    # The best single frame: on a loaded machine, the frame least disturbed
    # by other processes (what hyperpbd's cpu_threads bench also reports).
    best_frame = float("inf")
    for _ in range(args.frames):
        start = time.perf_counter()
        frame()
        ti.sync()
        best_frame = min(best_frame, time.perf_counter() - start)
    threads = args.threads if args.threads > 0 else "all"
    schedule = "one kernel per frame" if args.threads == 1 else "one kernel per substep"
    print(
        f"taichi peer_cloth {n}: median batch {median * 1e3:.3f} ms/frame, "
        f"best batch {best * 1e3:.3f} ms/frame "
        f"({args.fp}, threads {threads}, {schedule}, {len(batches)} batches); "
        f"best frame {best_frame * 1e3:.3f} ms"
    )


if __name__ == "__main__":
    main()
