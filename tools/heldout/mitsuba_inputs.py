#!/usr/bin/env python3
"""Noisy inputs and a converged reference of held-out scenes rendered by Mitsuba 3, so that
`lumo bench quality --set heldout --external DIR` (and tools/peers/run_peers.py) also score
frames from another renderer than lumo.

    /work/venv-mi/bin/python tools/heldout/mitsuba_inputs.py --out target/lumo-bench-cache/mitsuba

For each scene it writes DIR/<scene>-mitsuba/reference.pfm (--reference-spp samples, in
--chunks passes with their own seeds) and DIR/<scene>-mitsuba/<spp>spp/{color, albedo, normal,
position, depth}.pfm from Mitsuba's `aov` integrator (albedo, shading normal, world position,
distance) around its `path` integrator, with seed 0 — no emission plane: lumo has to find the
lights itself, as with any renderer that does not write one. PFM is written with numpy (the
venv has no PIL), rows bottom to top as the format says. Existing outputs are kept (delete the
folder to render again).
"""
import argparse
import os
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.join(HERE, "..", "..")
sys.path.insert(0, os.path.join(REPO, "scripts"))


def write_pfm(path, img):
    img = np.ascontiguousarray(img, dtype=np.float32)
    h, w = img.shape[:2]
    c = 1 if img.ndim == 2 else img.shape[2]
    tmp = path + ".tmp"
    with open(tmp, "wb") as f:
        f.write(("PF" if c == 3 else "Pf").encode() + f"\n{w} {h}\n-1.0\n".encode())
        f.write(np.ascontiguousarray(img[::-1]).astype("<f4").tobytes())
    os.replace(tmp, path)


AOV = """<integrator type="aov">
    <string name="aovs" value="alb:albedo,nn:sh_normal,pp:position,dd:depth"/>
    <integrator type="path" name="inner"><integer name="max_depth" value="{depth}"/>
        <integer name="rr_depth" value="5"/></integrator>
</integrator>"""


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenes", default="indirect-corridor,glossy-spheres,sun-blocks,small-lights")
    ap.add_argument("--out", default=os.path.join(REPO, "target", "lumo-bench-cache", "mitsuba"))
    ap.add_argument("--res", type=int, default=512)
    ap.add_argument("--spp", default="1,4")
    ap.add_argument("--reference-spp", type=int, default=512)
    ap.add_argument("--chunks", type=int, default=8)
    ap.add_argument("--variant", default="llvm_ad_rgb")
    a = ap.parse_args()
    from compare_mitsuba import ensure_llvm_path
    ensure_llvm_path()
    import mitsuba as mi
    mi.set_variant(a.variant)
    import xml.etree.ElementTree as ET
    for name in a.scenes.split(","):
        path = os.path.join(REPO, "scenes", "heldout", f"{name}.xml")
        depth = int(ET.parse(path).getroot().find("default[@name='max_depth']").get("value"))
        d = os.path.join(a.out, f"{name}-mitsuba")
        os.makedirs(d, exist_ok=True)
        ref = os.path.join(d, "reference.pfm")
        if not os.path.exists(ref):
            t = time.perf_counter()
            per = a.reference_spp // a.chunks
            scene = mi.load_file(path, res=str(a.res), spp=str(per))
            acc = None
            for k in range(a.chunks):
                img = np.array(mi.render(scene, seed=1000 + k), dtype=np.float64)[..., :3]
                acc = img if acc is None else acc + img
            write_pfm(ref, acc / a.chunks)
            print(f"{name}: reference {a.reference_spp} spp in {time.perf_counter() - t:.1f} s", file=sys.stderr)
        for spp in [int(s) for s in a.spp.split(",")]:
            sd = os.path.join(d, f"{spp}spp")
            if os.path.exists(os.path.join(sd, "depth.pfm")):
                continue
            os.makedirs(sd, exist_ok=True)
            # The scene's own integrator replaced by the AOV one around a path tracer.
            text = open(path).read()
            start, end = text.index("<integrator"), text.index("</integrator>") + len("</integrator>")
            text = text[:start] + AOV.format(depth=depth) + text[end:]
            tmp = os.path.join(os.path.dirname(path), f".{name}-aov.xml")
            with open(tmp, "w") as f:
                f.write(text)
            try:
                scene = mi.load_file(tmp, res=str(a.res), spp=str(spp))
            finally:
                os.remove(tmp)
            img = np.array(mi.render(scene, seed=0), dtype=np.float32)
            # Channels: RGB, then alb (3), nn (3), pp (3), dd (1).
            write_pfm(os.path.join(sd, "color.pfm"), img[..., 0:3])
            write_pfm(os.path.join(sd, "albedo.pfm"), img[..., 3:6])
            write_pfm(os.path.join(sd, "normal.pfm"), img[..., 6:9])
            write_pfm(os.path.join(sd, "position.pfm"), img[..., 9:12])
            write_pfm(os.path.join(sd, "depth.pfm"), img[..., 12])
            print(f"{name}: {spp} spp inputs", file=sys.stderr)


if __name__ == "__main__":
    main()
