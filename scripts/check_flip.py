#!/usr/bin/env python3
"""Reference numbers for lumo's own LDR-FLIP implementation.

Generates a few small, deterministic 8-bit sRGB image pairs that exercise FLIP's two pipelines
(noise, blur, colour shifts, misplaced edges, dark regions), writes them as PNG under
tests/data/flip/, evaluates them with NVIDIA's `flip-evaluator` package (LDR mode, default
67.02 ppd, sRGB input) and writes the mean FLIP and a few per-pixel values to
tests/data/flip/reference.json. The Rust test `flip_matches_flip_evaluator` in
crates/lumo-image/tests/integration/flip_reference.rs reads both.

Usage:  pip install flip-evaluator numpy
        python3 scripts/check_flip.py            # rewrite the PNGs and reference.json
        python3 scripts/check_flip.py --lumo     # also run `lumo compare` on each pair
"""

import argparse
import json
import struct
import subprocess
import sys
import zlib
from importlib.metadata import version
from pathlib import Path

import numpy as np
import flip_evaluator

ROOT = Path(__file__).resolve().parent.parent
OUT = ROOT / "tests" / "data" / "flip"
W, H = 64, 48
# Pixels whose FLIP value is also recorded, as (x, y): interior, corner and edge positions.
SAMPLES = [(0, 0), (5, 7), (31, 23), (40, 10), (63, 47), (20, 40)]


def write_png(path, rgb8):
    """Minimal 8-bit RGB PNG writer (no dependencies beyond zlib)."""
    h, w, _ = rgb8.shape
    raw = b"".join(b"\x00" + rgb8[y].tobytes() for y in range(h))

    def chunk(kind, data):
        body = kind + data
        return struct.pack(">I", len(data)) + body + struct.pack(">I", zlib.crc32(body) & 0xFFFFFFFF)

    png = b"\x89PNG\r\n\x1a\n"
    png += chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0))
    png += chunk(b"IDAT", zlib.compress(raw, 9))
    png += chunk(b"IEND", b"")
    path.write_bytes(png)


def quantise(img):
    return np.clip(np.round(img * 255.0), 0, 255).astype(np.uint8)


def pairs():
    rng = np.random.default_rng(20201)
    y, x = np.mgrid[0:H, 0:W].astype(np.float64)
    u, v = x / (W - 1), y / (H - 1)
    gradient = np.stack([u, v, 0.5 * (1 - u)], axis=-1)

    # Smooth gradient against the same with noise.
    yield "noise", gradient, gradient + rng.normal(0.0, 0.06, gradient.shape)

    # Sharp pattern (checker + thin lines) against a 3x3 box blur of it.
    checker = (((x // 6) + (y // 6)) % 2)[..., None] * np.array([0.9, 0.8, 0.7])
    checker[::9, :, :] = 0.1
    padded = np.pad(checker, ((1, 1), (1, 1), (0, 0)), mode="edge")
    blurred = sum(padded[dy:dy + H, dx:dx + W] for dy in range(3) for dx in range(3)) / 9.0
    yield "blur", checker, blurred

    # Saturated colours against a rotated hue (channel mix).
    hues = np.stack([0.5 + 0.5 * np.sin(6 * u + c * 2.1) * np.cos(4 * v) for c in range(3)], axis=-1)
    mix = np.array([[0.8, 0.2, 0.0], [0.0, 0.8, 0.2], [0.2, 0.0, 0.8]])
    yield "colour", hues, hues @ mix.T

    # A disc and bars moved by one pixel: edge and point differences.
    disc = ((x - 30) ** 2 + (y - 22) ** 2 < 12 ** 2).astype(np.float64)
    bars = ((x % 10) < 2).astype(np.float64) * 0.6
    shapes = np.stack([disc * 0.9 + bars * 0.3, disc * 0.4 + bars, disc * 0.2 + 0.1], axis=-1)
    shifted = np.roll(shapes, 1, axis=1)
    yield "shift", shapes, shifted

    # Dark image with small differences (the Hunt adjustment and sRGB toe matter here).
    dark = 0.08 * gradient + 0.02
    yield "dark", dark, dark + rng.uniform(-0.02, 0.02, dark.shape)

    # Unrelated random images: large errors, near the top of FLIP's range.
    yield "random", rng.uniform(0, 1, gradient.shape), rng.uniform(0, 1, gradient.shape)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--lumo", action="store_true", help="also print `lumo compare` for each pair")
    args = ap.parse_args()
    OUT.mkdir(parents=True, exist_ok=True)
    results = []
    for name, ref, test in pairs():
        ref8, test8 = quantise(ref), quantise(test)
        write_png(OUT / f"{name}_ref.png", ref8)
        write_png(OUT / f"{name}_test.png", test8)
        r = (ref8.astype(np.float32) / 255.0)
        t = (test8.astype(np.float32) / 255.0)
        fmap, mean, params = flip_evaluator.evaluate(r, t, "LDR", inputsRGB=True, applyMagma=False)
        fmap = fmap[:, :, 0]
        results.append({
            "name": name,
            "reference": f"{name}_ref.png",
            "test": f"{name}_test.png",
            "mean_flip": float(mean),
            "samples": [{"x": sx, "y": sy, "flip": float(fmap[sy, sx])} for sx, sy in SAMPLES],
        })
        print(f"{name:8s} mean FLIP {mean:.6f}  (ppd {params['ppd']:.4f})")
        if args.lumo:
            subprocess.run(["cargo", "run", "-q", "-p", "lumo-cli", "--", "compare",
                            str(OUT / f"{name}_ref.png"), str(OUT / f"{name}_test.png")],
                           cwd=ROOT, check=False)
    doc = {
        "generator": "scripts/check_flip.py",
        "flip_evaluator_version": version("flip-evaluator"),
        "numpy_version": np.__version__,
        "mode": "LDR, sRGB inputs, default ppd",
        "ppd": float(params["ppd"]),
        "pairs": results,
    }
    (OUT / "reference.json").write_text(json.dumps(doc, indent=2) + "\n")
    print(f"wrote {OUT / 'reference.json'}", file=sys.stderr)


if __name__ == "__main__":
    main()
