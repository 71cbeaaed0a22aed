#!/usr/bin/env python3
"""Time lumo's filters against peers on the same inputs, in one run.

Requirements (install into a virtual environment):

    pip install opencv-contrib-python-headless pyoidn numpy

and a release build of lumo: `cargo build --release -p lumo-cli` (or pass --lumo PATH).

What it does, for 512x512 and 1920x1080:
  1. Generates a synthetic noisy frame (planes at different depths and orientations,
     heavy-tailed 1-spp-like noise) and writes color/albedo/normal/position/depth as PFM.
  2. Runs `lumo denoise ... --timings --repeat N` (median of N = --repeats runs in one
     process, warm like the in-process peers) and parses the `filter <ms> ms` line: the guided filter with a 3-dim normal guide, and À-Trous with
     5 iterations and 3 edge weights (colour, normal, position).
  3. Times cv2.ximgproc.guidedFilter with the same 3-channel guide (normal*0.5+0.5, float32),
     the same radius and the same eps. Mapping: lumo's eps is in units of the guide value
     squared with the guide in [0,1]; OpenCV's guidedFilter adds eps to the diagonal of the
     guide covariance in the units of the guide image it is given, so for a float32 guide in
     [0,1] eps_cv = eps_lumo. (For an 8-bit guide it would be eps_lumo * 255**2.)
  4. Times OIDN (pyoidn.denoise, colour + albedo + normal, hdr=True, quality "high"; the first
     call, which builds the device and filter, is excluded).
  5. Prints ratios: lumo guided / OpenCV guided (target <= 1.0) and
     OIDN / lumo À-Trous 5 it 3 weights (target >= 20).

All timings are wall-clock medians of warm runs in one process (OpenCV's first call is
included in its median, OIDN's first call is excluded); both lumo and OpenCV use all cores
(rayon / cv threads), OIDN uses its own CPU device with all cores.

On a shared or noisy machine the speed of everything can drift by 2x within a minute, so
the four measurements are taken in --rounds interleaved rounds (lumo guided, OpenCV, lumo
À-Trous, OIDN, then again), each round's ratios are computed from that round's times, and
the table reports the median over rounds of every time and ratio (with the range of the
ratios): a slow phase that hits one tool then shifts one round, not the result.
"""

import argparse
import os
import re
import statistics
import subprocess
import sys
import tempfile
import time

import numpy as np


def write_pfm(path, img):
    """Writes a float32 PFM (3-channel 'PF' or 1-channel 'Pf'), rows bottom to top."""
    img = np.asarray(img, dtype=np.float32)
    h, w = img.shape[:2]
    header = ("PF" if img.ndim == 3 else "Pf") + f"\n{w} {h}\n-1.0\n"
    with open(path, "wb") as f:
        f.write(header.encode("ascii"))
        f.write(np.ascontiguousarray(img[::-1]).astype("<f4").tobytes())


def make_frame(w, h, seed=1):
    """A synthetic G-buffer: three planes (floor, back wall, a box face) plus noisy colour."""
    rng = np.random.default_rng(seed)
    ys, xs = np.mgrid[0:h, 0:w].astype(np.float32)
    u, v = xs / w, ys / h
    normal = np.zeros((h, w, 3), np.float32)
    depth = np.zeros((h, w), np.float32)
    albedo = np.zeros((h, w, 3), np.float32)
    floor = v > 0.6
    box = (u > 0.55) & (u < 0.8) & (v > 0.35) & (v < 0.75)
    wall = ~floor & ~box
    normal[wall] = (0, 0, 1)
    depth[wall] = 6.0
    albedo[wall] = (0.7, 0.7, 0.7)
    normal[floor] = (0, 1, 0)
    depth[floor] = 2.0 + 4.0 * (1.0 - (v[floor] - 0.6) / 0.4)
    checker = ((np.floor(u * 16) + np.floor(v * 16)) % 2).astype(np.float32)
    albedo[floor] = np.stack([0.3 + 0.5 * checker[floor]] * 3, -1)
    normal[box] = (-0.6, 0, 0.8)
    depth[box] = 3.5
    albedo[box] = (0.75, 0.6, 0.5)
    position = np.stack([u * 4 - 2, 2 - v * 3, -depth], -1).astype(np.float32)
    light = 0.6 + 0.4 * np.clip(normal[..., 1:2] + normal[..., 2:3] * 0.5, 0, 1)
    shadow = np.where((u > 0.3) & (u < 0.5) & floor, 0.3, 1.0)[..., None]
    ref = albedo * light * shadow
    mult = np.where(rng.random((h, w, 1)) < 0.25, rng.exponential(4.0, (h, w, 1)), 0.0)
    color = (ref * (0.5 + 0.5 * mult)).astype(np.float32)
    return dict(color=color, albedo=albedo, normal=normal, position=position, depth=depth)


def lumo_filter_ms(lumo, args, repeats):
    """Median filter time of `repeats` runs in one `lumo denoise` process (--repeat), i.e.
    warm like the in-process peers; the input reading and output writing are not timed."""
    out = subprocess.run([lumo, "denoise", *args, "--timings", "--repeat", str(repeats)],
                         capture_output=True, text=True)
    if out.returncode != 0:
        sys.exit(f"lumo failed: {' '.join(args)}\n{out.stderr}")
    m = re.search(r"^filter ([0-9.]+) ms$", out.stdout, re.M)
    if not m:
        sys.exit(f"no 'filter … ms' line in lumo output:\n{out.stdout}")
    return float(m.group(1))


