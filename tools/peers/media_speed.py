#!/usr/bin/env python3
"""Samples per second of lumo's volumetric path tracer beside Mitsuba 3's `volpath`, one run.

    apt-get install -y libllvm19          # Mitsuba's llvm_ad_rgb variant (see compare_mitsuba.py)
    pip install mitsuba numpy
    cargo build --release -p lumo-cli
    python3 tools/peers/media_speed.py --lumo target/release/lumo

Each scene of the Mitsuba validation suite named here (tests/data/mitsuba/scenes/NAME.xml) is
rendered at --res² and --spp by both renderers from the same file, alternating lumo and
Mitsuba --repeats times so that both see the same load, and the medians are compared.

  * lumo: `lumo render SCENE --pipeline none` as a user runs it; the time is the whole
    process (parse, BVH, render, EXR write), so lumo's figure is, if anything, pessimistic.
  * Mitsuba: the scene is loaded once and rendered once untimed (the JIT compiles its
    kernels then); each timed call is `mi.render` with the same seed (a new seed may
    re-trace the kernel), followed by a read-back of the image so the work has finished.

Both use every core (--threads). The table goes to stdout as Markdown; the image means are
printed too so a reader can see the two renderers did the same work.
"""

import argparse
import os
import platform
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
SUITE = ROOT / "tests" / "data" / "mitsuba"
sys.path.insert(0, str(ROOT / "scripts"))
from compare_mitsuba import ensure_llvm_path  # noqa: E402  (Debian's libLLVM 19 for Dr.Jit)


def read_exr_mean(mi, np, path):
    """Per-channel mean of an RGB EXR (Mitsuba's reader, so no extra dependency)."""
    img = np.array(mi.Bitmap(str(path)))[..., :3]
    return img.mean(axis=(0, 1))


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--lumo", default=str(ROOT / "target" / "release" / "lumo"))
    ap.add_argument(
        "--scenes", nargs="*", default=["media_fog_box", "media_smoke_grid", "media_glass_sphere"]
    )
    ap.add_argument("--res", type=int, default=128)
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--threads", type=int, default=os.cpu_count())
    ap.add_argument("--variant", default="llvm_ad_rgb")
    args = ap.parse_args()

    if args.variant.startswith("llvm"):
        ensure_llvm_path()
    import drjit as dr
    import mitsuba as mi
    import numpy as np

    mi.set_variant(args.variant)
    dr.set_thread_count(args.threads)
    samples = args.res * args.res * args.spp
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for name in args.scenes:
            path = SUITE / "scenes" / f"{name}.xml"
            scene = mi.load_file(str(path), res=str(args.res), spp=str(args.spp))
            np.array(mi.render(scene, spp=args.spp, seed=7))  # JIT warm-up, untimed
            out = Path(tmp) / f"{name}.exr"
            cmd = [
                args.lumo, "render", str(path), "--pipeline", "none",
                "-D", f"res={args.res}", "--spp", str(args.spp),
                "--threads", str(args.threads), "-o", str(out),
            ]
            lumo_t, mi_t = [], []
            mi_img = None
            for _ in range(args.repeats):
                t0 = time.perf_counter()
                subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
                lumo_t.append(time.perf_counter() - t0)
                t0 = time.perf_counter()
                mi_img = np.array(mi.render(scene, spp=args.spp, seed=7))
                mi_t.append(time.perf_counter() - t0)
            lm, mm = statistics.median(lumo_t), statistics.median(mi_t)
            rows.append(
                (name, samples / lm / 1e3, samples / mm / 1e3, mm / lm,
                 read_exr_mean(mi, np, out), mi_img[..., :3].mean(axis=(0, 1)))
            )
            print(f"{name}: lumo {lm:.3f} s, Mitsuba {mm:.3f} s", file=sys.stderr, flush=True)

    load = os.getloadavg()
    print(f"Mitsuba {mi.__version__} `volpath` ({args.variant}) and lumo, {args.res}x{args.res}, "
          f"{args.spp} spp, {args.threads} threads, median of {args.repeats} alternating runs; "
          f"{platform.processor() or platform.machine()}, {os.cpu_count()} CPUs, load average "
          f"{load[0]:.1f} at the end.\n")
    print("| scene | lumo (ksamples/s) | Mitsuba (ksamples/s) | lumo / Mitsuba | mean lumo | mean Mitsuba |")
    print("|---|---:|---:|---:|---|---|")
    for name, l, m, ratio, ml, mm in rows:
        fmt = lambda v: " ".join(f"{x:.4f}" for x in v)  # noqa: E731
        print(f"| {name} | {l:.0f} | {m:.0f} | {ratio:.2f}x | {fmt(ml)} | {fmt(mm)} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
