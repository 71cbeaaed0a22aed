"""The `--set` mode of run_peers.py: OIDN and OpenCV on the frames `lumo bench quality --set`
wrote (listed in CACHE/SET-inputs/cases.txt), merged with lumo's scores (RESULTS/SET.json)
into RESULTS/SET.md — relMSE and FLIP per scene × spp, ratios to OIDN, the reference noise —
plus a contact sheet RESULTS/SET.png (reference, noisy, lumo auto, lumo guided, OIDN) and
filter times of lumo and OIDN side by side at 512² and 1080p.
"""
import json
import os
import re
import statistics
import subprocess
import sys
import tempfile

import numpy as np

from run_peers import read_pfm, run, timed, write_pfm, atomic_write

# Methods in table order; peers last.
LUMO = ["none", "atrous", "guided", "bilateral", "auto"]


def demod_peer(fn):
    """A peer that filters the whole colour divided by the albedo (as `lumo denoise` does),
    then multiplies back; pixels without albedo are left as they are."""
    def go(p):
        c = np.nan_to_num(p["color"], nan=0.0, posinf=0.0, neginf=0.0)
        a = p["albedo"]
        dark = a < 1e-3
        illum = np.where(dark, c, c / np.maximum(a, 1e-3)).astype(np.float32)
        f = fn(illum, p)
        return np.where(dark, c, f * a).astype(np.float32)
    return go


def set_peers(cv2, pyoidn, a):
    out = {}
    if pyoidn is not None:
        def oidn(p):
            n = np.nan_to_num(p["normal"]).astype(np.float32)
            c = np.nan_to_num(p["color"], posinf=0.0).clip(0, None).astype(np.float32)
            return pyoidn.denoise(c, p["albedo"], n, hdr=True, quality="high")
        out["oidn"] = oidn

    def guide(p):
        return np.ascontiguousarray(np.nan_to_num(p["normal"]) * 0.5 + 0.5, dtype=np.float32)
    out["opencv-guided"] = demod_peer(
        lambda x, p: cv2.ximgproc.guidedFilter(guide(p), x, a.guided_radius, a.guided_eps, -1))
    out["opencv-jbf"] = demod_peer(
        lambda x, p: cv2.ximgproc.jointBilateralFilter(guide(p), x, 2 * a.jbf_radius + 1,
                                                       a.jbf_sigma_color, a.jbf_sigma_space))
    return out


def load(d):
    p = {k: read_pfm(os.path.join(d, f"{k}.pfm")) for k in ["color", "albedo", "normal"]}
    if p["albedo"].ndim == 2:
        p["albedo"] = np.repeat(p["albedo"][..., None], 3, axis=2)
    return p


def srgb8(img):
    x = np.clip(np.nan_to_num(img), 0, 1)
    s = np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1 / 2.4) - 0.055)
    return (s * 255 + 0.5).astype(np.uint8)


def contact_sheet(cv2, path, rows, tile=176):
    """rows: [(label, [(column title, image, caption)])]; tiles resized to `tile` px."""
    font = cv2.FONT_HERSHEY_SIMPLEX
    out_rows = []
    for label, cols in rows:
        tiles = []
        for title, img, caption in cols:
            t = cv2.resize(srgb8(img)[..., ::-1], (tile, tile), interpolation=cv2.INTER_AREA)
            band = np.full((30, tile, 3), 24, np.uint8)
            cv2.putText(band, title, (3, 12), font, 0.38, (255, 255, 255), 1, cv2.LINE_AA)
            cv2.putText(band, caption, (3, 26), font, 0.36, (120, 220, 255), 1, cv2.LINE_AA)
            tiles.append(np.vstack([t, band]))
        out_rows.append(np.hstack(tiles))
    sheet = np.vstack(out_rows)
    cv2.imwrite(path, sheet, [cv2.IMWRITE_PNG_COMPRESSION, 9])


def median_ratio(vals):
    return statistics.median(vals) if vals else float("nan")


