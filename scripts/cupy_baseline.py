#!/usr/bin/env python3
"""CUDA floor for the device check, measured with the CuPy already on the GPU
machine (scripts/device-check.sh runs it; docs/device-check.md).

    chain   93 dependent tiny kernels (y = y * a + b) over 65,536 f32 elements,
            launched one after another on one stream: seconds per kernel
    graph   the same 93 launches captured once into a CUDA graph and replayed
    copy    a device-to-device copy of COPY_BYTES: bytes moved per second
            (read + write)

Prints one JSON object. Without CuPy (or without a CUDA device) it prints
{"skipped": "<why>"} and exits 0: the rest of the check does not depend on it.
"""
import json
import statistics
import sys
import time

KERNELS = 93
ELEMENTS = 65_536


def main():
    dry = "--dry" in sys.argv[1:]
    try:
        import cupy as cp

        cp.cuda.runtime.getDeviceCount()
    except Exception as e:  # noqa: BLE001 - any failure means "no CuPy here"
        print(json.dumps({"skipped": f"CuPy unavailable: {type(e).__name__}: {e}"}))
        return 0
    copy_bytes = (64 << 20) if dry else (2 << 30)
    repeats = 5 if dry else 30
    axpb = cp.ElementwiseKernel("float32 a, float32 b", "float32 y", "y = y * a + b", "axpb")
    y = cp.ones(ELEMENTS, dtype=cp.float32)
    stream = cp.cuda.Stream(non_blocking=True)

    def chain():
        for _ in range(KERNELS):
            axpb(cp.float32(0.999), cp.float32(0.001), y)

    def timed(run):
        times = []
        for _ in range(repeats):
            start, end = cp.cuda.Event(), cp.cuda.Event()
            start.record(stream)
            run()
            end.record(stream)
            end.synchronize()
            times.append(cp.cuda.get_elapsed_time(start, end) / 1e3)
        return statistics.median(times)

    def wall(run):
        times = []
        for _ in range(repeats):
            t0 = time.perf_counter()
            run()
            stream.synchronize()
            times.append(time.perf_counter() - t0)
        return statistics.median(times)

    out = {"device": cp.cuda.runtime.getDeviceProperties(0)["name"].decode(), "dry": dry}
    with stream:
        chain()
        stream.synchronize()
        plain = timed(chain)
        out["chain_kernels"] = KERNELS
        out["chain_elements"] = ELEMENTS
        out["chain_seconds"] = plain
        out["chain_wall_seconds"] = wall(chain)
        out["seconds_per_dependent_kernel"] = plain / KERNELS
        try:
            stream.begin_capture()
            chain()
            graph = stream.end_capture()
            graph.launch(stream)
            stream.synchronize()
            replay = timed(lambda: graph.launch(stream))
            out["graph_seconds"] = replay
            out["graph_wall_seconds"] = wall(lambda: graph.launch(stream))
            out["graph_seconds_per_kernel"] = replay / KERNELS
        except Exception as e:  # noqa: BLE001 - older CuPy: no stream capture
            out["graph_skipped"] = f"{type(e).__name__}: {e}"
        src = cp.ones(copy_bytes // 4, dtype=cp.float32)
        dst = cp.empty_like(src)
        cp.copyto(dst, src)
        stream.synchronize()
        copy = timed(lambda: cp.copyto(dst, src))
        out["copy_bytes"] = copy_bytes
        out["copy_seconds"] = copy
        out["copy_bytes_per_second"] = 2 * copy_bytes / copy
    print(json.dumps(out))
    return 0


if __name__ == "__main__":
    sys.exit(main())
