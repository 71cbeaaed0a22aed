#!/usr/bin/env python3
"""Peers side by side with lumo: other denoisers on lumo's noisy inputs, in the same tables.

Run after `lumo bench quality` (and `lumo bench speed`) with the same settings:

    python3 -m venv .venv-peers
    .venv-peers/bin/pip install -r tools/peers/requirements.txt
    .venv-peers/bin/python tools/peers/run_peers.py --lumo target/release/lumo

For every scene and spp it
  1. writes the noisy frame and its AOVs with `lumo bench inputs` (exactly the image
     `lumo bench quality` scores as its `none` row) and gets the converged reference from the
     same cache with `lumo bench reference`;
  2. denoises it with each peer, timing the filter call in-process (median of --repeats calls
     after one untimed warm-up call, which for OIDN also creates the device and filter):
       - Intel Open Image Denoise (pyoidn): colour + albedo + normal, hdr, quality "high";
       - OpenCV ximgproc.guidedFilter and ximgproc.jointBilateralFilter, each used the way
         lumo's indirect-light pipelines are: on the demodulated indirect light
         (indirect / albedo), guided by the normal (n * 0.5 + 0.5, float32), then
         `direct + albedo * filtered` (direct light unfiltered);
  3. scores the result with `lumo compare --json` against the reference;
  4. appends rows marked "(peer)" to docs/results/quality.md (the relMSE and FLIP summary
     tables and each scene's table; the trace time is the `none` row's, the total adds the
     peer's filter time) and a peers section with versions and settings; and, if speed.md
     exists, a peers section of filter times at the Table 2 resolutions there.
Re-running replaces the previous peer rows; nothing is written until everything is done, and
then via a temporary file and a rename.
"""

import argparse
import json
import os
import platform
import re
import statistics
import subprocess
import sys
import tempfile
import time

import numpy as np

# The references of `lumo bench quality --set` are EXR; OpenCV reads EXR only when this is set
# before it is imported (heldout_set.py).
os.environ.setdefault("OPENCV_IO_ENABLE_OPENEXR", "1")

PEER_MARK = "(peer)"


def read_pfm(path):
    """A PFM file as float32 (H, W, C) (or (H, W) for one channel), rows top to bottom."""
    with open(path, "rb") as f:
        kind = f.readline().strip()
        w, h = map(int, f.readline().split())
        scale = float(f.readline())
        data = np.frombuffer(f.read(), dtype="<f4" if scale < 0 else ">f4")
    c = 3 if kind == b"PF" else 1
    img = data.reshape(h, w, c)[::-1].astype(np.float32)
    return img if c == 3 else img[..., 0]


def write_pfm(path, img):
    """A float32 RGB PFM, rows bottom to top."""
    img = np.ascontiguousarray(img, dtype=np.float32)
    h, w = img.shape[:2]
    with open(path, "wb") as f:
        f.write(f"PF\n{w} {h}\n-1.0\n".encode("ascii"))
        f.write(np.ascontiguousarray(img[::-1]).astype("<f4").tobytes())


def run(cmd):
    out = subprocess.run(cmd, capture_output=True, text=True)
    if out.returncode != 0:
        sys.exit(f"failed: {' '.join(cmd)}\n{out.stderr}")
    return out


def timed(fn, repeats):
    """(result, median ms) of `repeats` calls after one untimed warm-up call."""
    result = fn()
    times = []
    for _ in range(repeats):
        t = time.perf_counter()
        result = fn()
        times.append((time.perf_counter() - t) * 1e3)
    return result, statistics.median(times)


def demodulated(planes):
    """(illumination, albedo, direct, passthrough mask): indirect / albedo where albedo > 0."""
    albedo, direct, indirect = planes["albedo"], planes["direct"], planes["indirect"]
    # Non-finite samples (rare) would spread through every window; zero them as lumo does.
    indirect = np.nan_to_num(indirect, nan=0.0, posinf=0.0, neginf=0.0)
    dark = albedo < 1e-3
    illum = np.where(dark, indirect, indirect / np.maximum(albedo, 1e-3)).astype(np.float32)
    return illum, albedo, direct, dark


def remodulate(filtered, planes, dark):
    albedo, direct, indirect = planes["albedo"], planes["direct"], planes["indirect"]
    ind = np.where(dark, indirect, albedo * filtered)
    return (direct + ind).astype(np.float32)


