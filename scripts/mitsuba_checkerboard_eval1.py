#!/usr/bin/env python3
"""Show that Mitsuba 3's `checkerboard` swaps color0 and color1 where it is read as a number.

Mitsuba's textures have `eval` (a colour) and `eval_1` (one number: roughness, alpha, weights).
The checkerboard's `eval` puts color0 on the squares where floor(2u) + floor(2v) is even, as
its documentation and lumo do; its `eval_1` puts color1 there. So a checkerboard `roughness`
(principled) or `alpha` (rough conductors, dielectrics, plastics) renders with the two values
swapped in Mitsuba, while a checkerboard colour does not.

Two checks, Mitsuba only (no lumo):
1. `eval` and `eval_1` at the centres of the four squares of the unit cell.
2. A reduced scene: a principled floor under an area light, its `roughness` (a) a checkerboard
   of 0.25 / 0.9, (b) the same checkerboard with the two values swapped, (c) a nearest-filtered
   8x8 bitmap of the pattern `eval` gives (0.25 on the even squares). (a) differs from (c)
   block by block; (b) equals (c) to noise.

Usage (Mitsuba 3 and numpy; the llvm variant needs libLLVM, see compare_mitsuba.py):
    python3 scripts/mitsuba_checkerboard_eval1.py [--variant scalar_rgb] [--spp 1024]
Exit status 1 if Mitsuba no longer swaps the values (then the note in
docs/mitsuba-materials.md is out of date).
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

FLOOR = """<scene version="3.0.0">
  <integrator type="path"><integer name="max_depth" value="4"/></integrator>
  <sensor type="perspective">
    <float name="fov" value="45"/>
    <transform name="to_world"><lookat origin="0,2.2,5" target="0,0.5,0" up="0,1,0"/></transform>
    <sampler type="independent"><integer name="sample_count" value="16"/></sampler>
    <film type="hdrfilm"><integer name="width" value="64"/><integer name="height" value="64"/>
      <rfilter type="box"/></film>
  </sensor>
  <shape type="rectangle">
    <transform name="to_world"><rotate x="1" angle="-90"/><scale value="4"/></transform>
    <bsdf type="principled"><rgb name="base_color" value="0.55, 0.5, 0.45"/>
      <float name="specular" value="0.6"/>ROUGHNESS</bsdf>
  </shape>
  <shape type="rectangle">
    <transform name="to_world"><rotate x="1" angle="90"/><scale value="0.7"/>
      <translate x="0.5" y="3.2" z="0.8"/></transform>
    <emitter type="area"><rgb name="radiance" value="10"/></emitter>
  </shape>
  <emitter type="constant"><rgb name="radiance" value="0.15"/></emitter>
</scene>
"""


def checker(c0: float, c1: float) -> str:
    return (
        '<texture name="roughness" type="checkerboard">'
        f'<float name="color0" value="{c0}"/><float name="color1" value="{c1}"/>'
        '<transform name="to_uv"><scale x="4" y="4"/></transform></texture>'
    )


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--variant", default="scalar_rgb")
    ap.add_argument("--spp", type=int, default=1024)
    args = ap.parse_args()
    if args.variant.startswith("llvm"):
        sys.path.insert(0, str(Path(__file__).resolve().parent))
        from compare_mitsuba import ensure_llvm_path

        ensure_llvm_path()
    import mitsuba as mi
    import numpy as np

    mi.set_variant(args.variant)
    print(f"Mitsuba {mi.__version__}, {args.variant}")
    tex = mi.load_dict({"type": "checkerboard", "color0": 0.25, "color1": 0.9})
    swapped = False
    print("square (u, v)   eval   eval_1")
    for uv in [(0.25, 0.25), (0.75, 0.25), (0.25, 0.75), (0.75, 0.75)]:
        si = mi.SurfaceInteraction3f()
        si.uv = mi.Point2f(*uv)
        e = float(np.array(tex.eval(si)).ravel()[0])
        e1 = float(np.array(tex.eval_1(si)).ravel()[0])
        swapped |= abs(e - e1) > 1e-6
        print(f"({uv[0]:.2f}, {uv[1]:.2f})    {e:.2f}   {e1:.2f}")

    with tempfile.TemporaryDirectory() as d:
        # 8x8 texels over the floor's uv square = the checkerboard with to_uv 4 (two squares
        # per uv unit); Mitsuba's bitmap row 0 is v = 0 at the image's top.
        i, j = np.meshgrid(np.arange(8), np.arange(8), indexing="xy")
        img = np.where((i + j) % 2 == 0, 0.25, 0.9).astype(np.float32)[..., None]
        mi.Bitmap(img).write(f"{d}/rough.exr")
        bitmap = (
            '<texture name="roughness" type="bitmap">'
            f'<string name="filename" value="{d}/rough.exr"/>'
            '<string name="filter_type" value="nearest"/><boolean name="raw" value="true"/>'
            "</texture>"
        )
        images = {}
        for name, rough in [
            ("checkerboard 0.25/0.9", checker(0.25, 0.9)),
            ("checkerboard 0.9/0.25", checker(0.9, 0.25)),
            ("bitmap (eval's pattern)", bitmap),
        ]:
            scene = mi.load_string(FLOOR.replace("ROUGHNESS", rough))
            images[name] = np.array(mi.render(scene, spp=args.spp, seed=1))[..., :3]
    ref = images["bitmap (eval's pattern)"]
    blocks = lambda a: a.reshape(4, 16, 4, 16, 3).mean(axis=(1, 3))
    print("roughness                 worst 16x16 block vs the bitmap")
    for name, img in images.items():
        rel = np.abs(blocks(img) - blocks(ref)) / np.maximum(blocks(ref), 0.1 * ref.mean())
        print(f"{name:25} {100 * rel.max():6.2f} %")
    return 0 if swapped else 1


if __name__ == "__main__":
    sys.exit(main())
