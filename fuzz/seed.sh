#!/bin/sh
# Seeds the fuzzers' corpora from the sample scenes and writes their dictionaries (the XML
# tags and parameter names the Mitsuba loader looks for; the PLY header keywords).
# Run from fuzz/.
set -eu
mkdir -p corpus/mitsuba_xml corpus/ply
cp ../scenes/*.xml ../scenes/include/*.xml corpus/mitsuba_xml/
cp ../scenes/meshes/*.ply corpus/ply/
# In-memory scenes read no files, so also seed materials.xml without its include and file
# shapes: the fuzzer then starts from a scene that loads and reaches every BSDF.
python3 - <<'PY'
import re
s = open("../scenes/materials.xml").read()
s = re.sub(r'\s*<include [^>]*/>', '', s)
s = re.sub(r'\s*<shape type="(ply|obj)">.*?</shape>', '', s, flags=re.S)
open("corpus/mitsuba_xml/materials_inline.xml", "w").write(s)
PY
# And the structures a byte mutation rarely builds: parameters, references between plugins,
# nested textures and integrators.
cat > corpus/mitsuba_xml/refs.xml <<'XML'
<scene version="3.0.0">
<default name="r" value="0.5"/><default name="rr" value="$r, $r, $r"/>
<integrator type="aov" id="i"><integrator type="path"><integer name="max_depth" value="4"/></integrator></integrator>
<texture type="checkerboard" id="t"><rgb name="color0" value="$rr"/><float name="color1" value="0.1"/></texture>
<bsdf type="diffuse" id="d"><ref name="reflectance" id="t"/></bsdf>
<bsdf type="twosided" id="w"><ref id="d"/></bsdf>
<shape type="sphere" id="s"><ref id="w"/><emitter type="area"><spectrum name="radiance" value="400:1, 700:2"/></emitter></shape>
<shape type="cube"><bsdf type="principled"><ref name="base_color" id="t"/><float name="metallic" value="1"/></bsdf></shape>
</scene>
XML
{
    for t in scene default include ref bsdf texture sensor film sampler rfilter integrator \
        shape emitter transform lookat translate rotate scale matrix float integer boolean \
        string rgb spectrum point vector; do
        echo "\"<$t \""
    done
    for a in name= value= type= id= version= filename= x= y= z= angle= origin= target= up=; do
        echo "\"$a\""
    done
    grep -ohE '"[a-z_0-9]{2,24}"' ../crates/lumo-scene/src/load/mitsuba/*.rs | sort -u
} > mitsuba_xml.dict
for w in ply format ascii binary_little_endian binary_big_endian 1.0 comment obj_info element \
    vertex face property list char uchar short ushort int uint float double int8 uint8 int16 \
    uint16 int32 uint32 float32 float64 x y z nx ny nz u v s t red green blue \
    vertex_indices vertex_index end_header; do
    echo "\"$w\""
done > ply.dict

# Image readers, OBJ and glTF (issue 25): the sample files, the crafted hostile inputs of
# tests/data/bad, small reference images, and a tiny valid uncompressed EXR and PFM.
mkdir -p corpus/image_exr corpus/image_pfm corpus/image_png corpus/obj corpus/gltf
cp ../tests/data/bad/*.exr corpus/image_exr/
cp ../tests/data/bad/*.pfm corpus/image_pfm/
cp ../tests/data/bad/*.png ../tests/data/flip/blur_*.png ../scenes/textures/checker.png \
    corpus/image_png/
find ../tests/data/mitsuba/refs -name '*.exr' -size -10k -exec cp {} corpus/image_exr/ \;
cp ../scenes/meshes/*.obj corpus/obj/
# The gltf target reads its first byte as the choice of .gltf (even) or .glb (odd).
{ printf '\000'; cat ../scenes/hierarchy.gltf; } > corpus/gltf/hierarchy.gltf
{ printf '\001'; cat ../scenes/hierarchy.glb; } > corpus/gltf/hierarchy.glb
{ printf '\000'; cat ../tests/data/bad/zero_rotation.gltf; } > corpus/gltf/zero_rotation.gltf
python3 - <<'PY'
import struct
def attr(name, kind, value):
    return name.encode() + b"\0" + kind.encode() + b"\0" + struct.pack("<i", len(value)) + value
w, h = 2, 2
chlist = b"".join(c + b"\0" + struct.pack("<iB3xii", 2, 0, 1, 1) for c in (b"B", b"G", b"R")) + b"\0"
window = struct.pack("<iiii", 0, 0, w - 1, h - 1)
header = (attr("channels", "chlist", chlist) + attr("compression", "compression", b"\0")
          + attr("dataWindow", "box2i", window) + attr("displayWindow", "box2i", window)
          + attr("lineOrder", "lineOrder", b"\0")
          + attr("pixelAspectRatio", "float", struct.pack("<f", 1.0))
          + attr("screenWindowCenter", "v2f", struct.pack("<ff", 0, 0))
          + attr("screenWindowWidth", "float", struct.pack("<f", 1.0)) + b"\0")
start = 8 + len(header) + 8 * h
chunks, offsets = b"", []
for y in range(h):
    data = struct.pack("<6f", *[0.25 * (y + 1)] * 6)  # B, G, R rows of 2 floats each
    offsets.append(start + len(chunks))
    chunks += struct.pack("<ii", y, len(data)) + data
exr = b"\x76\x2f\x31\x01" + struct.pack("<i", 2) + header + b"".join(struct.pack("<Q", o) for o in offsets) + chunks
open("corpus/image_exr/tiny_rgb.exr", "wb").write(exr)
pfm = b"PF\n2 2\n-1.0\n" + struct.pack("<12f", *[0.5] * 12)
open("corpus/image_pfm/tiny.pfm", "wb").write(pfm)
open("corpus/image_pfm/tiny_grey_be.pfm", "wb").write(b"Pf\n3 1\n1.0\n" + struct.pack(">3f", 1, 2, 3))
PY
