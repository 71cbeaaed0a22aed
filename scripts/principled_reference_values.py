#!/usr/bin/env python3
"""Prints Mitsuba 3's `principled` BSDF values and densities at fixed directions, for the test
`principled_evaluates_as_mitsuba` (crates/lumo-render/tests/integration/principled.rs).

Mitsuba's wi is lumo's wo (towards the viewer) and Mitsuba's wo lumo's wi (towards the light);
values include the cosine, as lumo's do. Variant scalar_rgb (on Debian set
DRJIT_LIBLLVM_PATH if Mitsuba asks for LLVM).
"""
import math

import mitsuba as mi

mi.set_variant("scalar_rgb")

CASES = [
    dict(base_color=[0.8, 0.3, 0.2], roughness=0.4, metallic=0.3, clearcoat=0.7,
         clearcoat_gloss=0.5, sheen=0.5, sheen_tint=0.4, spec_tint=0.6),
    dict(base_color=[0.2, 0.5, 0.9], roughness=0.7, anisotropic=0.6, metallic=0.9,
         flatness=0.5),
    dict(base_color=[0.9, 0.8, 0.6], roughness=0.3, spec_trans=0.7, eta=1.4),
    dict(base_color=[0.6, 0.6, 0.6], roughness=1.0, specular=0.8, spec_trans=1.0),
]
DIRS = [
    ((0.3, 0.2, 0.9), (-0.4, 0.1, 0.8)),
    ((0.1, -0.6, 0.3), (0.5, 0.5, 0.2)),
    ((0.3, 0.2, 0.9), (-0.2, -0.1, -0.9)),
    ((0.2, 0.1, -0.7), (-0.3, 0.0, -0.6)),
    ((0.2, 0.1, -0.7), (-0.1, -0.3, 0.8)),
]


def unit(v):
    n = math.sqrt(sum(x * x for x in v))
    return [x / n for x in v]


def rgb(c):
    return {"type": "rgb", "value": c}


for case in CASES:
    d = {"type": "principled"}
    for k, v in case.items():
        d[k] = rgb(v) if isinstance(v, list) else v
    b = mi.load_dict(d)
    for wo, wi in DIRS:
        si = mi.SurfaceInteraction3f()
        si.wi = mi.Vector3f(unit(wo))
        ctx = mi.BSDFContext()
        w = mi.Vector3f(unit(wi))
        f = b.eval(ctx, si, w)
        p = b.pdf(ctx, si, w)
        print(f"{case} wo={wo} wi={wi}: f=({f[0]:.7e}, {f[1]:.7e}, {f[2]:.7e}) pdf={p:.7e}")
