#!/usr/bin/env python3
"""Re-scores lumo's default `auto` on the held-out frames already in the bench cache (the
inputs and references of the last `lumo bench quality --set heldout`, listed in
target/lumo-bench-cache/heldout-inputs/cases.txt) without re-rendering anything, against
the relMSE, FLIP and OIDN columns of docs/results/heldout.md:

    python3 tools/heldout/rescore_auto.py [path/to/lumo]

For a change to the filter's defaults, when the references' ~80 CPU-minutes are not
affordable: each frame is denoised by `lumo denoise --input-dir` (every default) and scored by
`lumo compare`. Prints a line per frame (with the worst 32×32 block: the block where auto's
relMSE is the largest multiple of the unfiltered input's, computed as `lumo bench quality`'s
`worst_block` does) and the ratios to OIDN the issue's targets name; `--json FILE` also
writes the per-frame numbers."""
import json, os, subprocess, sys, statistics, tempfile

sys.path.insert(0, os.path.dirname(__file__))
from rescore_auto_blocks import read_pfm, worst_block  # noqa: E402

args = sys.argv[1:]
json_out = None
if "--json" in args:
    i = args.index("--json"); json_out = args[i + 1]; del args[i:i + 2]
L=args[0] if args else "target/release/lumo"
cases=[l.rstrip("\n").split("\t") for l in open("target/lumo-bench-cache/heldout-inputs/cases.txt")]
# OIDN numbers from the published table
md=open("docs/results/heldout.md").read().splitlines()
def table(head):
    i=md.index(head); rows={}
    for l in md[i+4:]:
        if not l.startswith("|"): break
        c=[x.strip() for x in l.strip("|").split("|")]
        rows[(c[0],c[2])]=c
    return rows
rel=table("## relMSE"); flip=table("## FLIP")
out=[]
for name, spp, d, ref, who in cases:
    out_pfm = os.path.join(tempfile.gettempdir(), "lumo-rescore.pfm")
    subprocess.run([L,"denoise","--input-dir",d,"-o",out_pfm],check=True,capture_output=True)
    r=subprocess.run([L,"compare",ref,out_pfm],capture_output=True,text=True).stdout.strip().splitlines()[-1].split()
    rm, fl = float(r[2]), float(r[6])
    key=(name if who=="lumo" else name, spp)
    c=rel.get(key); f=flip.get(key)
    # columns: scene renderer spp none atrous guided bilateral auto oidn ...
    old_rm, oidn_rm, none_rm = float(c[7]), float(c[8]), float(c[3])
    old_fl, oidn_fl = float(f[7]), float(f[8])
    wb = worst_block(read_pfm(ref), read_pfm(os.path.join(d, "color.pfm")), read_pfm(out_pfm))
    out.append((name, spp, old_rm, rm, oidn_rm, none_rm, old_fl, fl, oidn_fl, wb))
    print(f"{name} {spp}: relMSE {old_rm:.3g} -> {rm:.3g} (oidn {oidn_rm:.3g}), FLIP {old_fl:.4f} -> {fl:.4f} (oidn {oidn_fl:.4f}), worst block {wb[0]:.2f} at ({wb[1]}, {wb[2]})", flush=True)
fr=[o[7]/o[8] for o in out]; rr=[o[3]/o[4] for o in out]
print("FLIP ratio median", statistics.median(fr), "worst", max(fr), "above 1.2:", sum(x>1.2 for x in fr))
print("relMSE ratio median", statistics.median(rr), "worst", max(rr), "above 3:", sum(x>3 for x in rr))
print("worse than input:", [(o[0],o[1]) for o in out if o[3]>o[5]])
print("worst block above 1.2x the input's:", sum(o[9][0] > 1.2 for o in out), "of", len(out), "frames; worst", max(o[9][0] for o in out))
if json_out:
    keys = ["scene", "spp", "old_relmse", "relmse", "oidn_relmse", "input_relmse", "old_flip", "flip", "oidn_flip"]
    json.dump([dict(zip(keys, o[:9]), worst_block=o[9][0], worst_block_at=o[9][1:]) for o in out], open(json_out, "w"), indent=1)