def cpu_model():
    """The CPU's model name (Linux), for the benchmark record."""
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return "unknown"


def load():
    """1/5/15-minute load averages (Linux): the machine may be shared during a run."""
    try:
        with open("/proc/loadavg") as f:
            return " ".join(f.read().split()[:3])
    except OSError:
        return "n/a"


def timed(fn, repeats):
    times = []
    for _ in range(repeats):
        t = time.perf_counter()
        fn()
        times.append((time.perf_counter() - t) * 1e3)
    return statistics.median(times)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--lumo", default=os.path.join("target", "release", "lumo"))
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--rounds", type=int, default=3,
                    help="interleaved rounds; the table gives medians over rounds")
    ap.add_argument("--radius", type=int, default=24)
    ap.add_argument("--eps", type=float, default=0.003)
    a = ap.parse_args()
    import cv2

    try:
        import pyoidn
    except ImportError as e:  # say exactly why, keep the OpenCV comparison
        pyoidn = None
        print(f"pyoidn unavailable: {e}")
    print(f"cv2 {cv2.__version__}, threads {cv2.getNumThreads()}; cores {os.cpu_count()}; "
          f"cpu {cpu_model()}; load {load()}")
    rows = []
    with tempfile.TemporaryDirectory() as d:
        for w, h in [(512, 512), (1920, 1080)]:
            f = make_frame(w, h)
            paths = {}
            for k, img in f.items():
                paths[k] = os.path.join(d, f"{k}-{w}x{h}.pfm")
                write_pfm(paths[k], img)
            out = os.path.join(d, "out.pfm")
            guided = ["--color", paths["color"], "--normal", paths["normal"], "--filter", "guided",
                      "--guide-dims", "3", "--radius", str(a.radius), "--eps-normal", str(a.eps),
                      "-o", out]
            atrous = ["--color", paths["color"], "--albedo", paths["albedo"], "--normal",
                      paths["normal"], "--position", paths["position"], "--depth", paths["depth"],
                      "--filter", "atrous", "--iterations", "5",
                      # the paper's fixed colour σ, not the default spatial noise estimate
                      "--variance-source", "none", "--sigma-color", "4",
                      "--sigma-normal", "0.3", "--sigma-position", "0.1", "-o", out]
            guide = np.ascontiguousarray(f["normal"] * 0.5 + 0.5, dtype=np.float32)
            src = np.ascontiguousarray(f["color"], dtype=np.float32)
            albedo = f["albedo"].astype(np.float32)
            normal = f["normal"].astype(np.float32)

            def oidn():
                return pyoidn.denoise(src, albedo, normal, hdr=True)

            if pyoidn is not None:
                oidn()  # device and filter creation excluded
            rounds = []
            for r in range(a.rounds):
                t_lumo_g = lumo_filter_ms(a.lumo, guided, a.repeats)
                t_cv = timed(lambda: cv2.ximgproc.guidedFilter(guide, src, a.radius, a.eps, -1),
                             a.repeats)
                t_lumo_a = lumo_filter_ms(a.lumo, atrous, a.repeats)
                t_oidn = timed(oidn, a.repeats) if pyoidn is not None else None
                rounds.append((t_lumo_g, t_cv, t_lumo_a, t_oidn))
                oi = f"{t_oidn:.1f} ms, OIDN/À-Trous {t_oidn / t_lumo_a:.1f}" if t_oidn else "n/a"
                print(f"{w}x{h} round {r + 1}: guided {t_lumo_g:.1f} vs OpenCV {t_cv:.1f} ms "
                      f"(ratio {t_lumo_g / t_cv:.2f}); À-Trous {t_lumo_a:.1f} ms, OIDN {oi}; "
                      f"load {load()}")
            rows.append((w, h, rounds))
    print(f"load at the end: {load()}")
    print()
    print(f"Medians over {a.rounds} interleaved rounds (ratios: median of the per-round ratios, "
          "range in brackets).")
    print()
    print("| size | lumo guided ms | OpenCV guided ms | lumo/OpenCV (target ≤ 1) | lumo À-Trous 5it 3w ms "
          "| OIDN ms | OIDN/À-Trous (target ≥ 20) |")
    print("|---|---|---|---|---|---|---|")
    med = statistics.median
    for w, h, rounds in rows:
        g, cv, at, oi = (med([r[i] for r in rounds]) if rounds[0][i] is not None else None
                         for i in range(4))
        rg = [r[0] / r[1] for r in rounds]
        g_ratio = f"{med(rg):.2f} ({min(rg):.2f}–{max(rg):.2f})"
        if oi is not None:
            ro = [r[3] / r[2] for r in rounds]
            oi_s, o_ratio = f"{oi:.1f}", f"{med(ro):.1f} ({min(ro):.1f}–{max(ro):.1f})"
        else:
            oi_s, o_ratio = "n/a", "n/a"
        print(f"| {w}×{h} | {g:.1f} | {cv:.1f} | {g_ratio} | {at:.1f} | {oi_s} | {o_ratio} |")


if __name__ == "__main__":
    main()