def main_set(a, cv2, pyoidn, versions):
    root = os.path.join(a.cache, f"{a.set}-inputs")
    cases = [l.split("\t") for l in open(os.path.join(root, "cases.txt")).read().splitlines() if l]
    with open(os.path.join(a.results, f"{a.set}.json")) as f:
        lumo = json.load(f)
    rows = [r for r in lumo["rows"]]
    fns = set_peers(cv2, pyoidn, a)
    images = {}
    with tempfile.TemporaryDirectory() as d:
        for name, spp, folder, ref, renderer in cases:
            spp = int(spp)
            planes = load(folder)
            for peer, fn in fns.items():
                img, ms = timed(lambda: fn(planes), a.repeats)
                out = os.path.join(d, f"{name}-{spp}-{peer}.pfm")
                write_pfm(out, img)
                j = json.loads(run([a.lumo, "compare", ref, out, "--json"]).stdout)["images"][0]
                rows.append(dict(case=name, spp=spp, method=peer, ms=ms, **{
                    k: j[k] for k in ["mse", "relmse", "smape", "psnr_db", "ssim", "flip"]}))
                if peer == "oidn" and spp == 1:
                    images[(name, "oidn")] = img
                print(f"{name} {spp} spp {peer}: relMSE {j['relmse']:.3e} FLIP {j['flip']:.4f} "
                      f"{ms:.0f} ms", file=sys.stderr)
            if spp == 1:
                images[(name, "ref")] = read_any(a, ref, d)
                images[(name, "noisy")] = planes["color"]
                for m in ["auto", "guided"]:
                    o = os.path.join(d, f"{name}-{m}.pfm")
                    run([a.lumo, "denoise", "--input-dir", folder, "--filter", m, "-o", o])
                    images[(name, m)] = read_pfm(o)
        times = side_by_side(a, fns.get("oidn"), d)
    methods = LUMO + list(fns)
    md = set_markdown(a, lumo, rows, methods, cases, times, versions)
    atomic_write(os.path.join(a.results, f"{a.set}.md"), md)
    score = {(r["case"], r["spp"], r["method"]): r for r in rows}
    sheet_rows = []
    for name, spp, *_ in cases:
        if int(spp) != 1 or (name, "oidn") not in images:
            continue
        cap = lambda m: f"FLIP {score[(name, 1, m)]['flip']:.3f} rel {score[(name, 1, m)]['relmse']:.1e}"
        sheet_rows.append((name, [
            (f"{name[:22]} ref", images[(name, "ref")], "1 spp row"),
            ("noisy 1 spp", images[(name, "noisy")], cap("none")),
            ("lumo auto", images[(name, "auto")], cap("auto")),
            ("lumo guided", images[(name, "guided")], cap("guided")),
            ("OIDN high", images[(name, "oidn")], cap("oidn")),
        ]))
    png = os.path.join(a.results, f"{a.set}.png")
    contact_sheet(cv2, png, sheet_rows)
    print(f"wrote {os.path.join(a.results, a.set + '.md')} and {png}", file=sys.stderr)


def read_any(a, path, d):
    """A reference as float32 RGB (H, W, 3): PFM directly, EXR through OpenCV (run_peers.py
    enables its EXR reader)."""
    if path.endswith(".pfm"):
        return read_pfm(path)
    import cv2
    img = cv2.imread(path, cv2.IMREAD_UNCHANGED)
    if img is None:
        raise SystemExit(f"cannot read {path}")
    return img[..., :3][..., ::-1].astype(np.float32)


def side_by_side(a, oidn, d):
    """[(method, size, ms)]: OIDN in-process and lumo's filters by `lumo denoise --timings
    --repeat N` (the in-process median, warm), on the same planes, one size after the other."""
    out = []
    for size in [s for s in a.speed_sizes.split(",") if s]:
        w, h = map(int, size.split("x"))
        inputs = os.path.join(d, f"speed-{size}")
        run([a.lumo, "bench", "inputs", "cornell", "--spp", "1", "--size", size, "--out", inputs])
        # As another renderer's frame: no emission plane, so lumo searches for the lights.
        for extra in ["emission", "variance", "direct", "indirect"]:
            p = os.path.join(inputs, f"{extra}.pfm")
            if os.path.exists(p):
                os.remove(p)
        planes = load(inputs)
        if oidn is not None:
            _, ms = timed(lambda: oidn(planes), a.repeats)
            out.append(("OIDN high (pyoidn)", (w, h), ms))
        for m in ["auto", "guided", "atrous"]:
            o = run([a.lumo, "denoise", "--input-dir", inputs, "--filter", m, "--timings",
                     "--repeat", str(a.repeats + 1), "-o", os.path.join(d, "t.pfm")]).stdout
            ms = float(re.search(r"^filter ([0-9.]+) ms$", o, re.M).group(1))
            out.append((f"lumo {m}", (w, h), ms))
        print(f"speed {size} done", file=sys.stderr)
    return out


