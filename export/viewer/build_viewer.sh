#!/usr/bin/env bash
# Builds the 3D viewer of `abrad report`: installs the npm packages of export/viewer/package.json
# (exact versions from its package-lock.json: three.js and esbuild) into DIR/node_modules with
# `npm ci`, and bundles main.js with three.js into DIR/abrad-viewer.js, one minified classic
# script (an IIFE: a page opened from file:// cannot load ES modules), with three.js's licence
# beside it. Once per lock file and main.js: a later run with the same ones does nothing, so it
# works offline after the first run.
#
#   export/viewer/build_viewer.sh [--optional] SOURCE_DIR DIR
#
# --optional (the build's step): a failure (no Node.js, no registry) is a notice and exit 0,
# so the build goes on and `abrad report` says how to get the 3D view; without it a failure
# fails (the test set-up: the report's tests must not pass without their viewer).
set -euo pipefail
optional=false
if [[ ${1:-} == --optional ]]; then optional=true; shift; fi
(($# == 2)) || { echo "usage: build_viewer.sh [--optional] SOURCE_DIR DIR" >&2; exit 2; }
src=$1
dir=$2
give_up() {
    echo "build_viewer: $1; abrad report will write its pages without the 3D view" >&2
    if $optional; then exit 0; fi
    exit 1
}
for tool in node npm; do
    command -v "$tool" >/dev/null || give_up "$tool not found (scripts/install-deps.sh installs Node.js)"
done
mkdir -p "$dir"
stamp="$dir/.abrad-viewer-stamp"
want=$(cat "$src/package-lock.json" "$src/main.js" | cksum)
if [[ -f "$stamp" && -f "$dir/abrad-viewer.js" && $(cat "$stamp") == "$want" ]]; then
    echo "build_viewer: $dir/abrad-viewer.js is up to date"
    exit 0
fi
cp "$src/package.json" "$src/package-lock.json" "$dir/"
(cd "$dir" && npm ci --no-audit --no-fund --loglevel=error) || give_up "npm ci failed"
tmp="$dir/abrad-viewer.js.tmp-$$"
cp "$src/main.js" "$dir/main.js"  # beside node_modules, where esbuild resolves 'three'
"$dir/node_modules/.bin/esbuild" "$dir/main.js" --bundle --format=iife --minify \
    --target=es2020 --legal-comments=eof --log-level=warning --outfile="$tmp" ||
    { rm -f "$tmp"; give_up "esbuild failed"; }
cp "$dir/node_modules/three/LICENSE" "$dir/LICENSE-three.txt"
mv "$tmp" "$dir/abrad-viewer.js"
echo "$want" >"$stamp"
echo "build_viewer: wrote $dir/abrad-viewer.js (three $(node -p "require('$dir/node_modules/three/package.json').version"))"
