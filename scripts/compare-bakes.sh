#!/usr/bin/env bash
# Bakes the samples with two abrad binaries and compares the results: the check that a
# refactoring changed no bake. Each case imports a sample, bakes it with one set of options,
# exports an ASCII PLY and compares it. A case passes when the meshes are the same (as sets of
# faces: vertex numbering may differ) and every position, normal, irradiance and radiosity
# agrees within a relative 1e-12 of the largest value of its column (per-light sums are added
# in thread order, so two runs of one binary may differ in the last bits), and the bakes
# record the same statistics.
#
# Known: the discontinuity mesh of some scenes is not reproducible from run to run (a few
# sliver faces along shadow edges whose corners differ by one ulp). When the meshes differ,
# the old binary bakes the case up to five times more: the case passes when the new mesh is
# one of the old binary's (and its values agree as above); when none of the old runs matches
# but they differ among themselves, each surface's integrated irradiance must agree (relative
# 1e-4). The output says which.
#
#   scripts/compare-bakes.sh OLD_ABRAD NEW_ABRAD [WORKDIR]
#   ONLY=furnished scripts/compare-bakes.sh ...     # the cases whose name matches a regex
#
# Exit status: 0 all cases agree, 1 some case differs, 2 usage.
set -euo pipefail
if (($# < 2)); then
    echo "usage: $0 OLD_ABRAD NEW_ABRAD [WORKDIR]" >&2
    exit 2
fi
old=$(realpath "$1")
new=$(realpath "$2")
root=$(cd "$(dirname "$0")/.." && pwd)
work=${3:-$(mktemp -d)}
mkdir -p "$work"
shared=${ABRAD_SHARED_DATA:-$root/../shared/data}

# name | import arguments | bake options
cases=(
    "paper_dm|$root/samples/paper_simple/paper_occluder.obj|"
    "paper_nodm|$root/samples/paper_simple/paper_occluder.obj|--dm off"
    "paper_patch|$root/samples/paper_simple/paper_occluder.obj|--shading patch"
    "paper_nodm_patch|$root/samples/paper_simple/paper_occluder.obj|--dm off --shading patch"
    "paper_zbuffer|$root/samples/paper_simple/paper_occluder.obj|--method zbuffer --dm off"
    "paper_lights_vertices|$root/samples/paper_simple/paper_occluder.obj|--lights vertices --refine-rounds 2"
    "paper_converge|$root/samples/paper_simple/paper_occluder.obj|--bounces converge --dm off"
    "paper_converge_dm|$root/samples/paper_simple/paper_occluder.obj|--bounces converge"
    "paper_bounces2|$root/samples/paper_simple/paper_simple.obj|--bounces 2 --dm off"
    "cornell_dm|$root/samples/cornell_box/CornellBox-Original.obj --up y|"
    "cornell_converge|$root/samples/cornell_box/CornellBox-Original.obj --up y|--bounces converge --overrelax 1.5 --dm off"
    "furnished_dm|$root/samples/furnished_room/furnished_room.obj|--reach 6"
    "furnished_nodm|$root/samples/furnished_room/furnished_room.obj|--dm off --threads 1"
)
if [[ -f $shared/dxf/3dface.dxf ]]; then
    cases+=("dxf_dm|$shared/dxf/3dface.dxf --scene $root/samples/dxf_plan/scene.toml|")
else
    echo "compare-bakes: $shared/dxf/3dface.dxf absent, dxf case skipped" >&2
fi

compare_ply() {
    python3 - "$@" <<'PY'
# Order-independent: the discontinuity mesher may number a region's vertices in a different
# order from run to run. Faces are compared as sets of (surface, corner positions), vertex
# values by (surface, position, normal).
import sys
def read(path):
    with open(path) as f:
        props, n_v, n_f, cur = [], 0, 0, None
        for line in f:
            w = line.split()
            if w[:2] == ["element", "vertex"]: n_v, cur = int(w[2]), "v"
            elif w[:2] == ["element", "face"]: n_f, cur = int(w[2]), "f"
            elif w and w[0] == "property" and cur == "v": props.append(w[-1])
            elif w == ["end_header"]: break
        verts = [next(f).split() for _ in range(n_v)]
        faces = [next(f).split() for _ in range(n_f)]
    faces_set, values = set(), {}
    for fc in faces:
        idx, surface = [int(x) for x in fc[1:4]], fc[4]
        corners = [tuple(verts[i][:3]) for i in idx]
        k = corners.index(min(corners))
        faces_set.add((surface, tuple(corners[k:] + corners[:k])))
        for i in idx:
            values[(surface, tuple(verts[i][:6]))] = [float(x) for x in verts[i][6:]]
    return props, faces_set, values
pa, fa, va = read(sys.argv[1])
pb, fb, vb = read(sys.argv[2])
if pa != pb or fa != fb or va.keys() != vb.keys():
    # Different meshes: compare each surface's area and integrated irradiance instead
    def integrals(faces, values):
        out = {}
        for surface, corners in faces:
            import math
            a, b, c = [tuple(map(float, p)) for p in corners]
            u = [b[i] - a[i] for i in range(3)]; w = [c[i] - a[i] for i in range(3)]
            cr = [u[1]*w[2]-u[2]*w[1], u[2]*w[0]-u[0]*w[2], u[0]*w[1]-u[1]*w[0]]
            area = 0.5 * math.sqrt(sum(x * x for x in cr))
            h = [values[k][3:6] for k in values if k[0] == surface and k[1][:3] in corners][:3]
            mean = sum(sum(x) for x in h) / max(1, 3 * len(h))
            acc = out.setdefault(surface, [0.0, 0.0])
            acc[0] += area; acc[1] += area * mean
        return out
    print(f"  mesh differs: {len(fa - fb)} of {len(fa)} faces only in the first, "
          f"{len(fb - fa)} of {len(fb)} only in the second")
    if len(sys.argv) > 3:
        ia, ib = integrals(fa, va), integrals(fb, vb)
        worst = max(abs(ia[s][1] - ib.get(s, [0, 0])[1]) / max(1e-300, abs(ia[s][1])) for s in ia)
        print(f"  per-surface integrated irradiance: worst relative difference {worst:.3g}")
        sys.exit(0 if worst <= 1e-4 and ia.keys() == ib.keys() else 1)
    sys.exit(3)
worst = 0.0
for c in range(len(next(iter(va.values())))):
    scale = max(1e-300, max(abs(v[c]) for v in va.values()))
    worst = max(worst, max(abs(va[k][c] - vb[k][c]) for k in va) / scale)
print(f"  {len(va)} vertices, {len(fa)} faces, worst relative difference {worst:.3g}")
sys.exit(0 if worst <= 1e-12 else 1)
PY
}

bake_case() {  # exe dir model options name
    local exe=$1 dir=$2 model=$3 options=$4
    rm -rf "$dir" && mkdir -p "$dir"
    # shellcheck disable=SC2086
    "$exe" import $model --db "$dir/s.visdb" >"$dir/import.log" 2>&1
    # shellcheck disable=SC2086
    "$exe" bake --db "$dir/s.visdb" --name b $options >"$dir/bake.log" 2>&1
    "$exe" export --db "$dir/s.visdb" --format ply --ascii --output "$dir/b.ply" >/dev/null
    "$exe" info --db "$dir/s.visdb" | tr ' ' '\n' | sed -n 's/^\([a-z0-9_]*\)=.*/\1/p' \
        | grep -v '^seconds' >"$dir/stat-names.txt"
}

status=0
for c in "${cases[@]}"; do
    IFS='|' read -r name model options <<<"$c"
    [[ $name =~ ${ONLY:-.} ]] || continue
    bake_case "$old" "$work/$name/old" "$model" "$options"
    bake_case "$new" "$work/$name/new" "$model" "$options"
    echo "$name ($options)"
    rc=0
    compare_ply "$work/$name/old/b.ply" "$work/$name/new/b.ply" || rc=$?
    if ((rc == 3)); then
        # The mesh differs. The discontinuity mesh of some scenes is not reproducible from run
        # to run (see above): bake with the old binary twice more. The case passes when the new
        # mesh is one of the old binary's; else, when the old runs disagree among themselves,
        # each surface's integrated irradiance must agree (relative 1e-4)
        same=0 old_varies=0
        for k in 2 3 4 5 6; do
            bake_case "$old" "$work/$name/old$k" "$model" "$options"
            compare_ply "$work/$name/old/b.ply" "$work/$name/old$k/b.ply" >/dev/null || old_varies=1
            if compare_ply "$work/$name/old$k/b.ply" "$work/$name/new/b.ply" >/dev/null; then
                same=$k
                break
            fi
        done
        if ((same)); then
            echo "  the new mesh is the old binary's of its run $same (its mesh varies from run to run):"
            compare_ply "$work/$name/old$same/b.ply" "$work/$name/new/b.ply" || status=1
        elif ((old_varies)); then
            echo "  the old binary's own meshes differ from run to run; old vs old:"
            compare_ply "$work/$name/old/b.ply" "$work/$name/old2/b.ply" integrals || true
            echo "  new vs old:"
            compare_ply "$work/$name/old/b.ply" "$work/$name/new/b.ply" integrals || status=1
        else
            echo "  the old binary reproduces its own mesh six times: a real difference"
            status=1
        fi
    elif ((rc != 0)); then
        status=1
    fi
    if ! diff -q "$work/$name/old/stat-names.txt" "$work/$name/new/stat-names.txt" >/dev/null; then
        echo "  statistics differ:"
        diff "$work/$name/old/stat-names.txt" "$work/$name/new/stat-names.txt" || true
        status=1
    fi
done
exit $status
