#!/usr/bin/env bash
# One sample's exports checked by independent readers: imports the sample, bakes it with the
# smallest bake that exercises the writers (direct light only, no discontinuity meshing, patch
# shading, a coarse hemicube), exports glTF and GLB and validates both with the Khronos glTF
# validator (zero errors and zero warnings), then exports PLY (float positions, Y up) and OBJ
# and reads them with three.js's loaders (tests/export/read_exports.mjs).
# Exit status: 0 every check passed, 1 a check or a step failed (the files stay in OUTDIR),
# 2 usage, 77 the sample's model is not here (dxf_plan and fzk_haus read the shared data
# folder, $ABRAD_SHARED_DATA).
#
#   tests/export/sample_exports.sh ABRAD NODE_DIR SAMPLE OUTDIR
set -euo pipefail
(($# == 4)) || { sed -n '2,11p' "${BASH_SOURCE[0]}" | sed 's/^# \{0,1\}//' >&2; exit 2; }
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
run "$abrad" export --db "$db" --output "$out/$sample.obj"
run node "$tests/read_exports.mjs" "$node_dir/node_modules" "${BASH_REMATCH[1]}" \
    "${BASH_REMATCH[2]}" "$out/$sample.ply" "$out/$sample.obj" "$out/$sample.gltf"
