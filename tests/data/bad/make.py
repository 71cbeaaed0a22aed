#!/usr/bin/env python3
"""Writes the crafted hostile inputs in this folder (issue 25): tiny files whose headers lie
about their size, empty and NaN images, negative colours, an include fan-out bomb, a glTF node
with a zero rotation. Each one is used by a regression test in crates/lumo-image/tests or
crates/lumo-scene/tests (hostile_input.rs). Run from anywhere; the files are committed."""
import base64
import json
import os
import struct
import zlib

HERE = os.path.dirname(os.path.abspath(__file__))


def put(name, data):
    if isinstance(data, str):
        data = data.encode()
    path = os.path.join(HERE, name)
    os.makedirs(os.path.dirname(path), exist_ok=True)
    with open(path, "wb") as f:
        f.write(data)


def pfm(w, h, values, magic="PF"):
    return f"{magic}\n{w} {h}\n-1.0\n".encode() + b"".join(struct.pack("<f", v) for v in values)


def png_chunk(kind, body):
    return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body))


def png(w, h, idat):
    ihdr = struct.pack(">IIBBBBB", w, h, 8, 0, 0, 0, 0)  # 8-bit grey
    return (b"\x89PNG\r\n\x1a\n" + png_chunk(b"IHDR", ihdr) + png_chunk(b"IDAT", idat)
            + png_chunk(b"IEND", b""))


def exr(w, h, table_entries):
    """A scan-line OpenEXR header (one float channel Y, no compression) for a w×h data
    window, followed by only `table_entries` entries of its block offset table."""
    def attr(name, kind, value):
        return name.encode() + b"\0" + kind.encode() + b"\0" + struct.pack("<i", len(value)) + value
    chlist = b"Y\0" + struct.pack("<iB3xii", 2, 0, 1, 1) + b"\0"
    window = struct.pack("<iiii", 0, 0, w - 1, h - 1)
    header = (attr("channels", "chlist", chlist)
              + attr("compression", "compression", b"\0")
              + attr("dataWindow", "box2i", window)
              + attr("displayWindow", "box2i", window)
              + attr("lineOrder", "lineOrder", b"\0")
              + attr("pixelAspectRatio", "float", struct.pack("<f", 1.0))
              + attr("screenWindowCenter", "v2f", struct.pack("<ff", 0, 0))
              + attr("screenWindowWidth", "float", struct.pack("<f", 1.0))
              + b"\0")
    return b"\x76\x2f\x31\x01" + struct.pack("<i", 2) + header + b"\0" * (8 * table_entries)


def jpeg(w, h):
    """Baseline JPEG markers up to the scan, for a w×h grey image; no scan data."""
    dqt = b"\xff\xdb" + struct.pack(">H", 67) + b"\0" + b"\x01" * 64
    sof = b"\xff\xc0" + struct.pack(">HBHHB", 11, 8, h, w, 1) + b"\x01\x11\x00"
    # One DC and one AC table, each with a single 1-bit code.
    dht = b"\xff\xc4" + struct.pack(">H", 2 + 2 * 18) + b"\x00" + b"\x01" + b"\0" * 15 + b"\x00" \
        + b"\x10" + b"\x01" + b"\0" * 15 + b"\x00"
    sos = b"\xff\xda" + struct.pack(">HB", 8, 1) + b"\x01\x00" + b"\x00\x3f\x00"
    return b"\xff\xd8" + dqt + sof + dht + sos + b"\0" * 16 + b"\xff\xd9"


# Item 7: an image without pixels, used as an envmap and as a texture.
put("empty.pfm", "PF\n0 4\n-1.0\n")
# Item 8: headers claiming far more pixels than the file holds.
put("huge_window.exr", exr(100000, 100000, 1))
put("many_blocks.exr", exr(1, 1 << 20, 1))
put("huge_ihdr.png", png(100000, 100000, zlib.compress(b"\0" * 16)))
put("short_8k.png", png(8192, 8192, zlib.compress(b"\0" * 16)))
put("huge.hdr", b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 16384 +X 16384\n"
    + b"\x02\x02\x40\x00" + b"\x80\x01" * 8)
