#!/usr/bin/env python3
"""Writes the small binary and generated test assets under scenes/ (run from the repo root).

scenes/meshes/pyramid_le.ply, pyramid_be.ply, pyramid_ascii.ply: the same square pyramid
(5 vertices with normals, uvs and colours; the ASCII one with a quad base) in the three
PLY encodings. scenes/textures/checker.png: an 8×8 checkerboard. scenes/hierarchy.gltf and scenes/hierarchy.glb: a two-level node hierarchy (a
parent that carries a floor quad and a child cube), a perspective camera, a point and a spot
light (KHR_lights_punctual) and a one-second translation animation of the child.
Standard library only, so it runs anywhere Python 3 does.
"""
import base64
import os
import json
import struct
import zlib

PYR_V = [  # x y z  nx ny nz  u v  r g b
    (-1, 0, -1, 0, -1, 0, 0, 0, 255, 0, 0),
    (1, 0, -1, 0, -1, 0, 1, 0, 0, 255, 0),
    (1, 0, 1, 0, -1, 0, 1, 1, 0, 0, 255),
    (-1, 0, 1, 0, -1, 0, 0, 1, 255, 255, 0),
    (0, 1.5, 0, 0, 1, 0, 0.5, 0.5, 255, 255, 255),
]
# The ASCII file keeps the base as one quad (lumo fan-triangulates it); the binary files use
# two triangles, which Mitsuba's PLY reader also accepts.
PYR_F_QUAD = [(0, 1, 2, 3), (0, 4, 1), (1, 4, 2), (2, 4, 3), (3, 4, 0)]
PYR_F = [(0, 1, 2), (0, 2, 3), (0, 4, 1), (1, 4, 2), (2, 4, 3), (3, 4, 0)]


def ply_header(fmt, faces):
    return (
        "ply\nformat %s 1.0\ncomment lumo test pyramid\nelement vertex %d\n"
        "property float x\nproperty float y\nproperty float z\n"
        "property float nx\nproperty float ny\nproperty float nz\n"
        "property float u\nproperty float v\n"
        "property uchar red\nproperty uchar green\nproperty uchar blue\n"
        "element face %d\nproperty list uchar int vertex_indices\nend_header\n"
        % (fmt, len(PYR_V), len(faces))
    ).encode()


def write_ply(path, fmt):
    faces = PYR_F_QUAD if fmt == "ascii" else PYR_F
    with open(path, "wb") as f:
        f.write(ply_header(fmt, faces))
        if fmt == "ascii":
            for v in PYR_V:
                f.write((" ".join(str(x) for x in v) + "\n").encode())
            for face in faces:
                f.write((" ".join(str(x) for x in (len(face),) + face) + "\n").encode())
            return
        e = "<" if fmt == "binary_little_endian" else ">"
        for v in PYR_V:
            f.write(struct.pack(e + "8f3B", *v))
        for face in faces:
            f.write(struct.pack(e + "B%di" % len(face), len(face), *face))