def set_markdown(a, lumo, rows, methods, cases, times, versions):
    keys = [(c[0], int(c[1]), c[4]) for c in cases]
    get = {(r["case"], r["spp"], r["method"]): r for r in rows}
    L = [f"# Held-out evaluation: lumo's filters and OIDN on scenes never tuned on"
         if a.set == "heldout" else f"# The {a.set} set: lumo's filters and the peers", ""]
    L += [f"Generated by `{lumo['command']}` then `tools/peers/run_peers.py --set {a.set}`. "
          f"Machine: {lumo['machine']}.{(' ' + lumo['note']) if lumo.get('note') else ''}", ""]
    L += [f"- Frames: {lumo['size'][0]}×{lumo['size'][1]}, seed {lumo['seed']}; lumo renders of "
          f"`scenes/{a.set}/*.xml` and, where listed as Mitsuba 3, frames of the same scene files "
          f"from Mitsuba 3's `aov` + `path` integrators (tools/heldout/mitsuba_inputs.py). Every "
          f"method gets colour, albedo, normal (lumo also position and depth) and **no emission "
          f"plane**; lumo's filters run exactly as `lumo denoise --input-dir DIR --filter F` with "
          f"every default (emitters found in the frame).",
          f"- References: the same renderer at {lumo['reference_spp']} spp, independent seed. "
          f"Their own noise is estimated from the noisy 4-spp frame: relMSE(4 spp) ≈ V·(1/4 + "
          f"1/N), so the reference's own relMSE ≈ V/N (column *ref noise*).",
          "- Scores: `lumo compare` — relMSE (ε = 0.01) on linear RGB; FLIP is lumo's LDR-FLIP on "
          "the display image (sRGB of clamp(x), exposure 0), not HDR-FLIP.",
          "- OIDN: `pyoidn.denoise(color, albedo, normal, hdr=True, quality=\"high\")`. OpenCV: "
          "`ximgproc.guidedFilter` / `jointBilateralFilter` on colour / albedo guided by the normal, "
          "times albedo.", ""]
    for title, key, fmt in [("relMSE", "relmse", "{:.2e}"), ("FLIP", "flip", "{:.4f}")]:
        L += [f"## {title}", "", "| scene | renderer | spp | " + " | ".join(methods) + " |",
              "|---|---|---:|" + "---:|" * len(methods)]
        for name, spp, ren in keys:
            cells = [fmt.format(get[(name, spp, m)][key]) if (name, spp, m) in get else "—"
                     for m in methods]
            L.append(f"| {name} | {ren} | {spp} | " + " | ".join(cells) + " |")
        L.append("")
    # Ratios to OIDN.
    filters = ["atrous", "guided", "bilateral", "auto"]
    L += ["## Against OIDN", "",
          "FLIP ratio = method's FLIP / OIDN's on the same frame (< 1: better than OIDN). "
          "*best fixed* = the best of lumo's fixed filters on that frame (chosen after the fact). "
          "relMSE blow-up = auto's relMSE / the best lumo filter's.", "",
          "| scene | renderer | spp | auto FLIP / OIDN | best fixed FLIP / OIDN | auto relMSE / OIDN | "
          "auto relMSE / best lumo | ref noise (relMSE) | OIDN relMSE |",
          "|---|---|---:|---:|---:|---:|---:|---:|---:|"]
    ratios = {"auto": [], "best": [], "blow": []}
    for name, spp, ren in keys:
        o = get.get((name, spp, "oidn"))
        if o is None:
            continue
        au = get[(name, spp, "auto")]
        best_flip = min(get[(name, spp, m)]["flip"] for m in filters if m != "auto")
        best_rel = min(get[(name, spp, m)]["relmse"] for m in filters)
        r_auto, r_best = au["flip"] / o["flip"], best_flip / o["flip"]
        blow = au["relmse"] / best_rel
        ratios["auto"].append(r_auto)
        ratios["best"].append(r_best)
        ratios["blow"].append(blow)
        n4 = get.get((name, 4, "none"))
        refn = n4["relmse"] / (lumo["reference_spp"] / 4 + 1) if n4 else float("nan")
        L.append(f"| {name} | {ren} | {spp} | {r_auto:.2f} | {r_best:.2f} | "
                 f"{au['relmse'] / o['relmse']:.2f} | {blow:.2f} | {refn:.1e} | {o['relmse']:.1e} |")
    if ratios["auto"]:
        L += ["", f"**auto: median FLIP ratio to OIDN {median_ratio(ratios['auto']):.2f}** "
              f"(target ≤ 1.0), worst {max(ratios['auto']):.2f} (target ≤ 1.2), "
              f"{sum(r > 1.2 for r in ratios['auto'])} of {len(ratios['auto'])} frames above 1.2; "
              f"best fixed filter per frame (an oracle no user has): median "
              f"{median_ratio(ratios['best']):.2f}, worst {max(ratios['best']):.2f}. "
              f"auto's relMSE against the best lumo filter's: worst {max(ratios['blow']):.2f}× "
              f"(target ≤ 2), {sum(b > 2 for b in ratios['blow'])} frames above 2.", ""]
    if times:
        sizes = list(dict.fromkeys(t[1] for t in times))
        L += ["## Time, side by side", "",
              "Filter time per frame on lumo's cornell render at 1 spp (no emission plane), in one "
              "run: OIDN in-process (median of the repeats after a warm-up call that creates the "
              "device), lumo by `lumo denoise --timings --repeat N` (in-process median; the emitter "
              "search included). Same machine, same moment, 2 threads each.", "",
              "| method | " + " | ".join(f"{w}×{h} ms" for w, h in sizes) + " | vs OIDN |",
              "|---|" + "---:|" * (len(sizes) + 1)]
        for m in dict.fromkeys(t[0] for t in times):
            vals = [next((t[2] for t in times if t[0] == m and t[1] == s), float("nan")) for s in sizes]
            oi = [next((t[2] for t in times if t[0].startswith("OIDN") and t[1] == s), float("nan")) for s in sizes]
            rel = " / ".join(f"{v / o:.2f}×" for v, o in zip(vals, oi))
            L.append(f"| {m} | " + " | ".join(f"{v:.0f}" for v in vals) + f" | {rel} |")
        L.append("")
    L += [f"![Contact sheet: per held-out frame at 1 spp the reference, the noisy input, lumo auto, "
          f"lumo guided and OIDN, with FLIP and relMSE]({a.set}.png)", "", versions, ""]
    return "\n".join(L)
