#!/usr/bin/env bash
# Renders a fixed set of small images with `lumo render` into DIR, so that a restructuring can
# be checked bit for bit: run it before and after, then `tools/house/render_set.sh --compare A B`.
# Usage: tools/house/render_set.sh DIR [LUMO]   |   tools/house/render_set.sh --compare A B
set -euo pipefail
if [[ "${1:-}" == "--compare" ]]; then
    a=$2 b=$3 bad=0 n=0
    while IFS= read -r f; do
        n=$((n + 1))
        if ! cmp -s "$a/$f" "$b/$f"; then echo "DIFFERS: $f"; bad=1; fi
    done < <(cd "$a" && find . -type f ! -name '*.log' | sort)
    [[ $bad == 0 ]] && echo "all $n files identical"
    exit $bad
fi
out=${1:?usage: render_set.sh DIR [LUMO]}
lumo=${2:-target/release/lumo}
root=$(cd "$(dirname "$0")/../.." && pwd)
mkdir -p "$out"
r() { # name, then render arguments
    local name=$1
    shift
    "$lumo" render "$@" --threads 2 -o "$out/$name" >"$out/${name%.*}.log" 2>&1 \
        || { echo "failed: $name"; cat "$out/${name%.*}.log"; exit 1; }
}
cornell=cornell
gltf=$root/scenes/hierarchy.gltf
xml=$root/scenes/materials.xml
fog=$root/tests/data/mitsuba/scenes/media_fog_box.xml
r cornell_none.exr $cornell --size 48x40 --spp 4 --pipeline none
r cornell_default.exr $cornell --size 48x40 --spp 4
r gltf_none.exr "$gltf" --size 40x32 --spp 4 --pipeline none
r gltf_default.exr "$gltf" --size 40x32 --spp 4
r xml_none.exr "$xml" --size 40x32 --spp 4 --pipeline none
r xml_default.exr "$xml" --size 40x32 --spp 4
r fog_none.exr "$fog" --size 32x32 --spp 4 --pipeline none
r cornell_light.exr $cornell --size 48x40 --spp 2 --integrator light
r xml_light.exr "$xml" --size 40x32 --spp 2 --integrator light
r cornell_bdpt.exr $cornell --size 48x40 --spp 2 --integrator bdpt
r xml_bdpt.exr "$xml" --size 40x32 --spp 2 --integrator bdpt
r cornell_ppm.exr $cornell --size 48x40 --spp 2 --integrator ppm
r cornell_spectral.exr $cornell --size 48x40 --spp 2 --spectral --pipeline none
r xml_spectral_lt.exr "$xml" --size 40x32 --spp 2 --spectral --integrator light
r cornell_aovs.exr $cornell --size 48x40 --spp 4 --aovs "$out/cornell_aovs_planes"
r cornell_png.png $cornell --size 48x40 --spp 4 --seed 7 --pipeline none
"$lumo" render $cornell --size 48x40 --spp 2 --frames 0..2 --orbit 20 --temporal --threads 2 \
    -o "$out/seq.exr" >"$out/seq.log" 2>&1 || { echo "failed: seq"; cat "$out/seq.log"; exit 1; }
echo "rendered into $out"