def gltf_scene():
    # Buffer: floor quad (positions, normals, uvs, indices), cube (positions, indices),
    # animation times and translations.
    floor_pos = [(-2, 0, -2), (2, 0, -2), (2, 0, 2), (-2, 0, 2)]
    floor_nrm = [(0, 1, 0)] * 4
    floor_uv = [(0, 0), (1, 0), (1, 1), (0, 1)]
    floor_idx = [0, 2, 1, 0, 3, 2]
    cube_pos = [(x, y, z) for x in (-0.5, 0.5) for y in (0, 1) for z in (-0.5, 0.5)]
    # Outward counter-clockwise faces of the cube (vertex = 4x + 2y + z).
    cube_idx = [0, 1, 3, 0, 3, 2, 4, 6, 7, 4, 7, 5, 0, 4, 5, 0, 5, 1,
                2, 3, 7, 2, 7, 6, 0, 2, 6, 0, 6, 4, 1, 5, 7, 1, 7, 3]
    times = [0.0, 1.0]
    moves = [(0, 0, 0), (1, 0, 0)]
    chunks = []

    def add(data, fmt):
        off = sum(len(c) for c in chunks)
        raw = b"".join(struct.pack("<" + fmt, *(d if isinstance(d, tuple) else (d,))) for d in data)
        raw += b"\0" * (-len(raw) % 4)
        chunks.append(raw)
        return off, len(raw)

    views = [add(floor_pos, "3f"), add(floor_nrm, "3f"), add(floor_uv, "2f"),
             add(floor_idx, "H"), add(cube_pos, "3f"), add(cube_idx, "H"),
             add(times, "f"), add(moves, "3f")]
    blob = b"".join(chunks)
    buffer_views = [{"buffer": 0, "byteOffset": o, "byteLength": n} for o, n in views]

    def acc(view, ctype, count, typ, **kw):
        a = {"bufferView": view, "componentType": ctype, "count": count, "type": typ}
        a.update(kw)
        return a

    F, U16 = 5126, 5123
    accessors = [
        acc(0, F, 4, "VEC3", min=[-2, 0, -2], max=[2, 0, 2]),
        acc(1, F, 4, "VEC3"),
        acc(2, F, 4, "VEC2"),
        acc(3, U16, 6, "SCALAR"),
        acc(4, F, 8, "VEC3", min=[-0.5, 0, -0.5], max=[0.5, 1, 0.5]),
        acc(5, U16, 36, "SCALAR"),
        acc(6, F, 2, "SCALAR", min=[0], max=[1]),
        acc(7, F, 2, "VEC3"),
    ]
    doc = {
        "asset": {"version": "2.0", "generator": "lumo scripts/make_test_scenes.py"},
        "extensionsUsed": ["KHR_lights_punctual"],
        "scene": 0,
        "scenes": [{"nodes": [0, 2, 3, 4]}],
        "nodes": [
            {"name": "base", "mesh": 0, "translation": [0, -0.5, 0], "children": [1]},
            {"name": "box", "mesh": 1, "translation": [0.25, 0, 0], "scale": [1, 1.5, 1]},
            {"name": "camera", "camera": 0, "translation": [0, 1.5, 6],
             "rotation": [-0.0998, 0, 0, 0.995]},
            {"name": "lamp", "translation": [0, 3, 2],
             "extensions": {"KHR_lights_punctual": {"light": 0}}},
            {"name": "spot", "translation": [0, 4, 0], "rotation": [-0.7071068, 0, 0, 0.7071068],
             "extensions": {"KHR_lights_punctual": {"light": 1}}},
        ],
        "meshes": [
            {"name": "floor", "primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1,
                                                             "TEXCOORD_0": 2},
                                              "indices": 3, "material": 0}]},
            {"name": "cube", "primitives": [{"attributes": {"POSITION": 4}, "indices": 5,
                                             "material": 1}]},
        ],
        "materials": [
            {"name": "floor", "pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.8, 0.8, 1],
                                                       "metallicFactor": 0,
                                                       "roughnessFactor": 0.9}},
            {"name": "gold", "pbrMetallicRoughness": {"baseColorFactor": [1.0, 0.77, 0.34, 1],
                                                      "metallicFactor": 1,
                                                      "roughnessFactor": 0.4}},
        ],
        "cameras": [{"type": "perspective",
                     "perspective": {"yfov": 0.7, "aspectRatio": 1.5, "znear": 0.1}}],
        "extensions": {"KHR_lights_punctual": {"lights": [
            {"type": "point", "color": [1, 0.9, 0.8], "intensity": 20},
            {"type": "spot", "intensity": 30, "spot": {"innerConeAngle": 0.3,
                                                       "outerConeAngle": 0.5}},
        ]}},
        "animations": [{"name": "slide", "samplers": [{"input": 6, "output": 7,
                                                       "interpolation": "LINEAR"}],
                        "channels": [{"sampler": 0, "target": {"node": 1,
                                                               "path": "translation"}}]}],
        "accessors": accessors,
        "bufferViews": buffer_views,
    }
    return doc, blob


def write_gltf():
    doc, blob = gltf_scene()
    embedded = dict(doc)
    embedded["buffers"] = [{"byteLength": len(blob), "uri": "data:application/octet-stream;base64,"
                            + base64.b64encode(blob).decode()}]
    with open("scenes/hierarchy.gltf", "w") as f:
        json.dump(embedded, f, indent=1)
        f.write("\n")
    binary = dict(doc)
    binary["buffers"] = [{"byteLength": len(blob)}]
    js = json.dumps(binary).encode()
    js += b" " * (-len(js) % 4)
    total = 12 + 8 + len(js) + 8 + len(blob)
    with open("scenes/hierarchy.glb", "wb") as f:
        f.write(struct.pack("<4sII", b"glTF", 2, total))
        f.write(struct.pack("<I4s", len(js), b"JSON") + js)
        f.write(struct.pack("<I4s", len(blob), b"BIN\0") + blob)


def write_checker_png(path, n=8):
    """An n×n 8-bit RGB checkerboard of 2×2-pixel squares: orange and dark blue."""
    rows = b""
    for y in range(n):
        rows += b"\0" + b"".join(
            bytes((230, 120, 30)) if (x // 2 + y // 2) % 2 == 0 else bytes((20, 40, 90))
            for x in range(n))

    def chunk(kind, data):
        return (struct.pack(">I", len(data)) + kind + data
                + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF))

    os.makedirs(os.path.dirname(path), exist_ok=True)
    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n")
        f.write(chunk(b"IHDR", struct.pack(">IIBBBBB", n, n, 8, 2, 0, 0, 0)))
        f.write(chunk(b"IDAT", zlib.compress(rows)))
        f.write(chunk(b"IEND", b""))


if __name__ == "__main__":
    write_checker_png("scenes/textures/checker.png")
    write_ply("scenes/meshes/pyramid_le.ply", "binary_little_endian")
    write_ply("scenes/meshes/pyramid_be.ply", "binary_big_endian")
    write_ply("scenes/meshes/pyramid_ascii.ply", "ascii")
    write_gltf()
