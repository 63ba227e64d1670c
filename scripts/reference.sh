#!/usr/bin/env bash
# One sample's reference comparison, in one command: imports and bakes the sample (direct
# light, --bounces 0, unless --bounces says otherwise), renders the bake three ways and
# compares them in linear light:
#
#   own.exr        abrad render (abrad's Gouraud rasterizer)
#   baked_pov.exr  POV-Ray rendering `abrad export --format pov` (the same bake, unlit)
#   reference.exr  POV-Ray rendering `abrad export --format pov-reference` (the model lit by
#                  POV-Ray's own point lights; direct light only unless --bounces)
#
# and writes own_vs_pov.png and baked_vs_reference.png (A | B | 4 x |A - B|, tone-mapped),
# the difference EXRs, own.png, baked_pov.png and summary.txt (PSNRs and times) into OUTDIR.
# POV-Ray writes the linear images as OpenEXR (+FE), e.g. for the `pov` export:
#   povray +Ibaked.pov +Obaked_pov.exr +FE +W320 +H240 -A -D
# and baked_pov.png from the tone-mapped variant (`abrad export --format pov --pov-tone-map`):
#   povray +Ibaked_png.pov +Obaked_pov.png +FN +W320 +H240 -A -D
# (a PNG of the linear `pov` export clips every value over 1).
# Exit status: 0 both comparisons within their thresholds, 1 a comparison failed or a step
# broke (the images stay in OUTDIR for a person to look at), 2 usage.
#
#   scripts/reference.sh [options] SAMPLE OUTDIR
#     SAMPLE: paper_simple | cornell_box | furnished_room | dxf_plan | fzk_haus
#     --abrad PATH              the abrad binary (default build/release/tools/abrad)
#     --width W --height H      image size (default 320 x 240)
#     --light-samples N         point lights sampling the emitters in the reference (default 256)
#     --min-psnr-own DB         own vs POV-Ray-baked threshold (default 55)
#     --min-psnr-reference DB   baked vs reference threshold (default: the sample's, below)
#     --bake-options "OPTS"     bake options after --bounces 0 (default: the sample's, a fine
#                               refinement so that Gouraud interpolation error stays small:
#                               --refine-tolerance 0.01 --refine-rounds 8 --refine-min-edge 0.01)
#     --bounces N               bake with --bounces N and let POV-Ray's radiosity do N bounces
#                               in the reference (default 0: direct light against direct light)
#     --quality Q               POV-Ray radiosity quality when N > 0: low, medium, high
#     --no-reference            skip the POV-Ray reference (FZK-Haus smoke test)
#   dxf_plan and fzk_haus read ../shared/data (or $ABRAD_SHARED_DATA).
set -euo pipefail

here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
abrad="$here/build/release/tools/abrad"
width=320
height=240
light_samples=256
min_psnr_own=55
min_psnr_reference=""
reference=1
bake_extra=""
bounces=0
quality=medium
bake_extra_given=0
usage() { sed -n '2,35p' "${BASH_SOURCE[0]}" | sed 's/^# \{0,1\}//' >&2; exit 2; }
args=()
while (($#)); do
    case "$1" in
        --abrad) abrad=$2; shift 2 ;;
        --width) width=$2; shift 2 ;;
        --height) height=$2; shift 2 ;;
        --light-samples) light_samples=$2; shift 2 ;;
        --min-psnr-own) min_psnr_own=$2; shift 2 ;;
        --min-psnr-reference) min_psnr_reference=$2; shift 2 ;;
        --bake-options) bake_extra=$2; bake_extra_given=1; shift 2 ;;
        --bounces) bounces=$2; shift 2 ;;
        --quality) quality=$2; shift 2 ;;
        --no-reference) reference=0; shift ;;
        -h|--help) usage ;;
        -*) echo "reference.sh: unknown option $1" >&2; usage ;;
        *) args+=("$1"); shift ;;
    esac
done
((${#args[@]} == 2)) || usage
sample=${args[0]}
out=${args[1]}
shared="${ABRAD_SHARED_DATA:-$here/../shared/data}"

# Each sample: its model, import options, bake options and the baked-vs-reference threshold
# (dB; see README "Reference comparisons" for what the remaining difference is).
bake_opts=(--bounces "$bounces")
fine=(--refine-tolerance 0.01 --refine-rounds 8 --refine-min-edge 0.01)
case "$sample" in
    paper_simple)   models=("$here/samples/paper_simple/paper_occluder.obj"); import_opts=(); psnr_ref=40
                    bake_opts+=("${fine[@]}") ;;
    cornell_box)    models=("$here/samples/cornell_box/CornellBox-Original.obj"); import_opts=(--up y); psnr_ref=34
                    bake_opts+=("${fine[@]}") ;;
    furnished_room) models=("$here/samples/furnished_room/furnished_room.obj"); import_opts=(); psnr_ref=40
                    bake_opts+=("${fine[@]}") ;;
    dxf_plan)       models=("$shared/dxf/3dface.dxf"); import_opts=(--scene "$here/samples/dxf_plan/scene.toml"); psnr_ref=30
                    bake_opts+=("${fine[@]}") ;;
    fzk_haus)       models=("$shared/ifc/AC14-FZK-Haus.ifc"); import_opts=(--scene "$here/samples/fzk_haus/scene.toml")
                    bake_opts+=(--dm off --shading patch); psnr_ref=20 ;;
    *) echo "reference.sh: unknown sample '$sample'" >&2; usage ;;
