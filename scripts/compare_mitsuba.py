#!/usr/bin/env python3
"""Compare lumo against Mitsuba 3 on Mitsuba's built-in Cornell box (`mi.cornell_box()`).

What it does
------------
(a) Renders `mi.cornell_box()` in Mitsuba 3's `llvm_ad_rgb` variant with the
    settings lumo uses for its `cornell` scene: path integrator (--max-depth),
    box reconstruction filter, RGB float32 hdrfilm, independent sampler.
    One warm-up render is done first (Dr.Jit traces + LLVM-compiles the
    kernel, or loads it from its on-disk cache); then --runs timed renders,
    whose median gives Mitsuba's samples/s. Both timings are printed.
(b) Runs lumo --runs times (median, like Mitsuba's):
        cargo run --release -p lumo-cli -- render cornell --pipeline none --spp N \
            --max-depth D --size WxH -o /tmp/lumo_cornell.exr
    (or a prebuilt binary via --lumo-bin) and parses its final line, e.g.
        done in 1.23 s · 3.4 M samples/s · 12.3 M rays/s
(c) Prints both samples/s, the ratio lumo/mitsuba, the mean RGB of both images
    and their relative difference, per quadrant too; and, when
    tests/data/mitsuba_cornell_reference.json holds an entry for the same
    max depth, lumo's mean against that converged reference.

`--reference` instead (re)generates tests/data/mitsuba_cornell_reference.json
and tests/data/mitsuba_cornell_d{2,3,5}.exr (converged 1024 spp renders).

Install (Debian/Ubuntu, x86_64)
-------------------------------
    pip install mitsuba numpy            # OpenEXR optional (EXR fallback reader)
    apt-get update
    apt-get install -y libllvm19
    dpkg -L libllvm19 | grep 'libLLVM.*so'   # -> /usr/lib/x86_64-linux-gnu/libLLVM-19.so
    export DRJIT_LIBLLVM_PATH=/usr/lib/x86_64-linux-gnu/libLLVM-19.so

Mitsuba's `llvm_ad_*` variants abort with Debian's default libLLVM; libLLVM 19
works (tested: mitsuba 3.9.1, drjit 1.5.0, libllvm19 19.1). DRJIT_LIBLLVM_PATH
must be set before `import mitsuba`; this script sets it itself when it is
unset and one of the Debian libraries below exists.

Examples
--------
    python3 scripts/compare_mitsuba.py                         # 512x512, 16 spp, depth 5
    python3 scripts/compare_mitsuba.py --spp 64 --max-depth 3
    python3 scripts/compare_mitsuba.py --lumo-bin target/release/lumo
    python3 scripts/compare_mitsuba.py --mitsuba-only --runs 3
    python3 scripts/compare_mitsuba.py --avx2 --lumo-bin target/release/lumo   # AVX2 code on both
    python3 scripts/compare_mitsuba.py --reference --ref-spp 1024
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import re
import statistics
import subprocess
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
REFERENCE_JSON = REPO / "tests" / "data" / "mitsuba_cornell_reference.json"

_DEBIAN_LLVM = [
    "/usr/lib/x86_64-linux-gnu/libLLVM-19.so",
    "/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1",
    "/usr/lib/llvm-19/lib/libLLVM-19.so",
    "/usr/lib/llvm-19/lib/libLLVM.so.1",
    "/usr/lib/aarch64-linux-gnu/libLLVM-19.so",
]

# Named regions, as fractions of the image: (x0, x1, y0, y1), half-open, with
# x to the right and y downwards (row 0 = top of the image = ceiling).
# Chosen on the 512x512 render; each lies inside one surface.
REGIONS = {
    "top_left": (0.0, 0.5, 0.0, 0.5),
    "top_right": (0.5, 1.0, 0.0, 0.5),
    "bottom_left": (0.0, 0.5, 0.5, 1.0),
    "bottom_right": (0.5, 1.0, 0.5, 1.0),
}
PATCHES_512 = {  # pixel bounds on a 512x512 image: (x0, x1, y0, y1), half-open
    "light": (224, 288, 68, 78),
    "ceiling": (160, 352, 20, 56),
    "back_wall": (200, 312, 120, 200),
    "red_wall": (24, 96, 160, 240),
    "green_wall": (416, 488, 160, 240),
    "floor_front": (110, 240, 456, 500),
    "large_box_front": (160, 250, 240, 420),
    "small_box_front": (262, 370, 372, 460),
}
REGIONS.update({k: (x0 / 512, x1 / 512, y0 / 512, y1 / 512) for k, (x0, x1, y0, y1) in PATCHES_512.items()})


def ensure_llvm_path() -> None:
    if os.environ.get("DRJIT_LIBLLVM_PATH"):
        return
    for p in _DEBIAN_LLVM:
        if os.path.exists(p):
            os.environ["DRJIT_LIBLLVM_PATH"] = p
            return


def import_mitsuba(variant: str, avx2: bool = False):
    ensure_llvm_path()
    import mitsuba as mi  # noqa: E402  (must follow DRJIT_LIBLLVM_PATH)

    mi.set_variant(variant)
    if avx2:
        llvm_target_avx2()
    return mi


def llvm_target_avx2():
    """Makes Dr.Jit's LLVM backend generate AVX2 code, 8 lanes ("haswell"), as on a CPU without
    AVX-512. Dr.Jit's Python module does not expose jit_llvm_set_target, so it is called from
    libdrjit-core.so by its (C++-mangled) name. Ray queries go to Embree, which picks its own
    instruction set."""
    import ctypes
    import drjit as dr

    lib = ctypes.CDLL(str(Path(dr.__file__).parent / "libdrjit-core.so"))
    set_target = getattr(lib, "_Z19jit_llvm_set_targetPKcS0_j")
    set_target(b"haswell", b"+avx2,+fma,-avx512f,-avx512vl,-avx512dq,-avx512bw", 8)
    width = getattr(lib, "_Z21jit_llvm_vector_widthv")()
    print(f"Dr.Jit LLVM target set to haswell (AVX2), vector width {width}")


def parse_size(s: str) -> tuple[int, int]:
    m = re.fullmatch(r"\s*(\d+)\s*(?:[xX*]\s*(\d+))?\s*", s)
    if not m:
        raise argparse.ArgumentTypeError(f"bad --size {s!r}; use 512 or 640x480")
    w = int(m.group(1))
    h = int(m.group(2)) if m.group(2) else w
    return w, h


def cornell_dict(mi, width: int, height: int, spp: int, max_depth: int, rfilter: str = "box") -> dict:
    """mi.cornell_box() with lumo's render settings; geometry/materials/camera untouched."""
    d = mi.cornell_box()
    d["integrator"] = {"type": "path", "max_depth": max_depth}  # rr_depth stays at the default 5
    film = d["sensor"]["film"]
    film["width"], film["height"] = width, height
    film["rfilter"] = {"type": rfilter}
    film["pixel_format"] = "rgb"
    film["component_format"] = "float32"
    d["sensor"]["sampler"] = {"type": "independent", "sample_count": spp}
    return d


