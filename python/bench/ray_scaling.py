"""Benchmark (not a test) of lumo.ray: throughput with 1, 2 and 3 single-CPU Ray workers against
plain `lumo render` on the same cores, and where a chunk's time goes (scheduling, transfer,
reduction). Prints a Markdown table; run from the repository root after `pip install ./python`
and `cargo build --release -p lumo-cli`:

    python python/bench/ray_scaling.py [--size 256x256] [--spp 32] [--chunk-spp 4]
"""

import argparse
import os
import platform
import statistics
import subprocess
import tempfile
import time

import lumo.ray as lray

lray.loopback_only()

import ray  # noqa: E402
from ray.cluster_utils import Cluster  # noqa: E402
from lumo import _native  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
LUMO = os.environ.get("LUMO_BIN", os.path.join(ROOT, "target", "release", "lumo"))


def cpu_name():
    try:
        for line in open("/proc/cpuinfo"):
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor()


def time_cli(words, threads, out, runs):
    times = []
    for _ in range(runs):
        t = time.monotonic()
        subprocess.run([LUMO, "render", *words, "--threads", str(threads), "-o", out],
                       check=True, capture_output=True)
        times.append(time.monotonic() - t)
    return statistics.median(times)


def time_local_chunks(words, chunk_spp, out):
    """The same chunks rendered and added up in this process: the work without Ray."""
    plan = _native.RenderPlan(words + ["-o", out, "--threads", "1"], driver=True)
    t = time.monotonic()
    render = 0.0
    datas = []
    for c in plan.chunks(chunk_spp):
        r = time.monotonic()
        datas.append(plan.render_chunk(*c))
        render += time.monotonic() - r
    f = time.monotonic()
    for d in datas:
        plan.add_chunk(d)
    plan.finish(0)
    finish = time.monotonic() - f
    return time.monotonic() - t, render, finish, len(datas), len(datas[0])


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--size", default="256x256")
    ap.add_argument("--spp", type=int, default=32)
    ap.add_argument("--chunk-spp", type=int, default=4)
    ap.add_argument("--scene", default="cornell")
    ap.add_argument("--runs", type=int, default=3)
    a = ap.parse_args()
    words = [a.scene, "--size", a.size, "--spp", str(a.spp), "--pipeline", "none"]
    tmp = tempfile.mkdtemp(prefix="lumo-ray-bench-")
    out = os.path.join(tmp, "x.exr")
    w, h = map(int, a.size.split("x"))
    samples = w * h * a.spp
    print(f"lumo.ray benchmark: {a.scene} {a.size}, {a.spp} spp, chunks of {a.chunk_spp} spp, "
          f"pipeline none; {cpu_name()}, {os.cpu_count()} logical CPUs; medians of {a.runs} runs\n")
    total, render, finish, n, nbytes = time_local_chunks(words, a.chunk_spp, out)
    print(f"in-process, no Ray: {n} chunks rendered in {render:.3f} s on one thread, added up and "
          f"written in {finish * 1e3:.1f} ms; {nbytes / 1e6:.2f} MB per chunk "
          f"({nbytes / (w * h):.0f} bytes per pixel)\n")
    print("| workers | lumo render --threads N (s) | lumo.ray (s) | ray / plain | Msamples/s (ray) | overhead per chunk (ms) | overhead share |")
    print("|---:|---:|---:|---:|---:|---:|---:|")
    for workers in (1, 2, 3):
        plain = time_cli(words, workers, out, a.runs)
        c = Cluster(initialize_head=True, head_node_args={"num_cpus": 1, "include_dashboard": False})
        for _ in range(workers - 1):
            c.add_node(num_cpus=1)
        ray.init(address=c.address, log_to_driver=False)
        c.wait_for_nodes()
        # A warm-up run loads the scene in every worker process.
        lray.render(words + ["-o", out], chunk_spp=a.chunk_spp)
        times = []
        for _ in range(a.runs):
            t = time.monotonic()
            lray.render(words + ["-o", out], chunk_spp=a.chunk_spp)
            times.append(time.monotonic() - t)
        ray.shutdown()
        c.shutdown()
        dist = statistics.median(times)
        # Work per worker if the chunks spread evenly, against the wall time seen.
        ideal = render / workers + finish
        over = max(0.0, dist - ideal)
        print(f"| {workers} | {plain:.3f} | {dist:.3f} | {dist / plain:.2f} | {samples / dist / 1e6:.2f} | "
              f"{over / n * workers * 1e3:.1f} | {over / dist:.1%} |")


if __name__ == "__main__":
    main()
