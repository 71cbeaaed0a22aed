#!/usr/bin/env python3
"""Sweep `lumo denoise` parameters on real lumo renders against converged references.

For each scene and spp this renders a noisy frame with its AOVs (`lumo render --pipeline none
--aovs`), a reference (`--spp REF_SPP`, another seed), runs `lumo denoise` over a small grid of
settings per filter and scores each result with `lumo compare --json` (relMSE, ε = 0.01, and
SSIM). Prints Markdown tables (one row per setting, one column per scene × spp, plus the
geometric mean of relMSE over all of them) to stdout; the defaults of `lumo denoise` were chosen
from this output (docs/filters.md).

Standard library only. Usage:
    python3 scripts/sweep_denoise.py --lumo target/release/lumo [--work DIR] [--quick]
"""
import argparse
import json
import math
import os
import subprocess
import sys

SCENES = {"cornell": "192x192", "cornell-spheres": "192x192", "atrium": "240x150"}
SPPS = [1, 4]


def run(cmd):
    r = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    if r.returncode != 0:
        sys.exit(f"{' '.join(cmd)} failed:\n{r.stderr}")
    return r.stdout


def grid(quick):
    """(filter label, extra `lumo denoise` arguments)."""
    g = []
    for s in ([2, 4, 8] if quick else [1, 2, 4, 8, 16]):
        g.append((f"atrous plane σ_l={s}", ["--filter", "atrous", "--variance-source", "plane",
                                            "--sigma-color", str(s)]))
    for s in ([32, 64] if quick else [8, 16, 32, 64, 128]):
        g.append((f"atrous spatial σ_l={s}", ["--filter", "atrous", "--variance-source",
                                              "spatial", "--sigma-color", str(s)]))
    g.append(("atrous no colour weight", ["--filter", "atrous", "--variance-source", "none"]))
    for x in [0.05, 0.2]:
        g.append((f"atrous plane σ_l=4 σ_x={x}", ["--filter", "atrous", "--variance-source",
                                                  "plane", "--sigma-color", "4",
                                                  "--sigma-position", str(x)]))
    for it in [4, 6]:
        g.append((f"atrous plane σ_l=4 {it} it", ["--filter", "atrous", "--variance-source",
                                                  "plane", "--sigma-color", "4",
                                                  "--iterations", str(it)]))
    for r in ([16, 24] if quick else [8, 16, 24, 32]):
        for e in ([0.003] if quick else [0.001, 0.003, 0.01]):
            g.append((f"guided r={r} ε={e}", ["--filter", "guided", "--radius", str(r),
                                             "--eps-normal", str(e), "--eps-depth", str(e)]))
    for r in [8, 16]:
        for d in [0.05, 0.2]:
            g.append((f"bilateral r={r} σ_d={d}", ["--filter", "bilateral", "--radius", str(r),
                                                   "--sigma-depth", str(d)]))
    return g


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--lumo", default="target/release/lumo")
    ap.add_argument("--work", default="target/sweep-denoise")
    ap.add_argument("--ref-spp", type=int, default=512)
    ap.add_argument("--quick", action="store_true", help="a smaller grid")
    a = ap.parse_args()
    os.makedirs(a.work, exist_ok=True)
    cases = []
    for scene, size in SCENES.items():
        ref = os.path.join(a.work, f"{scene}-ref{a.ref_spp}.exr")
        if not os.path.exists(ref):
            print(f"rendering reference {scene} {size} {a.ref_spp} spp", file=sys.stderr)
            run([a.lumo, "render", scene, "--pipeline", "none", "--size", size, "--spp",
                 str(a.ref_spp), "--seed", "1000", "-o", ref])
        for spp in SPPS:
            aov = os.path.join(a.work, f"{scene}-{spp}spp")
            noisy = os.path.join(aov, "noisy.exr")
            if not os.path.exists(noisy):
                os.makedirs(aov, exist_ok=True)
                run([a.lumo, "render", scene, "--pipeline", "none", "--size", size, "--spp",
                     str(spp), "--seed", "7", "-o", noisy, "--aovs", aov])
            cases.append((scene, spp, ref, aov))
    rows = [("noisy input", None)] + grid(a.quick)
    results = {}
    for label, args in rows:
        for scene, spp, ref, aov in cases:
            out = os.path.join(aov, "noisy.exr")
            if args is not None:
                out = os.path.join(aov, "out.exr")
                run([a.lumo, "denoise", "--input-dir", aov, *args, "-o", out])
            j = json.loads(run([a.lumo, "compare", ref, out, "--json"]))["images"][0]
            results[(label, scene, spp)] = (j["relmse"], j["ssim"])
        print(f"done: {label}", file=sys.stderr)
    cols = [(s, p) for s, p, _, _ in cases]
    head = "| setting | " + " | ".join(f"{s} {p} spp" for s, p in cols) + " | geo. mean |"
    print("relMSE (ε = 0.01) against a %d-spp reference; SSIM in parentheses\n" % a.ref_spp)
    print(head)
    print("|---" * (len(cols) + 2) + "|")
    for label, _ in rows:
        vals = [results[(label, s, p)] for s, p in cols]
        gm = math.exp(sum(math.log(max(v[0], 1e-12)) for v in vals) / len(vals))
        cells = " | ".join(f"{r:.2e} ({q:.3f})" for r, q in vals)
        print(f"| {label} | {cells} | {gm:.2e} |")


if __name__ == "__main__":
    main()