def _cpu_seconds() -> float:
    """User+system CPU time of this process (all threads)."""
    import resource

    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def render_once(mi, scene, seed: int = 0, spp: int | None = None, cpu: list | None = None):
    """Render and force evaluation; returns (numpy HxWx3 float32, wall seconds).

    If `cpu` is a list, the render's process CPU seconds are appended to it."""
    import drjit as dr
    import numpy as np

    c0 = _cpu_seconds()
    t0 = time.perf_counter()
    img = mi.render(scene, seed=seed, spp=spp or 0)
    dr.eval(img)
    dr.sync_thread()
    arr = np.array(img, dtype=np.float32)
    dt = time.perf_counter() - t0
    if cpu is not None:
        cpu.append(_cpu_seconds() - c0)
    return arr[..., :3], dt


def region_means(img) -> dict:
    h, w = img.shape[:2]
    out = {}
    for name, (fx0, fx1, fy0, fy1) in REGIONS.items():
        x0, x1 = round(fx0 * w), round(fx1 * w)
        y0, y1 = round(fy0 * h), round(fy1 * h)
        out[name] = [float(v) for v in img[y0:y1, x0:x1].reshape(-1, 3).astype("float64").mean(axis=0)]
    return out


def mean_rgb(img) -> list[float]:
    return [float(v) for v in img.reshape(-1, 3).astype("float64").mean(axis=0)]


