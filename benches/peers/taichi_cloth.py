"""The peer cloth in Taichi: a hand-written XPBD cloth kernel to time the
hyperpbd CPU golden path against (not part of CI).

Same scene as `hyperpbd::scenes::peer_cloth(n)` (src/scenes/peer_cloth.rs):
n x n nodes, 1 m square in the x-z plane at y = 1, mass 1/n^2, the two far
corners fixed, the structural edges in four independent sets (horizontal
even/odd, vertical even/odd) projected in that Gauss-Seidel order with
compliance 0, dt 1/60, 10 substeps x 1 iteration, gravity 9.81 along -y.

Compliance 0 makes the XPBD update the PBD one, so this peer keeps no
multipliers (an advantage the golden path, which stores lambda, does not
take). One kernel call per substep; each stage is a top-level loop, which
Taichi runs in parallel on ti.cpu unless cpu_max_num_threads=1.

    python3 benches/peers/taichi_cloth.py --n 128 --threads 1
    python3 benches/peers/taichi_cloth.py --n 128            # all cores

Prints ms per frame (best of --repeats batches of --frames frames, after
a warm-up that includes the JIT compilation).
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
    init = dict(arch=ti.cpu, default_fp=fp, offline_cache=True)
    if args.threads > 0:
        init["cpu_max_num_threads"] = args.threads
    ti.init(**init)

    n = args.n
    substeps = 10
    h = (1.0 / 60.0) / substeps
    spacing = 1.0 / (n - 1)
    count = n * n

    x = ti.Vector.field(3, dtype=fp, shape=count)
    p = ti.Vector.field(3, dtype=fp, shape=count)
    v = ti.Vector.field(3, dtype=fp, shape=count)
    w = ti.field(dtype=fp, shape=count)
    # rest[0][k]: horizontal edge (a, b)-(a+1, b), k = a + (n-1) b;
    # rest[1][k]: vertical edge (a, b)-(a, b+1), k = a + n b.
    rest_h = ti.field(dtype=fp, shape=(n - 1) * n)
    rest_v = ti.field(dtype=fp, shape=n * (n - 1))

    @ti.kernel
    def initialise():
        for k in range(count):
            a = k % n
            b = k // n
            x[k] = ti.Vector([a * spacing - 0.5, 1.0, b * spacing - 0.5])
            v[k] = ti.Vector([0.0, 0.0, 0.0])
            w[k] = 1.0 * count
            if b == n - 1 and (a == 0 or a == n - 1):
                w[k] = 0.0
        for a, b in ti.ndrange(n - 1, n):
            rest_h[a + (n - 1) * b] = (x[a + 1 + n * b] - x[a + n * b]).norm()
        for a, b in ti.ndrange(n, n - 1):
            rest_v[a + n * b] = (x[a + n * (b + 1)] - x[a + n * b]).norm()

    @ti.func
    def project(i, j, rest):
        wi = w[i]
        wj = w[j]
        d = x[j] - x[i]
        length = d.norm()
        wsum = wi + wj
        if length > 0.0 and wsum > 0.0:
            dl = -(length - rest) / wsum
            unit = d / length
            # Plain stores, not `+=` (which Taichi turns into atomic adds):
            # edges of one set share no node.
            x[i] = x[i] + wi * -unit * dl
            x[j] = x[j] + wj * unit * dl

    @ti.kernel
    def substep():
        for k in range(count):
            if w[k] > 0.0:
                v[k][1] = v[k][1] + h * -9.81
                p[k] = x[k]
                x[k] = x[k] + h * v[k]
            else:
                p[k] = x[k]
        for b, k in ti.ndrange(n, n // 2):
            a = 2 * k
            project(a + n * b, a + 1 + n * b, rest_h[a + (n - 1) * b])
        for b, k in ti.ndrange(n, (n - 1) // 2):
            a = 2 * k + 1
            project(a + n * b, a + 1 + n * b, rest_h[a + (n - 1) * b])
        for k, a in ti.ndrange(n // 2, n):
            b = 2 * k
            project(a + n * b, a + n * (b + 1), rest_v[a + n * b])
        for k, a in ti.ndrange((n - 1) // 2, n):
            b = 2 * k + 1
            project(a + n * b, a + n * (b + 1), rest_v[a + n * b])
        for k in range(count):
            if w[k] > 0.0:
                v[k] = (x[k] - p[k]) / h

    def frame():
        for _ in range(substeps):
            substep()

    initialise()
    for _ in range(20):
        frame()
    ti.sync()
    best = float("inf")
    for _ in range(args.repeats):
        start = time.perf_counter()
        for _ in range(args.frames):
            frame()
        ti.sync()
        best = min(best, (time.perf_counter() - start) / args.frames)
    threads = args.threads if args.threads > 0 else "all"
    print(f"taichi peer_cloth {n}: {best * 1e3:.3f} ms/frame ({args.fp}, threads {threads})")


if __name__ == "__main__":
    main()
