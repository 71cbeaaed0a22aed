#!/usr/bin/env python3
"""Render one Mitsuba XML scene in Mitsuba 3 and in lumo at the same settings and compare.

Default scene: scenes/compare/materials_compare.xml (a rough conductor, a rough plastic, a
textured diffuse floor and a PLY mesh; see docs/mitsuba-materials.md).

Both renderers get the same file, size, samples per pixel and path depth (through the file's
`$res`, `$spp` and `$max_depth` parameters). Each renders --chunks independent passes of
spp/chunks samples with different seeds (Mitsuba's LLVM variant would otherwise hold every
sample of the image in memory at once); the passes are averaged, and their spread gives the
standard error of each mean. The script prints and writes (--markdown):

* mean RGB of both images, the per-channel ratio lumo / Mitsuba and its standard error;
* relMSE = mean over pixels and channels of (lumo - mitsuba)^2 / (mitsuba^2 + eps),
  eps = 1e-2, and the part of it that noise alone explains (from the two halves of the passes);
* the same means for a few regions of the image (each mostly one object), to tell which
  material a difference comes from;
* optionally (--png) a side-by-side image: Mitsuba | lumo | 4x |difference|.

Install (Debian/Ubuntu x86_64; see also scripts/compare_mitsuba.py):
    python3 -m venv .venv-mi && .venv-mi/bin/pip install mitsuba numpy
    apt-get install -y libllvm19
    export DRJIT_LIBLLVM_PATH=/usr/lib/x86_64-linux-gnu/libLLVM-19.so   # set here if unset

Example:
    cargo build --release -p lumo-cli
    .venv-mi/bin/python scripts/compare_mitsuba_scene.py --spp 1024 \\
        --markdown /tmp/cmp.md --png docs/images/mitsuba-materials.png
"""

from __future__ import annotations

import argparse
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

# The libLLVM search of the Cornell comparison (same folder, standard library only).
from compare_mitsuba import ensure_llvm_path

REPO = Path(__file__).resolve().parent.parent
DEFAULT_SCENE = REPO / "scenes" / "compare" / "materials_compare.xml"
EPS = 1e-2

# Regions as fractions of the image (x0, x1, y0, y1), y downwards; each lies mostly on one
# object of materials_compare.xml at its default camera.
REGIONS = {
    "conductor sphere": (0.16, 0.33, 0.38, 0.56),
    "plastic cube": (0.45, 0.62, 0.40, 0.54),
    "PLY pyramid": (0.70, 0.84, 0.50, 0.66),
    "textured floor": (0.30, 0.70, 0.78, 0.98),
    "back wall": (0.05, 0.95, 0.05, 0.25),
}


def import_mitsuba(variant: str):
    ensure_llvm_path()
    import mitsuba as mi  # noqa: E402  (DRJIT_LIBLLVM_PATH must be set first)

    try:
        mi.set_variant(variant)
    except Exception as e:  # noqa: BLE001  (fall back to the CPU variant without LLVM)
        print(f"variant {variant} unavailable ({e}); using scalar_rgb", file=sys.stderr)
        mi.set_variant("scalar_rgb")
    return mi


def render_mitsuba(mi, scene_path: Path, res: int, spp: int, depth: int, chunks: int):
    """List of `chunks` HxWx3 float64 passes of spp/chunks samples each, and wall seconds."""
    import drjit as dr
    import numpy as np

    per = spp // chunks
    scene = mi.load_file(str(scene_path), res=str(res), spp=str(per), max_depth=str(depth))
    passes = []
    t0 = time.perf_counter()
    for i in range(chunks):
        img = mi.render(scene, seed=1000 + i, spp=per)
        dr.eval(img)
        passes.append(np.array(img, dtype=np.float64)[..., :3])
    return passes, time.perf_counter() - t0


def read_exr(mi, path: Path):
    import numpy as np

    bmp = mi.Bitmap(str(path)).convert(
        mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.Float32, srgb_gamma=False
    )
    return np.array(bmp, dtype=np.float64)


def render_lumo(mi, lumo: Path, scene_path: Path, res: int, spp: int, depth: int, chunks: int):
    per = spp // chunks
    passes = []
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        for i in range(chunks):
            out = Path(tmp) / f"pass{i}.exr"
            cmd = [
                str(lumo), "render", str(scene_path), "--pipeline", "none",
                "-D", f"res={res}", "-D", f"spp={per}", "-D", f"max_depth={depth}",
                "--spp", str(per), "--max-depth", str(depth),
                "--seed", str(1000 + i), "-o", str(out),
            ]
            r = subprocess.run(cmd, capture_output=True, text=True)
            if r.returncode != 0:
                sys.exit(f"lumo failed ({' '.join(cmd)}):\n{r.stdout}\n{r.stderr}")
            if i == 0 and "warning" in r.stderr:
                print("lumo warnings:\n" + r.stderr.strip(), file=sys.stderr)
            passes.append(read_exr(mi, out))
    return passes, time.perf_counter() - t0


def stats(passes):
    """(mean image, per-channel mean, per-channel standard error of that mean)."""
    import numpy as np

    means = np.array([p.reshape(-1, 3).mean(axis=0) for p in passes])
    img = np.mean(passes, axis=0)
    se = means.std(axis=0, ddof=1) / np.sqrt(len(passes))
    return img, means.mean(axis=0), se


def rel_mse(a, ref):
    import numpy as np

    return float(np.mean((a - ref) ** 2 / (ref**2 + EPS)))