def machine_info() -> dict:
    cpu = platform.processor() or ""
    try:
        for line in open("/proc/cpuinfo"):
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return {"nproc": os.cpu_count(), "cpu_model": cpu, "platform": platform.platform()}


# ----------------------------------------------------------------------------- Mitsuba benchmark


def bench_mitsuba(mi, width, height, spp, max_depth, runs):
    scene = mi.load_dict(cornell_dict(mi, width, height, spp, max_depth))
    img, warm = render_once(mi, scene, seed=0)
    times, cpu = [], []
    for i in range(runs):
        img, dt = render_once(mi, scene, seed=i + 1, cpu=cpu)
        times.append(dt)
    med = statistics.median(times)
    n = width * height * spp
    return {
        "cpu_s": cpu,
        # samples per CPU-second x cores: what an idle machine would give if Mitsuba
        # scaled perfectly; a sanity check when other processes share the cores.
        "samples_per_cpu_s": n / statistics.median(cpu),
        "warmup_s": warm,
        "times_s": times,
        "median_s": med,
        "samples_per_s": n / med,
        "warmup_samples_per_s": n / warm,
        "image": img,
    }


# ----------------------------------------------------------------------------- lumo

_SPS_RE = re.compile(r"([0-9]+(?:\.[0-9]*)?(?:[eE][-+]?[0-9]+)?)\s*([kKMG]?)\s*samples/s")
_PREFIX = {"": 1.0, "k": 1e3, "K": 1e3, "M": 1e6, "G": 1e9}


def parse_samples_per_s(text: str) -> float | None:
    """Number before 'samples/s' on the last line that has one (k/M/G prefixes allowed)."""
    for line in reversed(text.splitlines()):
        m = _SPS_RE.search(line)
        if m:
            return float(m.group(1)) * _PREFIX[m.group(2)]
    return None


