#!/usr/bin/env python3
"""Writes scenes/skinned.gltf, the skinned and morphing glTF example of docs/animation.md (run
from the repo root; standard library only).

A tube standing on a floor, skinned to a chain of three joints (root, middle, tip): over two
seconds the middle and tip joints bend it sideways and back (rotation keys, linear), while a
morph target (a bulge around the middle) swells and shrinks (animated `weights`, linear).
Each vertex is weighted to its two nearest joints along the tube, so the bend is smooth.

  -o PATH    output file (default scenes/skinned.gltf).
"""
import argparse
import base64
import json
import math
import struct

RADIUS, HEIGHT = 0.25, 2.4
RINGS, SEGMENTS = 16, 16
JOINT_Y = [0.0, 0.8, 1.6]


def tube():
    """Positions, normals, joints, weights and bulge displacements of an open tube along +y."""
    pos, nrm, joints, weights, bulge = [], [], [], [], []
    for r in range(RINGS + 1):
        y = HEIGHT * r / RINGS
        # Linear blend between the two joints around y (the tip joint holds above it).
        k = min(int(y / 0.8), 2)
        f = min((y - JOINT_Y[k]) / 0.8, 1.0) if k < 2 else 0.0
        j = [k, min(k + 1, 2), 0, 0]
        w = [1.0 - f, f, 0.0, 0.0] if k < 2 else [1.0, 0.0, 0.0, 0.0]
        swell = 0.15 * math.exp(-((y - 1.2) / 0.4) ** 2)
        for s in range(SEGMENTS + 1):
            a = 2 * math.pi * s / SEGMENTS
            c, sn = math.cos(a), math.sin(a)
            pos.append((RADIUS * c, y, RADIUS * sn))
            nrm.append((c, 0.0, sn))
            joints.append(j)
            weights.append(w)
            bulge.append((swell * c, 0.0, swell * sn))
    idx = []
    for r in range(RINGS):
        for s in range(SEGMENTS):
            a = r * (SEGMENTS + 1) + s
            b, c, d = a + 1, a + SEGMENTS + 1, a + SEGMENTS + 2
            # Counter-clockwise seen from outside.
            idx += [a, c, b, b, c, d]
    return pos, nrm, joints, weights, bulge, idx


def quat_z(deg):
    h = math.radians(deg) / 2
    return (0.0, 0.0, math.sin(h), math.cos(h))


