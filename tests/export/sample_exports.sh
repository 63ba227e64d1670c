#!/usr/bin/env bash
# One sample's exports checked by independent readers: imports the sample, bakes it with the
# smallest bake that exercises the writers (direct light only, no discontinuity meshing, patch
# shading, a coarse hemicube), exports glTF and GLB and validates both with the Khronos glTF
# validator (zero errors and zero warnings), then exports PLY (float positions, Y up) and OBJ
# and reads them with three.js's loaders (tests/export/read_exports.mjs), and a binary PLY
# (surface ids on the vertices) and an ASCII one with meshio (read_ply_meshio.py, Debian's
# /usr/bin/python3 or $ABRAD_DEBIAN_PYTHON). Last, the first look (abrad render's PNG,
# automatic exposure): at most 2 % of the receivers' pixels clipped, and the PNG's own pixels
# at code 255 (counted by oiiotool) are those plus at most the emitters'.
# Exit status: 0 every check passed, 1 a check or a step failed (the files stay in OUTDIR),
# 2 usage, 77 the sample's model is not here (dxf_plan and fzk_haus read the shared data
# folder, $ABRAD_SHARED_DATA).
#
#   tests/export/sample_exports.sh ABRAD NODE_DIR SAMPLE OUTDIR
set -euo pipefail
(($# == 4)) || { sed -n '2,15p' "${BASH_SOURCE[0]}" | sed 's/^# \{0,1\}//' >&2; exit 2; }
abrad=$1
node_dir=$2
sample=$3
out=$4
here=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
tests=$here/tests/export
shared="${ABRAD_SHARED_DATA:-$here/../shared/data}"

import_opts=()
case "$sample" in
    paper_simple)   models=("$here/samples/paper_simple/paper_occluder.obj") ;;
    cornell_box)    models=("$here/samples/cornell_box/CornellBox-Original.obj"); import_opts=(--up y) ;;
    furnished_room) models=("$here/samples/furnished_room/furnished_room.obj") ;;
    dxf_plan)       models=("$shared/dxf/3dface.dxf"); import_opts=(--scene "$here/samples/dxf_plan/scene.toml") ;;
    fzk_haus)       models=("$shared/ifc/AC14-FZK-Haus.ifc"); import_opts=(--scene "$here/samples/fzk_haus/scene.toml") ;;
    *) echo "sample_exports: unknown sample '$sample'" >&2; exit 2 ;;
esac
for m in "${models[@]}"; do
    [[ -f "$m" ]] || { echo "sample_exports: $sample: $m is not here (shared data); skipped"; exit 77; }
done

rm -rf "$out"
mkdir -p "$out"
db="$out/$sample.visdb"
run() {  # run CMD...: shows the command and stops on failure
    echo "== $*"
    "$@" || { echo "sample_exports: $sample: failed: $*" >&2; exit 1; }
}
run "$abrad" import "${models[@]}" --db "$db" "${import_opts[@]}"
run "$abrad" bake --db "$db" --bounces 0 --dm off --shading patch --resolution 16
run "$abrad" export --db "$db" --output "$out/$sample.gltf"
run "$abrad" export --db "$db" --output "$out/$sample.glb"
run node "$tests/validate_gltf.cjs" "$node_dir/node_modules" "$out/$sample.gltf" "$out/$sample.glb"

# The PLY as web loaders want it (float positions, Y up) and the OBJ (Y up by default), read by
# three.js against abrad's counts and the glTF's box
echo "== $abrad export --db $db --output $out/$sample.ply --positions float --up y"
report=$("$abrad" export --db "$db" --output "$out/$sample.ply" --positions float --up y) ||
    { echo "sample_exports: $sample: PLY export failed" >&2; exit 1; }
echo "$report"
[[ $report =~ ([0-9]+)\ vertices,\ ([0-9]+)\ triangles ]] ||
    { echo "sample_exports: $sample: no counts in the export report" >&2; exit 1; }
vertices=${BASH_REMATCH[1]} triangles=${BASH_REMATCH[2]}
run "$abrad" export --db "$db" --output "$out/$sample.obj"
run node "$tests/read_exports.mjs" "$node_dir/node_modules" "$vertices" "$triangles" \
    "$out/$sample.ply" "$out/$sample.obj" "$out/$sample.gltf"

# meshio (Debian's python3-meshio, for Debian's own Python): the binary PLY with the surface
# ids on the vertices and the ASCII contract
run "$abrad" export --db "$db" --output "$out/$sample.meshio.ply" --surface-ids vertex
run "$abrad" export --db "$db" --output "$out/$sample.ascii.ply" --ascii
run "${ABRAD_DEBIAN_PYTHON:-/usr/bin/python3}" "$tests/read_ply_meshio.py" "$vertices" "$triangles" \
    "$out/$sample.meshio.ply" "$out/$sample.ascii.ply"

# The first look: automatic exposure clips at most 2 % of the receivers' pixels
echo "== $abrad render --db $db --output $out/$sample.png"
report=$("$abrad" render --db "$db" --output "$out/$sample.png") ||
    { echo "sample_exports: $sample: render failed" >&2; exit 1; }
echo "$report"
[[ $report =~ clipped:\ ([0-9]+)\ of\ ([0-9]+)\ receiver\ pixels.*emitters\ ([0-9]+)\ pixels ]] ||
    { echo "sample_exports: $sample: no clipped-pixel count in the render report" >&2; exit 1; }
clipped=${BASH_REMATCH[1]} receivers=${BASH_REMATCH[2]} emitters=${BASH_REMATCH[3]}
((receivers > 0 && 50 * clipped <= receivers)) ||
    { echo "sample_exports: $sample: $clipped of $receivers receiver pixels clipped (over 2 %)" >&2; exit 1; }
# The PNG itself: its pixels with a channel at 255 (OpenImageIO reads 255 as 1.0)
in_png=$(oiiotool "$out/$sample.png" --rangecheck 0,0,0 0.999,0.999,0.999 | awk '/>/ { print $1 }')
[[ $in_png =~ ^[0-9]+$ ]] || { echo "sample_exports: $sample: oiiotool did not count" >&2; exit 1; }
echo "PNG: $in_png pixels at code 255; abrad: $clipped receivers, $emitters emitter pixels"
((in_png >= clipped && in_png <= clipped + emitters)) ||
    { echo "sample_exports: $sample: the PNG has $in_png pixels at 255, abrad counted $clipped (+ $emitters emitters)" >&2; exit 1; }