esac
[[ -n "$min_psnr_reference" ]] || min_psnr_reference=$psnr_ref
if ((bake_extra_given)); then
    read -r -a extra <<<"$bake_extra"
    bake_opts=(--bounces "$bounces" "${extra[@]}")
fi
command -v povray >/dev/null || { echo "reference.sh: povray is not installed (scripts/install-deps.sh)" >&2; exit 1; }
[[ -x "$abrad" ]] || { echo "reference.sh: $abrad: no abrad binary (--abrad PATH)" >&2; exit 2; }

mkdir -p "$out"
out=$(cd "$out" && pwd)
log="$out/log.txt"
: >"$log"
now() { date +%s.%N; }
elapsed() { awk -v a="$1" -v b="$(now)" 'BEGIN { printf "%.2f", b - a }'; }
step() {  # step NAME CMD...: runs CMD with its output in the log, stops on failure
    local name=$1; shift
    echo "== $name: $*" >>"$log"
    if ! "$@" >>"$log" 2>&1; then
        echo "reference.sh: $sample: $name failed; see $log" >&2
        tail -5 "$log" >&2
        exit 1
    fi
}
# POV-Ray in OUTDIR (a povray.ini elsewhere does not leak in), linear OpenEXR, no antialiasing
povray_render() {
    local format=+FE
    [[ $2 == *.png ]] && format=+FN
    (cd "$out" && povray "+I$1" "+O$2" "$format" "+W$width" "+H$height" -A -D -V +L/usr/share/povray-3.7/include)
}

db="$out/$sample.visdb"
rm -f "$db"
t=$(now); step import "$abrad" import "${models[@]}" --db "$db" "${import_opts[@]}"; t_import=$(elapsed "$t")
t=$(now); step bake "$abrad" bake --db "$db" --name direct "${bake_opts[@]}"; t_bake=$(elapsed "$t")
view=(--width "$width" --height "$height")
step export-pov "$abrad" export --db "$db" --format pov --output "$out/baked.pov" "${view[@]}"
t=$(now); step povray-baked povray_render baked.pov baked_pov.exr; t_pov=$(elapsed "$t")
step export-pov-png "$abrad" export --db "$db" --format pov --pov-tone-map --output "$out/baked_png.pov" "${view[@]}"
step povray-baked-png povray_render baked_png.pov baked_pov.png
t=$(now); step render "$abrad" render --db "$db" --output "$out/own.exr" "${view[@]}"; t_own=$(elapsed "$t")
step render-png "$abrad" render --db "$db" --output "$out/own.png" "${view[@]}"
step render-false-colour "$abrad" render --db "$db" --output "$out/irradiance.png" --false-colour "${view[@]}"

status=0
compare() {  # compare A B NAME MIN_PSNR
    local result
    if result=$("$abrad" compare "$out/$1" "$out/$2" --min-psnr "$4" --clip 4 --diff "$out/diff_$3.exr" \
                 --side-by-side "$out/$3.png" 2>>"$log"); then :; else
        local rc=$?
        ((rc == 1)) || { echo "$result" >>"$log"; echo "reference.sh: $sample: compare $3 broke (exit $rc); see $log" >&2; exit 1; }
        status=1
        echo "reference.sh: $sample: $3: PSNR below $4 dB; look at $out/$3.png" >&2
    fi
    echo "$result" >>"$log"
    echo "$3: $(echo "$result" | awk -F': ' '/^psnr_db/ {p=$2} /^rmse/ {r=$2} /^max_error:/ {m=$2} END {printf "psnr %s dB, rmse %s, max error %s", p, r, m}') (threshold $4 dB)"
}
{
    echo "sample: $sample (${width}x${height}, bake: ${bake_opts[*]})"
    echo "times: import ${t_import} s, bake ${t_bake} s, povray baked ${t_pov} s, abrad render ${t_own} s"
    compare own.exr baked_pov.exr own_vs_pov "$min_psnr_own"
} >"$out/summary.txt"
if ((reference)); then
    step export-reference "$abrad" export --db "$db" --format pov-reference --output "$out/reference.pov" \
        --light-samples "$light_samples" --reference-bounces "$bounces" --quality "$quality" "${view[@]}"
    t=$(now); step povray-reference povray_render reference.pov reference.exr; t_ref=$(elapsed "$t")
    {
        echo "times: povray reference ${t_ref} s (${light_samples} light samples, ${bounces} POV-Ray radiosity bounces)"
        compare baked_pov.exr reference.exr baked_vs_reference "$min_psnr_reference"
    } >>"$out/summary.txt"
fi
cat "$out/summary.txt"
exit $status
