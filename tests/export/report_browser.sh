#!/usr/bin/env bash
# The report in a real browser: the furnished room lit by three downlights from an IES file, a
# work-plane grid, a quick bake, `abrad report`, then report_browser.mjs opens the page in
# Debian's chromium (puppeteer-core from NPM_DIR) and checks it. Exit 77 (skipped) without
# chromium.
#
#   tests/export/report_browser.sh ABRAD NPM_DIR VIEWER_DIR SAMPLES_DIR OUT_DIR
set -euo pipefail
(($# == 5)) || { echo "usage: report_browser.sh ABRAD NPM_DIR VIEWER_DIR SAMPLES_DIR OUT_DIR" >&2; exit 2; }
abrad=$1
npm_dir=$2
viewer_dir=$3
samples=$4
out=$5
chromium=$(command -v chromium || command -v chromium-browser || true)
if [[ -z $chromium ]]; then
    echo "report_browser: chromium not found (scripts/install-deps.sh installs Debian's): skipped"
    exit 77
fi
here=$(cd "$(dirname "$0")" && pwd)
rm -rf "$out"
mkdir -p "$out"
cp "$samples/furnished_room/downlight.ies" "$out/"
cat >"$out/scene.toml" <<'TOML'
[[exclude]]
object = "light_*"
[[luminaire]]
file = "downlight.ies"
name = "downlight"
position = [1.5, 2.5, 2.99]
count = 3
step = [1.5, 0.0, 0.0]
maintenance_factor = 0.8
[[grid]]
name = "work plane"
min = [0.0, 0.0]
max = [6.0, 5.0]
height = 0.75
spacing = 0.5
margin = 0.5
TOML
"$abrad" import "$samples/furnished_room/furnished_room.obj" --scene "$out/scene.toml" \
    --db "$out/room.visdb" >"$out/log.txt"
"$abrad" bake --db "$out/room.visdb" --name b --dm off --shading patch --resolution 16 \
    --bounces 2 --element-size 1 >>"$out/log.txt"
ABRAD_VIEWER=$viewer_dir "$abrad" report --db "$out/room.visdb" --out "$out/report" >>"$out/log.txt"
node "$here/report_browser.mjs" --modules "$npm_dir/node_modules" --chromium "$chromium" \
    --page "$out/report/index.html" --shot "$out/view3d.png" --luminaires 3 \
    --grid "work plane=$out/room.b.grid-work_plane.csv"