put("huge.jpg", jpeg(60000, 60000))
# Item 12: envmaps that are all NaN, or partly negative and NaN.
nan = float("nan")
put("nan_envmap.pfm", pfm(2, 1, [nan] * 6))
put("negative_envmap.pfm", pfm(2, 1, [-1.0, 0.5, 0.5, nan, 0.25, 0.25]))

scene = """<scene version="3.0.0">
<sensor type="perspective"><float name="fov" value="45"/></sensor>
{}
</scene>
"""
sphere = '<shape type="sphere"><bsdf type="diffuse"/></shape>'
for name, image in [("empty", "empty.pfm"), ("nan", "nan_envmap.pfm"),
                    ("negative", "negative_envmap.pfm"), ("huge_exr", "huge_window.exr")]:
    put(f"envmap_{name}.xml", scene.format(
        f'{sphere}\n<emitter type="envmap"><string name="filename" value="{image}"/></emitter>'))
for name, image in [("empty", "empty.pfm"), ("huge_png", "huge_ihdr.png"),
                    ("short_png", "short_8k.png"), ("huge_hdr", "huge.hdr"),
                    ("huge_jpg", "huge.jpg"), ("missing", "no_such_texture.png")]:
    put(f"texture_{name}.xml", scene.format(
        '<shape type="sphere"><bsdf type="diffuse"><texture type="bitmap" name="reflectance">'
        f'<string name="filename" value="{image}"/></texture></bsdf></shape>\n'
        '<emitter type="constant"/>'))
put("negative_values.xml", scene.format(
    '<shape type="sphere">\n'
    '<bsdf type="diffuse"><rgb name="reflectance" value="0.5, -0.2, 0.5"/></bsdf>\n'
    '<emitter type="area"><rgb name="radiance" value="-1, 2, 3"/></emitter>\n'
    '</shape>\n'
    '<emitter type="point"><spectrum name="intensity" value="400:1, 500:-2, 600:1"/></emitter>'))
put("missing_include.xml", scene.format('<include filename="no_such_file.xml"/>'))
put("missing_mesh.xml", scene.format(
    '<shape type="ply"><string name="filename" value="no_such_mesh.ply"/></shape>'))

# Item 10: 13 files, each including the next four times (4^12 includes, 3.4 GB of XML).
for i in range(13):
    body = "".join(f'<include filename="b{i + 1:02}.xml"/>' for _ in range(4)) if i < 12 else \
        '<shape type="sphere"/>'
    put(f"include_bomb/b{i:02}.xml", f'<scene version="3.0.0">{body}</scene>\n')

# Item 12: a camera node whose rotation is the zero quaternion.
put("zero_rotation.gltf", """{
  "asset": {"version": "2.0"},
  "scene": 0,
  "scenes": [{"nodes": [0]}],
  "nodes": [{"camera": 0, "rotation": [0, 0, 0, 0], "translation": [0, 0, 5]}],
  "cameras": [{"type": "perspective", "perspective": {"yfov": 0.8, "znear": 0.1}}]
}
""")

# Item 12: a material with a negative base colour and emission (glTF allows [0, 1]).
triangle = struct.pack("<9f", 0, 0, 0, 1, 0, 0, 0, 1, 0)
put("negative_color.gltf", json.dumps({
    "asset": {"version": "2.0"},
    "scene": 0,
    "scenes": [{"nodes": [0]}],
    "nodes": [{"mesh": 0}],
    "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "material": 0}]}],
    "materials": [{"pbrMetallicRoughness": {"baseColorFactor": [0.5, -0.5, 0.5, 1],
                                            "metallicFactor": 0},
                   "emissiveFactor": [-1, 0, 0]}],
    "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                   "min": [0, 0, 0], "max": [1, 1, 0]}],
    "bufferViews": [{"buffer": 0, "byteLength": 36}],
    "buffers": [{"byteLength": 36, "uri": "data:application/octet-stream;base64,"
                 + base64.b64encode(triangle).decode()}],
}, indent=1) + "\n")
