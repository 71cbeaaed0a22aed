#!/usr/bin/env python3
"""Writes scenes/animated.gltf, the animated glTF scene of docs/animation.md (run from the
repo root; standard library only).

Two seconds of node animation over a static floor: a ball that bounces across the floor
(translation keys, linear), a cube that spins (rotation keys) on a turntable that slides (its
parent: a hierarchy), an emissive panel that sweeps overhead (an area light that moves) and a
point light that circles (KHR_lights_punctual). Camera 0 stands still; camera 1 dollies in
(keyframed camera, `--camera 1`).

  --grid N   floor tessellation: N×N quads, 2·N² static triangles (default 8). A large grid
             makes the static part heavy, as in a real scene, to compare the per-frame update
             with a full BVH build (docs/animation.md uses --grid 300: 180,000 triangles).
  -o PATH    output file (default scenes/animated.gltf).
"""
import argparse
import base64
import json
import math
import struct


def look_rotation(eye, target):
    """The glTF node rotation (x, y, z, w) of a camera at `eye` looking at `target`, +y up
    (glTF cameras look along their -z)."""
    f = [t - e for t, e in zip(target, eye)]
    n = math.sqrt(sum(c * c for c in f))
    z = [-c / n for c in f]
    up = (0.0, 1.0, 0.0)
    x = [up[1] * z[2] - up[2] * z[1], up[2] * z[0] - up[0] * z[2], up[0] * z[1] - up[1] * z[0]]
    n = math.sqrt(sum(c * c for c in x))
    x = [c / n for c in x]
    y = [z[1] * x[2] - z[2] * x[1], z[2] * x[0] - z[0] * x[2], z[0] * x[1] - z[1] * x[0]]
    # Rotation matrix with columns x, y, z to a quaternion.
    m00, m11, m22 = x[0], y[1], z[2]
    tr = m00 + m11 + m22
    if tr > 0:
        s = math.sqrt(tr + 1.0) * 2
        return [(y[2] - z[1]) / s, (z[0] - x[2]) / s, (x[1] - y[0]) / s, 0.25 * s]
    if m00 > m11 and m00 > m22:
        s = math.sqrt(1.0 + m00 - m11 - m22) * 2
        return [0.25 * s, (y[0] + x[1]) / s, (z[0] + x[2]) / s, (y[2] - z[1]) / s]
    if m11 > m22:
        s = math.sqrt(1.0 + m11 - m00 - m22) * 2
        return [(y[0] + x[1]) / s, 0.25 * s, (z[1] + y[2]) / s, (z[0] - x[2]) / s]
    s = math.sqrt(1.0 + m22 - m00 - m11) * 2
    return [(z[0] + x[2]) / s, (z[1] + y[2]) / s, 0.25 * s, (x[1] - y[0]) / s]


def grid(n, half):
    pos, idx = [], []
    for j in range(n + 1):
        for i in range(n + 1):
            pos.append((-half + 2 * half * i / n, 0.0, -half + 2 * half * j / n))
    for j in range(n):
        for i in range(n):
            a = j * (n + 1) + i
            b, c, d = a + 1, a + n + 1, a + n + 2
            # Counter-clockwise seen from above (+y).
            idx += [a, c, b, b, c, d]
    return pos, idx


def uv_sphere(rings, segments):
    pos, nrm, idx = [], [], []
    for r in range(rings + 1):
        th = math.pi * r / rings
        for s in range(segments + 1):
            ph = 2 * math.pi * s / segments
            p = (math.sin(th) * math.cos(ph), math.cos(th), math.sin(th) * math.sin(ph))
            pos.append(p)
            nrm.append(p)
    for r in range(rings):
        for s in range(segments):
            a = r * (segments + 1) + s
            b, c, d = a + 1, a + segments + 1, a + segments + 2
            # The first and last rings meet at the poles: skip their zero-area triangles.
            if r > 0:
                idx += [a, b, c]
            if r < rings - 1:
                idx += [b, d, c]
    return pos, nrm, idx