def run_lumo(args, width, height, out_path: Path):
    common = [
        "render", "cornell",
        "--pipeline", "none",
        "--spp", str(args.spp),
        "--max-depth", str(args.max_depth),
        "--size", f"{width}x{height}",
        "-o", str(out_path),
    ]
    if args.lumo_bin:
        cmd = [args.lumo_bin] + common
    else:
        cmd = ["cargo", "run", "--release", "-p", "lumo-cli", "--"] + common
    cmd += args.lumo_arg
    print("$", " ".join(cmd), flush=True)
    if out_path.exists():
        out_path.unlink()
    import resource

    c0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    env = dict(os.environ)
    if args.avx2:
        env["LUMO_SIMD"] = "avx2"
    p = subprocess.run(cmd, cwd=REPO, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    wall = time.perf_counter() - t0
    c1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    # CPU seconds of the whole lumo process (scene setup, BVH, EXR writing included; with
    # `cargo run` also cargo's own check), an upper bound on the render's CPU time.
    cpu = (c1.ru_utime - c0.ru_utime) + (c1.ru_stime - c0.ru_stime)
    if p.returncode != 0:
        sys.stdout.write(p.stdout[-4000:])
        raise SystemExit(f"lumo failed with exit code {p.returncode}")
    lines = [l for l in p.stdout.splitlines() if l.strip()]
    tail = "\n".join(lines[-3:])
    print(tail)
    sps = parse_samples_per_s(p.stdout)
    if sps is None:
        print("warning: could not find '<n> [k|M|G] samples/s' in lumo's output", file=sys.stderr)
    return {"samples_per_s": sps, "wall_s": wall, "cpu_s": cpu, "cmd": cmd}


def read_exr(path: Path, mi=None):
    """HxWx3 float32 numpy array from an EXR (via mi.Bitmap, else the OpenEXR package)."""
    import numpy as np

    if mi is not None:
        try:
            bmp = mi.Bitmap(str(path))
            bmp = bmp.convert(mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.Float32, srgb_gamma=False)
            return np.array(bmp, dtype=np.float32)
        except Exception as e:  # pragma: no cover - fall back below
            print(f"mi.Bitmap could not read {path}: {e}; trying OpenEXR", file=sys.stderr)
    import OpenEXR

    with OpenEXR.File(str(path)) as f:
        ch = f.channels()
        if "RGB" in ch:
            arr = np.asarray(ch["RGB"].pixels, dtype=np.float32)
        elif "RGBA" in ch:
            arr = np.asarray(ch["RGBA"].pixels, dtype=np.float32)[..., :3]
        else:
            arr = np.stack([np.asarray(ch[c].pixels, dtype=np.float32) for c in ("R", "G", "B")], axis=-1)
    return arr


# ----------------------------------------------------------------------------- reference mode


def write_reference(mi, args) -> None:
    import numpy as np

    out_dir = Path(args.ref_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    width, height = args.size
    chunk = min(args.chunk_spp, args.ref_spp)
    assert args.ref_spp % chunk == 0, "--ref-spp must be a multiple of --chunk-spp"
    passes = args.ref_spp // chunk
    entries = []
    for depth in args.ref_depths:
        scene = mi.load_dict(cornell_dict(mi, width, height, chunk, depth))
        _, warm = render_once(mi, scene, seed=10_000)  # JIT warm-up, not part of the result
        acc = np.zeros((height, width, 3), dtype=np.float64)
        load_before = os.getloadavg()
        t0 = time.perf_counter()
        for i in range(passes):
            img, _ = render_once(mi, scene, seed=i)  # independent sampler, distinct seeds
            acc += img
        secs = time.perf_counter() - t0
        img = (acc / passes).astype(np.float32)
        name = f"mitsuba_cornell_d{depth}.exr"
        path = out_dir / name
        mi.Bitmap(img, mi.Bitmap.PixelFormat.RGB).write(str(path))
        saved = {"file": name, "width": width, "height": height, "downsampled": False}
        if path.stat().st_size >= 4 * 1024 * 1024:
            f = max(1, width // 128)
            small = img[: height // f * f, : width // f * f].reshape(height // f, f, width // f, f, 3).mean(axis=(1, 3))
            mi.Bitmap(small.astype(np.float32), mi.Bitmap.PixelFormat.RGB).write(str(path))
            saved.update(width=width // f, height=height // f, downsampled=True, box_factor=f)
        n = width * height * args.ref_spp
        e = {
            "mitsuba_version": mi.__version__,
            "variant": mi.variant(),
            "scene": "mitsuba.cornell_box() with integrator/film/rfilter/sampler overridden",
            "width": width,
            "height": height,
            "spp": args.ref_spp,
            "max_depth": depth,
            "rr_depth": 5,
            "integrator": "path",
            "sampler": "independent",
            "rfilter": "box",
            "film": "hdrfilm rgb float32",
            "mean_rgb": mean_rgb(img),
            "quadrant_means": {k: v for k, v in region_means(img).items() if k in
                               ("top_left", "top_right", "bottom_left", "bottom_right")},
            "region_means": {k: v for k, v in region_means(img).items() if k in PATCHES_512},
            "region_bounds_px_512": {k: list(v) for k, v in PATCHES_512.items()},
            "image": saved,
            "render_seconds": secs,
            "render_passes": f"{passes} x {chunk} spp (seeds 0..{passes - 1}), averaged",
            "warmup_seconds": warm,
            "samples_per_s": n / secs,
            "loadavg_1_5_15_before": [round(x, 2) for x in load_before],
            "loadavg_1_5_15_after": [round(x, 2) for x in os.getloadavg()],
            "machine": machine_info(),
        }
        print(json.dumps({k: v for k, v in e.items() if k != "machine"}, indent=1), flush=True)
        entries.append(e)
    REFERENCE_JSON.parent.mkdir(parents=True, exist_ok=True)
    out_json = out_dir / REFERENCE_JSON.name
    out_json.write_text(json.dumps(entries, indent=2) + "\n")
    print("wrote", out_json)


# ----------------------------------------------------------------------------- main


def fmt_rgb(v) -> str:
    return "(" + ", ".join(f"{x:.5f}" for x in v) + ")"


def rel(a, b) -> list[float]:
    return [(x - y) / y if y != 0 else float("nan") for x, y in zip(a, b)]


def fmt_rel(v) -> str:
    return "(" + ", ".join(f"{100 * x:+.2f}%" for x in v) + ")"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--size", type=parse_size, default=(512, 512), help="N or WxH (default 512)")
    ap.add_argument("--spp", type=int, default=16)
    ap.add_argument("--max-depth", type=int, default=5)
    ap.add_argument("--runs", type=int, default=3, help="timed Mitsuba renders after the warm-up, and lumo renders (medians)")
    ap.add_argument("--variant", default="llvm_ad_rgb", help="Mitsuba variant (default llvm_ad_rgb)")
    ap.add_argument("--lumo-bin", help="prebuilt lumo binary instead of `cargo run --release -p lumo-cli --`")
    ap.add_argument("--lumo-arg", action="append", default=[], help="extra argument passed to lumo (repeatable)")
    ap.add_argument("--lumo-out", default="/tmp/lumo_cornell.exr")
    ap.add_argument("--mitsuba-out", help="also write Mitsuba's (last timed) image to this EXR")
    ap.add_argument("--mitsuba-only", action="store_true", help="skip lumo")
    ap.add_argument("--avx2", action="store_true",
                    help="both in their AVX2 forms: Dr.Jit's LLVM target haswell (8 lanes), lumo with LUMO_SIMD=avx2")
    ap.add_argument("--reference", action="store_true", help="write converged reference EXRs + JSON, then exit")
    ap.add_argument("--ref-spp", type=int, default=1024)
    ap.add_argument("--chunk-spp", type=int, default=64, help="spp per render pass in --reference mode")
    ap.add_argument("--ref-depths", type=int, nargs="+", default=[2, 3, 5])
    ap.add_argument("--ref-dir", default=str(REFERENCE_JSON.parent))
    args = ap.parse_args()

    mi = import_mitsuba(args.variant, args.avx2)
    print(f"mitsuba {mi.__version__}, variant {mi.variant()}, DRJIT_LIBLLVM_PATH={os.environ.get('DRJIT_LIBLLVM_PATH')}")
    m = machine_info()
    print(f"machine: {m['nproc']} cores, {m['cpu_model']}")

    if args.reference:
        write_reference(mi, args)
        return

    width, height = args.size
    n = width * height * args.spp
    print(f"\n== Mitsuba: {width}x{height}, {args.spp} spp, max_depth {args.max_depth}, box filter")
    mb = bench_mitsuba(mi, width, height, args.spp, args.max_depth, args.runs)
    print(f"warm-up render (incl. JIT/kernel-cache): {mb['warmup_s']:.3f} s = {mb['warmup_samples_per_s'] / 1e6:.3f} M samples/s")
    print("timed renders: " + ", ".join(f"{t:.3f} s" for t in mb["times_s"]))
    print(f"median: {mb['median_s']:.3f} s = {mb['samples_per_s'] / 1e6:.3f} M samples/s"
          f"   (load average now: {os.getloadavg()[0]:.2f} on {os.cpu_count()} cores)")
    print(f"CPU time per render: " + ", ".join(f"{t:.3f} s" for t in mb["cpu_s"])
          + f" -> {mb['samples_per_cpu_s'] / 1e6:.3f} M samples per CPU-second"
          + f" (x {os.cpu_count()} cores = {mb['samples_per_cpu_s'] * os.cpu_count() / 1e6:.3f} M/s if the machine were idle)")
    m_img = mb["image"]
    if args.mitsuba_out:
        mi.Bitmap(m_img, mi.Bitmap.PixelFormat.RGB).write(args.mitsuba_out)
    m_mean = mean_rgb(m_img)
    print(f"Mitsuba mean RGB: {fmt_rgb(m_mean)}")

    ref = None
    if REFERENCE_JSON.exists():
        try:
            for e in json.loads(REFERENCE_JSON.read_text()):
                if e.get("max_depth") == args.max_depth:
                    ref = e
        except (ValueError, TypeError):
            pass
    if ref:
        print(f"reference ({ref['spp']} spp) mean RGB: {fmt_rgb(ref['mean_rgb'])}; "
              f"this Mitsuba render vs reference: {fmt_rel(rel(m_mean, ref['mean_rgb']))}")

    if args.mitsuba_only:
        return

    print(f"\n== lumo: {width}x{height}, {args.spp} spp, max_depth {args.max_depth}")
    # As many renders as Mitsuba's timed ones, medians of both: one render scatters by a few
    # per cent on a shared machine.
    runs = [run_lumo(args, width, height, Path(args.lumo_out)) for _ in range(max(1, args.runs))]
    lr = dict(runs[0])
    lr["wall_s"] = statistics.median(r["wall_s"] for r in runs)
    lr["cpu_s"] = statistics.median(r["cpu_s"] for r in runs)
    if all(r["samples_per_s"] is not None for r in runs):
        lr["samples_per_s"] = statistics.median(r["samples_per_s"] for r in runs)
        print("lumo renders: " + ", ".join(f"{r['samples_per_s'] / 1e6:.3f} M samples/s" for r in runs))
    l_img = read_exr(Path(args.lumo_out), mi)
    if l_img.shape[:2] != (height, width):
        print(f"warning: lumo image is {l_img.shape[1]}x{l_img.shape[0]}, expected {width}x{height}", file=sys.stderr)
    l_mean = mean_rgb(l_img)

    print("\n== comparison")
    print(f"Mitsuba samples/s: {mb['samples_per_s'] / 1e6:10.3f} M   (median of {args.runs}, {mb['median_s']:.3f} s)")
    if lr["samples_per_s"] is not None:
        print(f"lumo    samples/s: {lr['samples_per_s'] / 1e6:10.3f} M   (median of {len(runs)} as printed by lumo; process wall {lr['wall_s']:.2f} s)")
        print(f"ratio lumo/mitsuba: {lr['samples_per_s'] / mb['samples_per_s']:.3f}")
    else:
        wall_sps = n / lr["wall_s"]
        print(f"lumo samples/s not printed; from process wall time (incl. startup/build): {wall_sps / 1e6:.3f} M")
        print(f"ratio lumo/mitsuba (wall-time based): {wall_sps / mb['samples_per_s']:.3f}")
    # On a machine shared with other work, wall time depends on what else runs; CPU time per
    # sample does much less, so print that ratio too (lumo's includes its process start-up).
    l_cpu_sps = n / lr["cpu_s"] if lr["cpu_s"] > 0 else float("nan")
    print(f"samples per CPU-second: mitsuba {mb['samples_per_cpu_s'] / 1e6:.3f} M, "
          f"lumo {l_cpu_sps / 1e6:.3f} M (whole process, {lr['cpu_s']:.2f} CPU-s)")
    print(f"ratio lumo/mitsuba per CPU-second: {l_cpu_sps / mb['samples_per_cpu_s']:.3f}")
    print(f"mean RGB  mitsuba: {fmt_rgb(m_mean)}")
    print(f"mean RGB  lumo   : {fmt_rgb(l_mean)}")
    print(f"rel diff (lumo-mitsuba)/mitsuba: {fmt_rel(rel(l_mean, m_mean))}")
    if ref:
        print(f"rel diff lumo vs {ref['spp']}-spp reference: {fmt_rel(rel(l_mean, ref['mean_rgb']))}")
    if l_img.shape == m_img.shape:
        lr_, mr_ = region_means(l_img), region_means(m_img)
        print("\nregion means (lumo | mitsuba | rel diff):")
        for k in REGIONS:
            print(f"  {k:16s} {fmt_rgb(lr_[k])} | {fmt_rgb(mr_[k])} | {fmt_rel(rel(lr_[k], mr_[k]))}")


if __name__ == "__main__":
    main()
