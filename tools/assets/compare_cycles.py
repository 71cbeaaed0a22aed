#!/usr/bin/env python3
"""lumo beside Blender Cycles on the glTF asset set (scenes/assets/, made by make_assets.py):
the same .glb files, read by lumo's loader and by Blender's own glTF importer (which maps glTF
materials onto Cycles' Principled BSDF), rendered at equal resolution and path depth.

    pip install bpy numpy
    cargo build --release -p lumo-cli
    python3 tools/assets/compare_cycles.py     # → docs/results/assets-cycles.md, docs/images/assets-cycles.png

Settings shared by both: a one-pixel box filter, no denoiser, no clamping, no adaptive
sampling, black surroundings, lumo `--max-depth D` against Cycles' `max_bounces = D − 2`
(the mapping that makes them agree within 0.1 % on the Cornell box, docs/results/peers.md).
Cycles' Principled BSDFs are switched from multiple-scattering GGX (its default) to
single-scattering GGX, which is what the glTF specification and lumo use; the report states
where the remaining models differ. For each scene it reports the per-channel image means
(lumo / Cycles), the relMSE between the two images and each one's own noise (from a second
seed), and the 32-px blocks' mean ratios; the contact sheet shows lumo, Cycles and their
relative difference per scene.

Cycles ignores KHR_lights_punctual's `range` (its lights fall off with the inverse square
everywhere), so a scene whose point or spot lights have one is compared without it: both
renderers read a copy with every `range` removed, and the script says so.
"""
import argparse
import json
import os
import struct
import subprocess
import sys
import tempfile
import time
import urllib.parse

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.abspath(os.path.join(HERE, "..", ".."))
sys.path.insert(0, os.path.join(REPO, "tools", "peers"))
from render_peers import cycles_settings  # noqa: E402
from run_peers import read_pfm  # noqa: E402

#: Per scene: the time lumo renders at (seconds; None for a still) and the Blender frame.
POSES = {"character": (2.0, 60)}
BLOCK = 32


GLB_MAGIC, GLB_JSON, GLB_BIN = 0x46546C67, 0x4E4F534A, 0x004E4942


def read_gltf(path):
    """The file's JSON (a dict) and, for a .glb, its binary chunk (None for a .gltf)."""
    with open(path, "rb") as f:
        data = f.read()
    if len(data) < 12 or struct.unpack_from("<I", data, 0)[0] != GLB_MAGIC:
        return json.loads(data.decode("utf-8")), None
    at, doc, binary = 12, None, None
    while at + 8 <= len(data):
        length, kind = struct.unpack_from("<II", data, at)
        chunk = data[at + 8:at + 8 + length]
        if kind == GLB_JSON:
            doc = json.loads(chunk.decode("utf-8"))
        elif kind == GLB_BIN and binary is None:
            binary = chunk
        at += 8 + length
    if doc is None:
        sys.exit(f"{path}: a .glb without a JSON chunk")
    return doc, binary if binary is not None else b""


def write_glb(path, doc, binary):
    """A .glb of `doc` and `binary`, each chunk padded to 4 bytes as the spec requires (the
    JSON with spaces, the binary with zeros)."""
    text = json.dumps(doc, separators=(",", ":")).encode("utf-8")
    text += b" " * (-len(text) % 4)
    chunks = struct.pack("<II", len(text), GLB_JSON) + text
    if binary:
        binary += b"\0" * (-len(binary) % 4)
        chunks += struct.pack("<II", len(binary), GLB_BIN) + binary
    with open(path, "wb") as f:
        f.write(struct.pack("<III", GLB_MAGIC, 2, 12 + len(chunks)) + chunks)


