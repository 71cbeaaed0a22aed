#!/usr/bin/env python3
"""Render the Mitsuba validation suite's references with Mitsuba 3.

Every scene in tests/data/mitsuba/scenes/*.xml is rendered by Mitsuba 3 at 64x64 (the files'
`$res`) with many samples per pixel, in independent passes of `--spp / --passes` samples with
different seeds (averaged), and written as a half-float RGB OpenEXR to
tests/data/mitsuba/refs/NAME.exr. tests/data/mitsuba/references.json records the Mitsuba
version, variant, samples, the noise left in each reference (standard error of the image mean
and the largest of the 16x16 block means, relative, from the spread of the passes), the time and
the machine. The Rust test crates/lumo-render/tests/integration/mitsuba_suite.rs compares lumo against the
stored files; CI never needs Mitsuba.

The textures the scenes use (tests/data/mitsuba/textures/) are written by this script too when
they are missing, from closed-form patterns (numpy only), so the suite needs no downloaded data.

Install (Debian/Ubuntu x86_64):
    python3 -m venv .venv-mi && .venv-mi/bin/pip install mitsuba numpy
    apt-get install -y libllvm19          # for the llvm_ad_rgb variant (see compare_mitsuba.py)

Usage:
    .venv-mi/bin/python scripts/mitsuba_refs.py                 # every scene, 4096 spp
    .venv-mi/bin/python scripts/mitsuba_refs.py spot_light --spp 16384
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time
from pathlib import Path

from compare_mitsuba import ensure_llvm_path

REPO = Path(__file__).resolve().parent.parent
SUITE = REPO / "tests" / "data" / "mitsuba"
BLOCK = 16


def write_textures(mi, np) -> None:
    """The suite's textures, from closed-form patterns (deterministic)."""
    tex = SUITE / "textures"
    tex.mkdir(parents=True, exist_ok=True)
    sky = tex / "sky.exr"
    if not sky.exists():
        # Lat-long 64x32: a blue gradient sky, a dark ground and a small bright sun.
        h, w = 32, 64
        v = (np.arange(h) + 0.5) / h
        u = (np.arange(w) + 0.5) / w
        theta = v[:, None] * np.pi
        phi = u[None, :] * 2 * np.pi
        up = np.cos(theta) * np.ones_like(phi)
        img = np.zeros((h, w, 3), np.float32)
        sky_col = np.stack([0.3 + 0.3 * up, 0.5 + 0.3 * up, 0.9 + 0.2 * up], -1)
        ground = np.array([0.15, 0.12, 0.1])
        img[:] = np.where(up[..., None] > 0, sky_col, ground)
        sun = np.exp(-(((theta - 0.6) / 0.08) ** 2 + ((phi - 1.2) / 0.12) ** 2))
        img += (sun * 60.0)[..., None] * np.array([1.0, 0.9, 0.7])
        mi.Bitmap(img.astype(np.float32)).write(str(sky))
    grid = tex / "grid8.png"
    if not grid.exists():
        # 8x8 texels of distinct colours: magnified, nearest and bilinear lookups differ.
        i, j = np.meshgrid(np.arange(8), np.arange(8), indexing="ij")
        img = np.stack([(i * 37 + j * 11) % 256, (j * 53 + 40) % 256, ((i + j) % 2) * 200 + 30], -1)
        mi.Bitmap(img.astype(np.uint8)).write(str(grid))
    rough = tex / "checker_rough.png"
    if not rough.exists():
        # 8x8 squares of roughness 64/255 and 230/255 (read raw), 64/255 where the square's
        # column + row is even: the pattern a `checkerboard` of 0.25 / 0.9 with `to_uv` scale 4
        # has where it is read as a colour. Its `eval_1` (roughness, alpha) swaps the two in
        # Mitsuba 3.9.1 (scripts/mitsuba_checkerboard_eval1.py), so the suite uses a bitmap.
        i, j = np.meshgrid(np.arange(8), np.arange(8), indexing="xy")
        img = np.where((i + j) % 2 == 0, 64, 230).astype(np.uint8)[..., None]
        mi.Bitmap(img).write(str(rough))
    smoke = tex / "smoke.vol"
    if not smoke.exists():
        write_smoke_vol(np, smoke)
    height = tex / "bumps_height.png"
    normal = tex / "bumps_normal.png"
    if not height.exists() or not normal.exists():
        n = 128
        y, x = np.meshgrid((np.arange(n) + 0.5) / n, (np.arange(n) + 0.5) / n, indexing="ij")
        hgt = 0.5 + 0.5 * np.sin(2 * np.pi * 4 * x) * np.sin(2 * np.pi * 4 * y)
        mi.Bitmap((hgt * 255).round().astype(np.uint8)[..., None]).write(str(height))
        # Tangent-space normals of the same bumps (slope scaled for a visible effect).
        dx = np.cos(2 * np.pi * 4 * x) * np.sin(2 * np.pi * 4 * y)
        dy = np.sin(2 * np.pi * 4 * x) * np.cos(2 * np.pi * 4 * y)
        nrm = np.stack([-0.6 * dx, -0.6 * dy, np.ones_like(x)], -1)
        nrm /= np.linalg.norm(nrm, axis=-1, keepdims=True)
        mi.Bitmap(((nrm * 0.5 + 0.5) * 255).round().astype(np.uint8)).write(str(normal))


