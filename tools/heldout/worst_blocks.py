#!/usr/bin/env python3
"""Contact sheet of each held-out frame's worst 32x32 block (issue 47): the block where lumo
`auto`'s relMSE is the largest multiple of the unfiltered input's, shown magnified as
reference | input | lumo auto | OIDN, with the block's relMSE of each.

    .venv-peers/bin/python tools/heldout/worst_blocks.py [path/to/lumo] [-o docs/images/heldout-worst-blocks.png]

Inputs and references are the bench cache of the last `lumo bench quality --set heldout`
(target/lumo-bench-cache/heldout-inputs/cases.txt); lumo runs `lumo denoise --input-dir` with
every default (so lumo's own frames use their `dirac` plane where the cache has one), OIDN is
`pyoidn.denoise(color, albedo, normal, hdr=True, quality="high")`. Needs numpy, opencv and
pyoidn (tools/peers/requirements.txt)."""
import os, subprocess, sys, tempfile
import numpy as np
import cv2
import pyoidn

sys.path.insert(0, os.path.dirname(__file__))
from rescore_auto_blocks import read_pfm, block_errors, BLOCK  # noqa: E402

args = sys.argv[1:]
out_png = "docs/images/heldout-worst-blocks.png"
if "-o" in args:
    i = args.index("-o"); out_png = args[i + 1]; del args[i:i + 2]
lumo = args[0] if args else "target/release/lumo"
cases = [l.rstrip("\n").split("\t") for l in open("target/lumo-bench-cache/heldout-inputs/cases.txt")]
SHOW = 64  # pixels around the block's centre shown
ZOOM = 3

def srgb(a):
    a = np.clip(a[..., :3], 0, 1)
    a = np.where(a <= 0.0031308, 12.92 * a, 1.055 * a ** (1 / 2.4) - 0.055)
    return (a * 255 + 0.5).astype(np.uint8)[..., ::-1]  # BGR for OpenCV

def rel(ref, img, y0, x0):
    r, v = ref[y0:y0 + BLOCK, x0:x0 + BLOCK, :3], img[y0:y0 + BLOCK, x0:x0 + BLOCK, :3]
    e = (v - r) ** 2 / (r ** 2 + 0.01)
    return float(np.nanmean(np.where(np.isfinite(e), e, np.nan)))

rows = []
tmp = os.path.join(tempfile.gettempdir(), "lumo-worst-block.pfm")
for name, spp, d, ref_path, who in cases:
    ref, noisy = read_pfm(ref_path), read_pfm(os.path.join(d, "color.pfm"))
    subprocess.run([lumo, "denoise", "--input-dir", d, "-o", tmp], check=True, capture_output=True)
    auto = read_pfm(tmp)
    f32 = lambda a: np.ascontiguousarray(a.astype(np.float32))
    nrm = read_pfm(os.path.join(d, "normal.pfm"))
    oidn = pyoidn.denoise(f32(noisy[..., :3]), f32(read_pfm(os.path.join(d, "albedo.pfm"))[..., :3]),
                          f32(nrm[..., :3]), hdr=True, quality="high").astype(np.float64)
    base, err = block_errors(ref, noisy), block_errors(ref, auto)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(base > 0, err / base, np.where(err > 0, np.inf, -1.0))
    by, bx = np.unravel_index(int(np.argmax(ratio)), ratio.shape)
    y0, x0 = by * BLOCK, bx * BLOCK
    h, w = ref.shape[:2]
    cy, cx = min(max(y0 + BLOCK // 2 - SHOW // 2, 0), h - SHOW), min(max(x0 + BLOCK // 2 - SHOW // 2, 0), w - SHOW)
    tiles = []
    for label, img in [("reference", ref), ("input", noisy), ("lumo auto", auto), ("OIDN", oidn)]:
        t = srgb(img[cy:cy + SHOW, cx:cx + SHOW])
        t = cv2.resize(t, (SHOW * ZOOM, SHOW * ZOOM), interpolation=cv2.INTER_NEAREST)
        # The block itself, outlined.
        p0 = ((x0 - cx) * ZOOM, (y0 - cy) * ZOOM)
        cv2.rectangle(t, p0, (p0[0] + BLOCK * ZOOM - 1, p0[1] + BLOCK * ZOOM - 1), (0, 200, 255), 1)
        score = "" if label == "reference" else f" {rel(ref, img, y0, x0):.2e}"
        cv2.putText(t, label + score, (4, 14), cv2.FONT_HERSHEY_SIMPLEX, 0.4, (255, 255, 255), 1, cv2.LINE_AA)
        tiles.append(t)
    head = np.zeros((18, SHOW * ZOOM * 4, 3), np.uint8)
    r = ratio[by, bx]
    cv2.putText(head, f"{name} ({who}) {spp} spp: worst block ({bx}, {by}), auto / input = {r:.2f}",
                (4, 13), cv2.FONT_HERSHEY_SIMPLEX, 0.42, (255, 255, 255), 1, cv2.LINE_AA)
    rows.append(np.vstack([head, np.hstack(tiles)]))
    print(name, spp, f"block ({bx}, {by}) ratio {r:.2f}", flush=True)
# Two frames per row of the sheet.
pairs = [np.hstack([rows[i], rows[i + 1] if i + 1 < len(rows) else np.zeros_like(rows[i])])
         for i in range(0, len(rows), 2)]
cv2.imwrite(out_png, np.vstack(pairs), [cv2.IMWRITE_PNG_COMPRESSION, 9])
print("wrote", out_png)