def without_light_range(scene, tmp):
    """`scene`, or where a KHR_lights_punctual light has a `range`, a copy in `tmp` (same file
    name) with every `range` removed: Cycles ignores it, so lumo must too for a like-for-like
    comparison. The copy's relative buffer and image URIs point back at the original's files.
    Returns the path to render and the names of the lights whose range was removed."""
    doc, binary = read_gltf(scene)
    lights = doc.get("extensions", {}).get("KHR_lights_punctual", {}).get("lights", [])
    ranged = []
    for i, light in enumerate(lights):
        if "range" in light:
            del light["range"]
            ranged.append(light.get("name", f"light {i}"))
    if not ranged:
        return scene, ranged
    base = os.path.dirname(os.path.abspath(scene))
    for item in doc.get("buffers", []) + doc.get("images", []):
        uri = item.get("uri")
        if uri is not None and not uri.startswith("data:") and "://" not in uri:
            # Both loaders percent-decode a URI and join it to the file's folder; an
            # absolute path survives the join.
            absolute = os.path.join(base, urllib.parse.unquote(uri))
            item["uri"] = urllib.parse.quote(absolute)
    out = os.path.join(tmp, os.path.basename(scene))
    if binary is None:
        with open(out, "w") as f:
            json.dump(doc, f)
    else:
        write_glb(out, doc, binary)
    return out, ranged


def render_lumo(a, scene, seed, out):
    t, _ = POSES.get(os.path.splitext(os.path.basename(scene))[0], (None, None))
    cmd = [a.lumo, "render", scene, "--size", f"{a.res}x{a.res}", "--spp", str(a.spp),
           "--max-depth", str(a.depth), "--seed", str(seed), "--pipeline", "none", "-o", out]
    if t is not None:
        cmd += ["--time", str(t)]
    t0 = time.perf_counter()
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit(f"lumo failed on {scene}:\n{r.stderr}")
    return time.perf_counter() - t0, read_pfm(out), r.stderr


def render_cycles(a, scene, seed, out):
    import bpy

    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.import_scene.gltf(filepath=scene)
    sc = bpy.context.scene
    cams = [o for o in sc.objects if o.type == "CAMERA"]
    if not cams:
        sys.exit(f"{scene}: Blender's importer found no camera")
    sc.camera = cams[0]
    _, frame = POSES.get(os.path.splitext(os.path.basename(scene))[0], (None, None))
    if frame is not None:
        sc.frame_set(frame)
    cycles_settings(sc, a.depth, seed, a.threads, (a.res, a.res))
    cy = sc.cycles
    cy.transparent_max_bounces = 64  # alpha-masked layers are not path vertices in lumo
    cy.samples = a.cycles_spp
    world = bpy.data.worlds.new("black")
    world.use_nodes = True
    world.node_tree.nodes["Background"].inputs["Strength"].default_value = 0.0
    sc.world = world
    for m in bpy.data.materials:
        for n in (m.node_tree.nodes if m.node_tree else []):
            if n.type == "BSDF_PRINCIPLED":
                n.distribution = "GGX"
            if n.type == "VOLUME_ABSORPTION":
                exact_attenuation(n)
    sc.render.filepath = out
    t0 = time.perf_counter()
    bpy.ops.render.render(write_still=True)
    t = time.perf_counter() - t0
    img = bpy.data.images.load(out)
    px = np.array(img.pixels[:], dtype=np.float32).reshape(img.size[1], img.size[0], 4)
    bpy.data.images.remove(img)
    return t, px[::-1, :, :3].copy()


def exact_attenuation(node):
    """KHR_materials_volume's absorption, σ = −ln(attenuationColor) / attenuationDistance per
    channel, on a Cycles Volume Absorption node (σ = density × (1 − colour)). Blender's importer
    sets density 1/distance and colour = attenuationColor, which absorbs less (0.65 against
    1.05 per distance for a channel of 0.35)."""
    density = node.inputs["Density"].default_value
    color = node.inputs["Color"].default_value[:3]
    if density <= 0.0:
        return
    sigma = [-np.log(max(c, 1e-6)) * density for c in color]
    top = max(sigma)
    if top <= 0.0:
        return
    node.inputs["Density"].default_value = top
    node.inputs["Color"].default_value = (*[1.0 - s / top for s in sigma], 1.0)


def rel_mse(x, ref):
    return float(np.mean((x - ref) ** 2 / (ref ** 2 + 0.01)))


