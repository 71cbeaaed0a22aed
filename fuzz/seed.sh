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