CUBE_POS = [(x, y, z) for x in (-0.5, 0.5) for y in (-0.5, 0.5) for z in (-0.5, 0.5)]
CUBE_IDX = [0, 1, 3, 0, 3, 2, 4, 6, 7, 4, 7, 5, 0, 4, 5, 0, 5, 1,
            2, 3, 7, 2, 7, 6, 0, 2, 6, 0, 6, 4, 1, 5, 7, 1, 7, 3]
QUAD_POS = [(-1, 0, -1), (1, 0, -1), (1, 0, 1), (-1, 0, 1)]
QUAD_IDX = [0, 1, 2, 0, 2, 3]  # faces -y: the panel shines down


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--grid", type=int, default=8)
    ap.add_argument("-o", "--output", default="scenes/animated.gltf")
    args = ap.parse_args()
    if args.grid < 1 or (args.grid + 1) ** 2 > 2 ** 32:
        ap.error("--grid must be at least 1 and give fewer than 2^32 vertices")

    chunks, views, accessors = [], [], []

    def add(values, fmt, acc_type, component, target=None, bounds=False):
        raw = b"".join(struct.pack("<" + fmt, *(v if isinstance(v, (tuple, list)) else (v,)))
                       for v in values)
        offset = sum(len(c) for c in chunks)
        chunks.append(raw + b"\0" * (-len(raw) % 4))
        view = {"buffer": 0, "byteOffset": offset, "byteLength": len(raw)}
        if target:
            view["target"] = target
        views.append(view)
        acc = {"bufferView": len(views) - 1, "componentType": component,
               "count": len(values), "type": acc_type}
        if bounds:
            flat = [v if isinstance(v, (tuple, list)) else (v,) for v in values]
            acc["min"] = [min(c) for c in zip(*flat)]
            acc["max"] = [max(c) for c in zip(*flat)]
        accessors.append(acc)
        return len(accessors) - 1

    F, U32 = 5126, 5125
    vec3 = lambda vs: add(vs, "3f", "VEC3", F, 34962, bounds=True)
    index = lambda ix: add(ix, "I", "SCALAR", U32, 34963)

    floor_pos, floor_idx = grid(args.grid, 4.0)
    sphere_pos, sphere_nrm, sphere_idx = uv_sphere(16, 32)
    meshes = [
        {"name": "floor", "primitives": [{"attributes": {"POSITION": vec3(floor_pos)},
                                          "indices": index(floor_idx), "material": 0}]},
        {"name": "ball", "primitives": [{"attributes": {"POSITION": vec3(sphere_pos),
                                                        "NORMAL": vec3(sphere_nrm)},
                                         "indices": index(sphere_idx), "material": 1}]},
        {"name": "cube", "primitives": [{"attributes": {"POSITION": vec3(CUBE_POS)},
                                         "indices": index(CUBE_IDX), "material": 2}]},
        {"name": "panel", "primitives": [{"attributes": {"POSITION": vec3(QUAD_POS)},
                                          "indices": index(QUAD_IDX), "material": 3}]},
    ]

    def keys(times, values, fmt, acc_type):
        t = add(times, "f", "SCALAR", F, bounds=True)
        v = add(values, fmt, acc_type, F)
        return t, v

    samplers, channels = [], []

    def animate(node, path, times, values):
        fmt, acc_type = ("4f", "VEC4") if path == "rotation" else ("3f", "VEC3")
        t, v = keys(times, values, fmt, acc_type)
        samplers.append({"input": t, "output": v, "interpolation": "LINEAR"})
        channels.append({"sampler": len(samplers) - 1, "target": {"node": node, "path": path}})

    ts = [0.0, 0.5, 1.0, 1.5, 2.0]
    # Node numbers below: 0 floor, 1 ball, 2 turntable, 3 cube, 4 panel, 5 lamp, 6 camera,
    # 7 dolly camera.
    animate(1, "translation", ts, [(-2.0, 0.4, 1.0), (-1.0, 1.6, 1.0), (0.0, 0.4, 1.0),
                                   (1.0, 1.6, 1.0), (2.0, 0.4, 1.0)])
    animate(2, "translation", [0.0, 2.0], [(1.5, 0.0, -1.0), (-1.5, 0.0, -1.0)])
    spin = [[0.0, math.sin(a / 2), 0.0, math.cos(a / 2)]
            for a in (0.0, math.pi / 2, math.pi, 3 * math.pi / 2, 2 * math.pi)]
    animate(3, "rotation", ts, spin)
    animate(4, "translation", [0.0, 1.0, 2.0], [(-2.0, 3.0, 0.0), (0.0, 3.2, 0.5), (2.0, 3.0, 0.0)])
    circle = [(2.5 * math.cos(a), 2.5, 2.5 * math.sin(a)) for a in
              [2 * math.pi * k / 8 for k in range(9)]]
    animate(5, "translation", [2.0 * k / 8 for k in range(9)], circle)
    dolly_eye = [(0.0, 3.5, 10.0), (0.0, 2.5, 6.0)]
    animate(7, "translation", [0.0, 2.0], dolly_eye)

    eye, target = (0.0, 3.0, 8.0), (0.0, 0.8, 0.0)
    nodes = [
        {"name": "floor", "mesh": 0},
        {"name": "ball", "mesh": 1, "translation": [-2.0, 0.4, 1.0], "scale": [0.4, 0.4, 0.4]},
        {"name": "turntable", "translation": [1.5, 0.0, -1.0], "children": [3]},
        {"name": "cube", "mesh": 2, "translation": [0.0, 0.6, 0.0], "scale": [1.0, 1.2, 1.0]},
        {"name": "panel", "mesh": 3, "translation": [-2.0, 3.0, 0.0], "scale": [0.6, 1.0, 0.6]},
        {"name": "lamp", "translation": [2.5, 2.5, 0.0],
         "extensions": {"KHR_lights_punctual": {"light": 0}}},
        {"name": "camera", "camera": 0, "translation": list(eye),
         "rotation": look_rotation(eye, target)},
        {"name": "dolly", "camera": 0, "translation": list(dolly_eye[0]),
         "rotation": look_rotation((0.0, 3.0, 8.0), (0.0, 0.6, 0.0))},
    ]
    buffer = b"".join(chunks)
    doc = {
        "asset": {"version": "2.0", "generator": "lumo scripts/make_animated_scene.py"},
        "extensionsUsed": ["KHR_lights_punctual", "KHR_materials_emissive_strength"],
        "scene": 0,
        "scenes": [{"nodes": [0, 1, 2, 4, 5, 6, 7]}],
        "nodes": nodes,
        "meshes": meshes,
        "materials": [
            {"name": "floor", "pbrMetallicRoughness": {"baseColorFactor": [0.7, 0.7, 0.7, 1],
                                                        "metallicFactor": 0, "roughnessFactor": 1}},
            {"name": "red", "pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.15, 0.1, 1],
                                                      "metallicFactor": 0, "roughnessFactor": 0.5}},
            {"name": "gold", "pbrMetallicRoughness": {"baseColorFactor": [1.0, 0.77, 0.34, 1],
                                                       "metallicFactor": 1, "roughnessFactor": 0.3}},
            {"name": "panel", "emissiveFactor": [1.0, 0.9, 0.8],
             "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 12.0}},
             "pbrMetallicRoughness": {"baseColorFactor": [0.1, 0.1, 0.1, 1], "metallicFactor": 0}},
        ],
        "cameras": [{"type": "perspective",
                     "perspective": {"yfov": 0.7, "aspectRatio": 1.5, "znear": 0.1}}],
        "extensions": {"KHR_lights_punctual": {"lights": [
            {"type": "point", "color": [0.6, 0.8, 1.0], "intensity": 25}]}},
        "animations": [{"name": "play", "samplers": samplers, "channels": channels}],
        "buffers": [{"byteLength": len(buffer),
                     "uri": "data:application/octet-stream;base64,"
                            + base64.b64encode(buffer).decode()}],
        "bufferViews": views,
        "accessors": accessors,
    }
    with open(args.output, "w") as f:
        json.dump(doc, f, indent=1)
        f.write("\n")
    print("%s: %d floor triangles, %d bytes" % (args.output, 2 * args.grid ** 2, len(buffer)))


if __name__ == "__main__":
    main()