def block_ratios(l, c):
    """lumo / Cycles luminance means of each 32×32 block bright enough to compare (mean above 2 %
    of the image's)."""
    lum = lambda x: x @ np.array([0.2126, 0.7152, 0.0722])  # noqa: E731
    ll, lc = lum(l), lum(c)
    h, w = ll.shape
    out = []
    floor = 0.02 * lc.mean()
    for y in range(0, h - BLOCK + 1, BLOCK):
        for x in range(0, w - BLOCK + 1, BLOCK):
            bl, bc = ll[y:y + BLOCK, x:x + BLOCK].mean(), lc[y:y + BLOCK, x:x + BLOCK].mean()
            if bc > floor:
                out.append(bl / bc)
    return np.array(out)


def srgb(x, exposure=1.0):
    x = np.clip(x * exposure, 0.0, 1.0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1 / 2.4) - 0.055)


def heat(d):
    """|relative difference| 0 → black, 0.1 and above → white, through red and yellow."""
    t = np.clip(d / 0.1, 0.0, 1.0)
    return np.stack([np.clip(3 * t, 0, 1), np.clip(3 * t - 1, 0, 1), np.clip(3 * t - 2, 0, 1)], -1)


def save_png(path, rgb):
    """Writes an sRGB (H, W, 3) array in [0, 1] as PNG through Blender's image API."""
    import bpy

    h, w = rgb.shape[:2]
    img = bpy.data.images.new("sheet", w, h, alpha=False)
    rgba = np.concatenate([rgb, np.ones((h, w, 1))], -1)[::-1]
    # Blender stores byte images in sRGB already; mark the buffer as raw so it is not re-encoded.
    img.colorspace_settings.name = "Non-Color"
    img.pixels = rgba.astype(np.float32).ravel().tolist()
    img.filepath_raw = path
    img.file_format = "PNG"
    img.save()
    bpy.data.images.remove(img)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--lumo", default=os.path.join(REPO, "target", "release", "lumo"))
    ap.add_argument("--scenes", nargs="*", default=None)
    ap.add_argument("--res", type=int, default=192)
    ap.add_argument("--spp", type=int, default=1024, help="lumo's samples per pixel")
    ap.add_argument("--cycles-spp", type=int, default=1024)
    ap.add_argument("--depth", type=int, default=10)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--md", default=os.path.join(REPO, "docs", "results", "assets-cycles.md"))
    ap.add_argument("--sheet", default=os.path.join(REPO, "docs", "images", "assets-cycles.png"))
    a = ap.parse_args()
    scenes = a.scenes or sorted(
        os.path.join(REPO, "scenes", "assets", f)
        for f in os.listdir(os.path.join(REPO, "scenes", "assets")) if f.endswith(".glb"))
    import bpy

    rows, tiles = [], []
    with tempfile.TemporaryDirectory() as tmp:
        for scene in scenes:
            name = os.path.splitext(os.path.basename(scene))[0]
            scene, ranged = without_light_range(scene, tmp)
            if ranged:
                print(f"note: {name}: removed KHR_lights_punctual `range` from "
                      f"{', '.join(ranged)} for both renderers (Cycles ignores it)",
                      file=sys.stderr, flush=True)
            tl, l0, log = render_lumo(a, scene, 0, os.path.join(tmp, f"{name}-l0.pfm"))
            _, l1, _ = render_lumo(a, scene, 1, os.path.join(tmp, f"{name}-l1.pfm"))
            tc, c0 = render_cycles(a, scene, 0, os.path.join(tmp, f"{name}-c0.exr"))
            _, c1 = render_cycles(a, scene, 1, os.path.join(tmp, f"{name}-c1.exr"))
            l, c = (l0 + l1) / 2, (c0 + c1) / 2
            # Each image's own relMSE (of the two-seed mean) from the seeds' difference.
            # E(l0 − l1)² = 2σ², and the two-seed mean has variance σ²/2: a quarter.
            noise_l = rel_mse(l0, l1) / 4
            noise_c = rel_mse(c0, c1) / 4
            ratios = block_ratios(l, c)
            warnings = [w for w in log.splitlines() if "warning" in w.lower()]
            row = {
                "scene": name,
                "mean_ratio": (l.reshape(-1, 3).mean(0) / c.reshape(-1, 3).mean(0)).tolist(),
                "rel_mse": rel_mse(l, c),
                "noise_lumo": noise_l,
                "noise_cycles": noise_c,
                "blocks": len(ratios),
                "block_median": float(np.median(ratios)) if len(ratios) else float("nan"),
                "block_p05": float(np.percentile(ratios, 5)) if len(ratios) else float("nan"),
                "block_p95": float(np.percentile(ratios, 95)) if len(ratios) else float("nan"),
                "seconds_lumo": tl, "seconds_cycles": tc,
                "lumo_warnings": warnings,
                "range_removed": ranged,
            }
            rows.append(row)
            print(json.dumps(row), file=sys.stderr, flush=True)
            exposure = 0.5 / max(float(np.percentile(c, 99)), 1e-6) * 1.6
            d = np.abs(l - c).mean(-1) / (c.mean(-1) + 0.02)
            tiles.append([srgb(l, exposure), srgb(c, exposure), heat(d)])
    gap = 4
    r = a.res
    sheet = np.full((len(tiles) * (r + gap) - gap, 3 * (r + gap) - gap, 3), 0.05)
    for i, row in enumerate(tiles):
        for j, t in enumerate(row):
            sheet[i * (r + gap):i * (r + gap) + r, j * (r + gap):j * (r + gap) + r] = t
    os.makedirs(os.path.dirname(a.sheet), exist_ok=True)
    save_png(a.sheet, sheet)
    with open(a.md, "w") as f:
        f.write(report(a, rows, bpy.app.version_string))
    print(f"wrote {a.sheet} and {a.md}", file=sys.stderr)