def main():
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("-o", "--output", default="scenes/skinned.gltf")
    args = ap.parse_args()

    chunks, views, accessors = [], [], []

    def add(values, fmt, acc_type, component, bounds=False):
        raw = b"".join(struct.pack("<" + fmt, *(v if isinstance(v, (tuple, list)) else (v,)))
                       for v in values)
        offset = sum(len(c) for c in chunks)
        chunks.append(raw + b"\0" * (-len(raw) % 4))
        views.append({"buffer": 0, "byteOffset": offset, "byteLength": len(raw)})
        acc = {"bufferView": len(views) - 1, "componentType": component,
               "count": len(values), "type": acc_type}
        if bounds:
            flat = [v if isinstance(v, (tuple, list)) else (v,) for v in values]
            acc["min"] = [min(c) for c in zip(*flat)]
            acc["max"] = [max(c) for c in zip(*flat)]
        accessors.append(acc)
        return len(accessors) - 1

    F, U16, U32 = 5126, 5123, 5125
    pos, nrm, joints, weights, bulge, idx = tube()
    floor = [(-3, 0, -3), (3, 0, -3), (3, 0, 3), (-3, 0, 3)]
    tube_prim = {
        "attributes": {"POSITION": add(pos, "3f", "VEC3", F, bounds=True),
                       "NORMAL": add(nrm, "3f", "VEC3", F),
                       "JOINTS_0": add(joints, "4H", "VEC4", U16),
                       "WEIGHTS_0": add(weights, "4f", "VEC4", F)},
        "targets": [{"POSITION": add(bulge, "3f", "VEC3", F, bounds=True)}],
        "indices": add(idx, "I", "SCALAR", U32), "material": 1}
    floor_prim = {"attributes": {"POSITION": add(floor, "3f", "VEC3", F, bounds=True)},
                  "indices": add([0, 2, 1, 0, 3, 2], "I", "SCALAR", U32), "material": 0}
    # Inverse bind matrices: the joints stand at y = 0, 0.8, 1.6 (world) at bind time.
    ibm = [(1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, -y, 0, 1) for y in JOINT_Y]
    ibm_acc = add(ibm, "16f", "MAT4", F)

    times = [0.0, 1.0, 2.0]
    t = add(times, "f", "SCALAR", F, bounds=True)
    bend = add([quat_z(a) for a in (0.0, 35.0, 0.0)], "4f", "VEC4", F)
    swell = add([0.0, 1.0, 0.0], "f", "SCALAR", F)
    animation = {
        "name": "bend",
        "samplers": [{"input": t, "output": bend, "interpolation": "LINEAR"},
                     {"input": t, "output": swell, "interpolation": "LINEAR"}],
        "channels": [{"sampler": 0, "target": {"node": 3, "path": "rotation"}},
                     {"sampler": 0, "target": {"node": 4, "path": "rotation"}},
                     {"sampler": 1, "target": {"node": 1, "path": "weights"}}],
    }
    nodes = [
        {"name": "floor", "mesh": 0},
        {"name": "tube", "mesh": 1, "skin": 0},
        {"name": "root", "children": [3]},
        {"name": "middle", "translation": [0, 0.8, 0], "children": [4]},
        {"name": "tip", "translation": [0, 0.8, 0]},
        {"name": "camera", "camera": 0, "translation": [0, 1.3, 5.5]},
        {"name": "sun", "rotation": [-0.3826834, 0.0, 0.0, 0.9238795],
         "extensions": {"KHR_lights_punctual": {"light": 0}}},
    ]
    buffer = b"".join(chunks)
    doc = {
        "asset": {"version": "2.0", "generator": "lumo scripts/make_skinned_scene.py"},
        "extensionsUsed": ["KHR_lights_punctual"],
        "scene": 0,
        "scenes": [{"nodes": [0, 1, 2, 5, 6]}],
        "nodes": nodes,
        "meshes": [{"name": "floor", "primitives": [floor_prim]},
                   {"name": "tube", "primitives": [tube_prim], "weights": [0.0]}],
        "skins": [{"joints": [2, 3, 4], "inverseBindMatrices": ibm_acc, "skeleton": 2}],
        "materials": [
            {"name": "floor", "pbrMetallicRoughness": {"baseColorFactor": [0.7, 0.7, 0.7, 1],
                                                        "metallicFactor": 0, "roughnessFactor": 1}},
            {"name": "tube", "doubleSided": True,
             "pbrMetallicRoughness": {"baseColorFactor": [0.2, 0.45, 0.8, 1],
                                      "metallicFactor": 0, "roughnessFactor": 0.4}},
        ],
        "cameras": [{"type": "perspective",
                     "perspective": {"yfov": 0.7, "aspectRatio": 1.0, "znear": 0.1}}],
        "extensions": {"KHR_lights_punctual": {"lights": [
            {"type": "directional", "color": [1.0, 0.95, 0.9], "intensity": 3.0}]}},
        "animations": [animation],
        "buffers": [{"byteLength": len(buffer),
                     "uri": "data:application/octet-stream;base64,"
                            + base64.b64encode(buffer).decode()}],
        "bufferViews": views,
        "accessors": accessors,
    }
    with open(args.output, "w") as f:
        json.dump(doc, f, indent=1)
        f.write("\n")
    print("%s: %d tube triangles, %d bytes" % (args.output, len(idx) // 3, len(buffer)))


if __name__ == "__main__":
    main()