def write_smoke_vol(np, path: Path, n: int = 24) -> None:
    """A puff of smoke as a Mitsuba .vol grid (n^3 float32 densities in [0, 1], x fastest):
    a few soft Gaussian lumps with a ridged modulation, zero at the faces of the cube."""
    c = (np.arange(n) + 0.5) / n
    z, y, x = np.meshgrid(c, c, c, indexing="ij")
    d = np.zeros_like(x)
    for (cx, cy, cz, r, w) in [
        (0.5, 0.45, 0.5, 0.22, 1.0),
        (0.35, 0.6, 0.45, 0.15, 0.8),
        (0.65, 0.62, 0.55, 0.14, 0.7),
        (0.5, 0.75, 0.4, 0.12, 0.6),
    ]:
        d += w * np.exp(-((x - cx) ** 2 + (y - cy) ** 2 + (z - cz) ** 2) / (2 * r * r))
    d *= 0.75 + 0.25 * np.sin(23 * x) * np.sin(17 * y + 1) * np.sin(19 * z + 2)
    edge = np.minimum.reduce([x, 1 - x, y, 1 - y, z, 1 - z])
    d *= np.clip(edge / 0.1, 0, 1)
    d = np.clip(d, 0, None).astype("<f4")
    header = b"VOL" + bytes([3]) + np.array([1, n, n, n, 1], "<i4").tobytes()
    header += np.array([0, 0, 0, 1, 1, 1], "<f4").tobytes()
    path.write_bytes(header + d.tobytes())


def block_means(np, img):
    h, w = img.shape[:2]
    return img[: h // BLOCK * BLOCK, : w // BLOCK * BLOCK].reshape(
        h // BLOCK, BLOCK, w // BLOCK, BLOCK, -1
    ).mean(axis=(1, 3))


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("scenes", nargs="*", help="scene names (default: all)")
    ap.add_argument("--spp", type=int, default=4096)
    ap.add_argument("--passes", type=int, default=8)
    ap.add_argument("--variant", default="llvm_ad_rgb")
    ap.add_argument(
        "--spectral-variant",
        default="llvm_ad_spectral",
        help="variant for the scenes named spectral_* (lumo renders them with spectral transport)",
    )
    args = ap.parse_args()

    if args.variant.startswith("llvm") or args.spectral_variant.startswith("llvm"):
        ensure_llvm_path()
    import mitsuba as mi
    import numpy as np

    mi.set_variant(args.variant)
    write_textures(mi, np)
    (SUITE / "refs").mkdir(exist_ok=True)
    record_path = SUITE / "references.json"
    record = json.loads(record_path.read_text()) if record_path.exists() else {"scenes": {}}
    names = args.scenes or sorted(p.stem for p in (SUITE / "scenes").glob("*.xml"))
    per_pass = max(1, args.spp // args.passes)
    for name in names:
        path = SUITE / "scenes" / f"{name}.xml"
        if not path.exists():
            print(f"{path}: no such scene", file=sys.stderr)
            return 2
        variant = args.spectral_variant if name.startswith("spectral_") else args.variant
        mi.set_variant(variant)
        t0 = time.time()
        scene = mi.load_file(str(path), spp=str(per_pass))
        passes = []
        for k in range(args.passes):
            passes.append(np.array(mi.render(scene, spp=per_pass, seed=1000 + k))[..., :3])
        stack = np.stack(passes)
        img = stack.mean(axis=0)
        seconds = time.time() - t0
        mean = img.mean(axis=(0, 1))
        # Standard errors from the spread of the passes.
        se_mean = stack.mean(axis=(1, 2)).std(axis=0, ddof=1) / np.sqrt(args.passes)
        blocks = np.stack([block_means(np, p) for p in passes])
        se_blocks = blocks.std(axis=0, ddof=1) / np.sqrt(args.passes)
        floor = np.maximum(block_means(np, img), 0.1 * mean)
        mi.Bitmap(img.astype(np.float32)).convert(
            component_format=mi.Struct.Type.Float16
        ).write(str(SUITE / "refs" / f"{name}.exr"))
        record["scenes"][name] = {
            "spp": per_pass * args.passes,
            "mean_rgb": [float(x) for x in mean],
            "mean_rel_se": float((se_mean / np.maximum(mean, 1e-9)).max()),
            "block_rel_se_max": float((se_blocks / floor).max()),
            "seconds": round(seconds, 2),
            "variant": variant,
        }
        print(
            f"{name:28s} mean {mean[0]:.4f} {mean[1]:.4f} {mean[2]:.4f}  "
            f"rel. s.e. mean {record['scenes'][name]['mean_rel_se']:.4f}  "
            f"worst block {record['scenes'][name]['block_rel_se_max']:.4f}  {seconds:.1f} s",
            flush=True,
        )
    record.update(
        {
            "mitsuba_version": mi.__version__,
            "variant": args.variant,
            "resolution": "64x64 (the scenes' $res default)",
            "film": "hdrfilm, box reconstruction filter; stored as half-float RGB EXR",
            "machine": f"{platform.processor() or platform.machine()}, {os.cpu_count()} threads",
        }
    )
    record["scenes"] = dict(sorted(record["scenes"].items()))
    record_path.write_text(json.dumps(record, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