def report(a, rows, blender):
    import platform

    load = os.getloadavg()
    lines = [
        "# lumo beside Blender Cycles on the glTF asset set",
        "",
        f"Generated by `tools/assets/compare_cycles.py --res {a.res} --spp {a.spp} "
        f"--cycles-spp {a.cycles_spp} --depth {a.depth}` on {time.strftime('%d %B %Y, %H:%M UTC', time.gmtime())}, "
        f"{platform.processor() or platform.machine()}, {a.threads} threads, load average "
        f"{load[0]:.1f} at the end. Blender {blender} (`bpy`, Cycles CPU, single-scattering GGX). "
        "Scenes: `scenes/assets/*.glb`, made in Blender by `tools/assets/make_assets.py` and "
        "exported by its glTF exporter. Each image is the mean of two seeds; *noise* is that "
        "mean's own relMSE, estimated from the two seeds' difference. Discussion: "
        "[docs/gltf.md](../gltf.md#checked-against-cycles).",
        "",
        f"![lumo (left), Cycles (middle) and |lumo − Cycles| / (Cycles + 0.02) (right, black 0, "
        f"white ≥ 10 %), one row per scene]({os.path.relpath(a.sheet, os.path.dirname(a.md))})",
        "",
        "| scene | mean lumo / Cycles (R, G, B) | 32-px blocks: median [5 %, 95 %] | relMSE lumo vs Cycles | noise lumo / Cycles | time lumo / Cycles |",
        "|---|---|---|---:|---|---|",
    ]
    for r in rows:
        m = ", ".join(f"{v:.3f}" for v in r["mean_ratio"])
        lines.append(
            f"| {r['scene']} | {m} | {r['block_median']:.3f} [{r['block_p05']:.3f}, "
            f"{r['block_p95']:.3f}] | {r['rel_mse']:.2e} | {r['noise_lumo']:.1e} / "
            f"{r['noise_cycles']:.1e} | {r['seconds_lumo']:.1f} / {r['seconds_cycles']:.1f} s |")
    unranged = [f"{r['scene']} ({', '.join(r['range_removed'])})" for r in rows if r["range_removed"]]
    if unranged:
        lines += ["", "Compared without KHR_lights_punctual `range` (Cycles ignores it; the script "
                  "removed it for both renderers): " + "; ".join(unranged) + "."]
    warned = [(r["scene"], w) for r in rows for w in r["lumo_warnings"]]
    if warned:
        lines += ["", "lumo's warnings:", ""] + [f"- {s}: `{w}`" for s, w in warned]
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    main()