def halves_rel_mse(passes):
    """relMSE between the averages of the two halves of the passes (pure noise)."""
    import numpy as np

    h = len(passes) // 2
    a, b = np.mean(passes[:h], axis=0), np.mean(passes[h : 2 * h], axis=0)
    return rel_mse(a, b)


def region_mean(img, frac):
    h, w = img.shape[:2]
    x0, x1, y0, y1 = frac
    sub = img[round(y0 * h) : round(y1 * h), round(x0 * w) : round(x1 * w)]
    return sub.reshape(-1, 3).mean(axis=0)


def write_png(mi, path: Path, mitsuba_img, lumo_img):
    import numpy as np

    diff = np.abs(lumo_img - mitsuba_img) * 4.0
    strip = np.concatenate([mitsuba_img, lumo_img, diff], axis=1).astype(np.float32)
    bmp = mi.Bitmap(strip, mi.Bitmap.PixelFormat.RGB)
    bmp.convert(mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.UInt8, srgb_gamma=True).write(str(path))


def cpu_model() -> str:
    try:
        for line in open("/proc/cpuinfo"):
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor()


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("scene", nargs="?", type=Path, default=DEFAULT_SCENE)
    ap.add_argument("--res", type=int, default=256, help="the scene's $res (film width; the height is what the scene says)")
    ap.add_argument("--spp", type=int, default=1024)
    ap.add_argument("--max-depth", type=int, default=6)
    ap.add_argument("--chunks", type=int, default=16, help="independent passes per renderer")
    ap.add_argument("--variant", default="llvm_ad_rgb")
    ap.add_argument("--lumo-bin", type=Path, default=REPO / "target" / "release" / "lumo")
    ap.add_argument("--markdown", type=Path, help="write the summary table here")
    ap.add_argument("--png", type=Path, help="write Mitsuba | lumo | 4x|diff| here")
    args = ap.parse_args()
    if args.spp % args.chunks or args.chunks < 2:
        sys.exit("--spp must be a multiple of --chunks, and --chunks at least 2")
    if not args.lumo_bin.exists():
        sys.exit(f"{args.lumo_bin} not found: cargo build --release -p lumo-cli")

    import numpy as np

    mi = import_mitsuba(args.variant)
    scene = args.scene.resolve()
    print(f"mitsuba {mi.__version__} ({mi.variant()}), {scene.relative_to(REPO)}, $res={args.res}")
    mi_passes, mi_s = render_mitsuba(mi, scene, args.res, args.spp, args.max_depth, args.chunks)
    lu_passes, lu_s = render_lumo(
        mi, args.lumo_bin, scene, args.res, args.spp, args.max_depth, args.chunks
    )
    if mi_passes[0].shape != lu_passes[0].shape:
        sys.exit(f"image sizes differ: Mitsuba {mi_passes[0].shape}, lumo {lu_passes[0].shape}")
    h, w = mi_passes[0].shape[:2]
    setting = f"{w}x{h}, {args.spp} spp ({args.chunks} passes), max_depth {args.max_depth}"
    mi_img, mi_mean, mi_se = stats(mi_passes)
    lu_img, lu_mean, lu_se = stats(lu_passes)
    ratio = lu_mean / mi_mean
    ratio_se = ratio * np.sqrt((lu_se / lu_mean) ** 2 + (mi_se / mi_mean) ** 2)
    err = rel_mse(lu_img, mi_img)
    # Each full image has a quarter of the noise variance of the difference of its halves.
    noise = (halves_rel_mse(mi_passes) + halves_rel_mse(lu_passes)) / 4.0

    rows = []
    fmt3 = lambda v: ", ".join(f"{x:.4f}" for x in v)  # noqa: E731
    rows.append(("whole image", mi_mean, lu_mean, ratio))
    # The regions lie on the objects of the default scene only.
    for name, frac in (REGIONS.items() if scene == DEFAULT_SCENE.resolve() else []):
        a, b = region_mean(mi_img, frac), region_mean(lu_img, frac)
        rows.append((name, a, b, b / a))
    lines = [
        f"Scene `{scene.relative_to(REPO)}`, {setting}; Mitsuba {mi.__version__} "
        f"`{mi.variant()}`; machine: {os.cpu_count()} vCPU {cpu_model()}.",
        "",
        "| region | Mitsuba mean RGB | lumo mean RGB | lumo / Mitsuba (R, G, B) |",
        "| --- | --- | --- | --- |",
    ]
    for name, a, b, r in rows:
        lines.append(f"| {name} | {fmt3(a)} | {fmt3(b)} | {fmt3(r)} |")
    lines += [
        "",
        f"Whole-image ratio standard error (from the {args.chunks} passes): {fmt3(ratio_se)}.",
        f"relMSE (eps = {EPS}): {err:.5f}; of which noise alone explains about {noise:.5f}.",
        f"Render wall time on this machine: Mitsuba {mi_s:.1f} s, lumo {lu_s:.1f} s "
        "(not a benchmark: other processes shared the cores).",
    ]
    text = "\n".join(lines)
    print(text)
    worst = float(np.max(np.abs(ratio - 1.0)))
    print(f"largest whole-image channel difference: {100 * worst:.2f} % (target: 1 %)")
    if args.markdown:
        args.markdown.write_text(text + "\n")
    if args.png:
        write_png(mi, args.png, mi_img, lu_img)


if __name__ == "__main__":
    main()