def peers(cv2, pyoidn, a):
    """name -> (label, fn(planes) -> image). Each fn is timed as a whole."""
    out = {}
    if pyoidn is not None:
        def oidn(p):
            n = np.nan_to_num(p["normal"]).astype(np.float32)
            c = np.nan_to_num(p["color"], posinf=0.0).clip(0, None).astype(np.float32)
            return pyoidn.denoise(c, p["albedo"], n, hdr=True, quality="high")
        out["oidn"] = oidn

    def guide(p):
        return np.ascontiguousarray(np.nan_to_num(p["normal"]) * 0.5 + 0.5, dtype=np.float32)

    def cv_guided(p):
        illum, _, _, dark = demodulated(p)
        f = cv2.ximgproc.guidedFilter(guide(p), illum, a.guided_radius, a.guided_eps, -1)
        return remodulate(f, p, dark)
    out["opencv-guided"] = cv_guided

    def cv_jbf(p):
        illum, _, _, dark = demodulated(p)
        f = cv2.ximgproc.jointBilateralFilter(guide(p), illum, 2 * a.jbf_radius + 1,
                                              a.jbf_sigma_color, a.jbf_sigma_space)
        return remodulate(f, p, dark)
    out["opencv-jbf"] = cv_jbf
    return out


def load_planes(d):
    return {k: read_pfm(os.path.join(d, f"{k}.pfm")) for k in
            ["color", "albedo", "normal", "direct", "indirect"]}


def table_name(scene):
    """The name lumo's tables use: a built-in's name, a scene file's file name."""
    return os.path.basename(scene) if ("/" in scene or "." in scene) else scene


def atomic_write(path, text):
    tmp = os.path.join(os.path.dirname(path) or ".", f".{os.path.basename(path)}.tmp-{os.getpid()}")
    with open(tmp, "w") as f:
        f.write(text)
    os.replace(tmp, path)


def table_bounds(lines, heading):
    """(first row index, end index) of the table under `heading` (after its header + rule)."""
    i = lines.index(heading)
    while not lines[i].startswith("|"):
        i += 1
    j = i
    while j < len(lines) and lines[j].startswith("|"):
        j += 1
    return i + 2, j


def cells(line):
    return [c.strip() for c in line.strip().strip("|").split("|")]


def update_quality(md, results, scenes, spps, versions, settings_text):
    lines = [l for l in md.split("\n") if not (l.startswith("|") and PEER_MARK in l)]
    # Drop a previous peers section.
    if "## Peers" in lines:
        k = lines.index("## Peers")
        lines = lines[:k]
        while lines and lines[-1] == "":
            lines.pop()
        lines.append("")
    names = list(dict.fromkeys(r["peer"] for r in results))
    for heading, key, fmt in [("## relMSE per method and scene", "relmse", "{:.2e}"),
                              ("## FLIP per method and scene", "flip", "{:.4f}")]:
        start, end = table_bounds(lines, heading)
        header = cells(lines[start - 2])[1:]
        new = []
        for n in names:
            row = [f"{n} {PEER_MARK}"]
            for col in header:
                m = re.match(r"(.+) (\d+) spp$", col)
                r = next((r for r in results if m and r["peer"] == n and r["scene"] == m.group(1)
                          and r["spp"] == int(m.group(2))), None)
                row.append(sci(r[key]) if r and key == "relmse" else
                           (fmt.format(r[key]) if r else "—"))
            new.append("| " + " | ".join(row) + " |")
        lines[end:end] = new
    for s in scenes:
        start, end = table_bounds(lines, f"### {s}")
        trace = {}
        for l in lines[start:end]:
            c = cells(l)
            if c[0] == "none":
                trace[int(c[1])] = float(c[8])
        new = []
        for spp in spps:
            for n in names:
                r = next((r for r in results if r["peer"] == n and r["scene"] == s and r["spp"] == spp), None)
                if r is None:
                    continue
                t = trace.get(spp, float("nan"))
                psnr = "inf" if r["psnr_db"] is None else f"{r['psnr_db']:.2f}"
                new.append(f"| {n} {PEER_MARK} | {spp} | {sci(r['mse'])} | {sci(r['relmse'])} | "
                           f"{r['smape']:.4f} | {psnr} | {r['ssim']:.4f} | {r['flip']:.4f} | "
                           f"{t:.0f} | {r['ms']:.0f} | {t + r['ms']:.0f} |")
        lines[end:end] = new
    text = "\n".join(lines).rstrip("\n") + "\n\n## Peers\n\n" + settings_text + "\n\n" + versions + "\n"
    return text


def sci(v):
    """Like lumo's `{:.2e}`: 1.23e-2, 4.00e0."""
    if v is None:
        return "—"
    m, e = f"{v:.2e}".split("e")
    return f"{m}e{int(e)}"


def speed_section(rows, versions, settings_text, lumo_rows):
    sizes = list(dict.fromkeys(r[1] for r in rows))
    out = ["## Peers: filter time per resolution", "",
           "From `tools/peers/run_peers.py`, in one run: ms per frame on lumo's cornell render at 1 spp "
           "(`lumo bench inputs`), median of the repeats after a warm-up call; OpenCV and OIDN timed "
           "in-process including demodulation, lumo's filters by `lumo denoise --timings` (the "
           "`filter` line, median of separate processes) on the same planes. " + settings_text, "",
           "| filter | " + " | ".join(f"{w}×{h} ms" for w, h in sizes) + " |",
           "|---|" + "---:|" * len(sizes)]
    names = list(dict.fromkeys(r[0] for r in rows))
    for n in names:
        vals = [next((f"{r[2]:.1f}" for r in rows if r[0] == n and r[1] == s), "—") for s in sizes]
        out.append(f"| {n} {PEER_MARK} | " + " | ".join(vals) + " |")
    for n in dict.fromkeys(r[0] for r in lumo_rows):
        vals = [next((f"{r[2]:.1f}" for r in lumo_rows if r[0] == n and r[1] == s), "—") for s in sizes]
        out.append(f"| {n} | " + " | ".join(vals) + " |")
    out += ["", versions]
    return "\n".join(out) + "\n"


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--lumo", default=os.path.join("target", "release", "lumo"))
    ap.add_argument("--scenes", default="cornell,cornell-spheres,atrium")
    ap.add_argument("--size", default="256x256")
    ap.add_argument("--spp", default="1,4")
    ap.add_argument("--reference-spp", default="1024")
    ap.add_argument("--seed", default="0")
    ap.add_argument("--max-depth", default=None)
    ap.add_argument("--cache", default=os.path.join("target", "lumo-bench-cache"))
    ap.add_argument("--results", default=os.path.join("docs", "results"))
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--speed-sizes", default="512x512,1024x1024",
                    help="resolutions of the speed.md peers section ('' to skip)")
    ap.add_argument("--guided-radius", type=int, default=8)
    ap.add_argument("--guided-eps", type=float, default=0.003)
    ap.add_argument("--jbf-radius", type=int, default=16)
    ap.add_argument("--jbf-sigma-color", type=float, default=0.3)
    ap.add_argument("--jbf-sigma-space", type=float, default=8.0)
    ap.add_argument("--set", default=None,
                    help="score the frames of `lumo bench quality --set SET` instead "
                         "(heldout_set.py): RESULTS/SET.md and SET.png")
    a = ap.parse_args()
    import cv2
    try:
        import pyoidn
        oidn_version = f"pyoidn {pyoidn_version()} (OIDN {pyoidn.version.oidn_version})"
    except ImportError as e:  # keep the OpenCV peers and say why OIDN is missing
        pyoidn, oidn_version = None, f"pyoidn unavailable: {e}"
        print(oidn_version, file=sys.stderr)
    lumo_version = run([a.lumo, "--version"]).stdout.strip()
    versions = (f"Versions: {lumo_version}; {oidn_version}; OpenCV {cv2.__version__} "
                f"(opencv-contrib-python-headless, {cv2.getNumThreads()} threads); NumPy "
                f"{np.__version__}; Python {platform.python_version()}.")
    settings_text = (
        f"OIDN: `pyoidn.denoise(color, albedo, normal, hdr=True, quality=\"high\")` on the whole "
        f"noisy colour. OpenCV: on the demodulated indirect light (indirect / albedo), guide = "
        f"normal·0.5+0.5 (float32, 3 channels), then direct + albedo·filtered — the way lumo's "
        f"guided, jbu and bilateral pipelines treat indirect light; `guidedFilter` r = "
        f"{a.guided_radius}, eps = {a.guided_eps}; `jointBilateralFilter` d = {2 * a.jbf_radius + 1}, "
        f"sigmaColor = {a.jbf_sigma_color}, sigmaSpace = {a.jbf_sigma_space}. Times: median of "
        f"{a.repeats} in-process calls after a warm-up call (for OIDN the warm-up creates the device).")
    if a.set:
        from heldout_set import main_set
        if a.speed_sizes == "512x512,1024x1024":
            a.speed_sizes = "512x512,1920x1080"
        return main_set(a, cv2, pyoidn, versions)
    fns = peers(cv2, pyoidn, a)
    scenes = a.scenes.split(",")
    spps = [int(s) for s in a.spp.split(",")]
    common = ["--size", a.size, "--seed", a.seed] + (["--max-depth", a.max_depth] if a.max_depth else [])
    results = []
    with tempfile.TemporaryDirectory() as d:
        for s in scenes:
            ref = run([a.lumo, "bench", "reference", s, "--reference-spp", a.reference_spp,
                       "--cache", a.cache] + common).stdout.strip()
            for spp in spps:
                inputs = os.path.join(d, f"{s}-{spp}")
                run([a.lumo, "bench", "inputs", s, "--spp", str(spp), "--out", inputs] + common)
                planes = load_planes(inputs)
                for name, fn in fns.items():
                    img, ms = timed(lambda: fn(planes), a.repeats)
                    out = os.path.join(d, f"{s}-{spp}-{name}.pfm")
                    write_pfm(out, img)
                    j = json.loads(run([a.lumo, "compare", ref, out, "--json"]).stdout)["images"][0]
                    j.update(peer=name, scene=table_name(s), spp=spp, ms=ms)
                    results.append(j)
                    print(f"{s} {spp} spp {name}: relMSE {j['relmse']:.3e} FLIP {j['flip']:.4f} "
                          f"{ms:.1f} ms", file=sys.stderr)
        speed_rows, lumo_rows = [], []
        for size in [x for x in a.speed_sizes.split(",") if x]:
            w, h = map(int, size.split("x"))
            inputs = os.path.join(d, f"speed-{size}")
            run([a.lumo, "bench", "inputs", "cornell", "--spp", "1", "--size", size, "--out", inputs])
            planes = load_planes(inputs)
            for name, fn in fns.items():
                _, ms = timed(lambda: fn(planes), a.repeats)
                speed_rows.append((name, (w, h), ms))
            for label, extra in [("lumo À-Trous (`lumo denoise --filter atrous`)", ["--filter", "atrous"]),
                                 ("lumo guided (`lumo denoise --filter guided`)", ["--filter", "guided"])]:
                times = []
                for _ in range(a.repeats):
                    o = run([a.lumo, "denoise", "--input-dir", inputs, *extra, "--timings",
                             "-o", os.path.join(d, "lumo-out.pfm")]).stdout
                    times.append(float(re.search(r"^filter ([0-9.]+) ms$", o, re.M).group(1)))
                lumo_rows.append((label, (w, h), statistics.median(times)))
            print(f"speed {size} done", file=sys.stderr)
    qpath = os.path.join(a.results, "quality.md")
    with open(qpath) as f:
        md = f.read()
    names = [table_name(s) for s in scenes]
    atomic_write(qpath, update_quality(md, results, names, spps, versions, settings_text))
    spath = os.path.join(a.results, "speed.md")
    if speed_rows and os.path.exists(spath):
        with open(spath) as f:
            sp = f.read()
        k = sp.find("## Peers")
        sp = (sp[:k] if k >= 0 else sp).rstrip("\n") + "\n\n"
        atomic_write(spath, sp + speed_section(speed_rows, versions, settings_text, lumo_rows))
    print(f"updated {qpath}" + (f" and {spath}" if speed_rows else ""), file=sys.stderr)


def pyoidn_version():
    try:
        from importlib.metadata import version
        return version("pyoidn")
    except Exception:  # metadata missing in odd installs; the OIDN version still says enough
        return "?"


if __name__ == "__main__":
    main()
