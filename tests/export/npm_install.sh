#!/usr/bin/env bash
# Installs the npm packages of tests/export/package.json (exact versions from its
# package-lock.json) into DIR/node_modules with `npm ci`, once: a later run with the same lock
# file does nothing, so the tests work offline after the first install. A failed install fails
# (the readers' tests must not pass without their readers).
#
#   tests/export/npm_install.sh SOURCE_DIR DIR
set -euo pipefail
(($# == 2)) || { echo "usage: npm_install.sh SOURCE_DIR DIR" >&2; exit 2; }
src=$1
dir=$2
for tool in node npm; do
    command -v "$tool" >/dev/null ||
        { echo "npm_install: $tool not found (scripts/install-deps.sh installs Node.js)" >&2; exit 1; }
done
mkdir -p "$dir"
stamp="$dir/node_modules/.abrad-package-lock.json"
if [[ -f "$stamp" ]] && cmp -s "$stamp" "$src/package-lock.json"; then
    echo "npm_install: $dir/node_modules is up to date"
    exit 0
fi
cp "$src/package.json" "$src/package-lock.json" "$dir/"
(cd "$dir" && npm ci --no-audit --no-fund --loglevel=error)
cp "$src/package-lock.json" "$stamp"
echo "npm_install: installed $(cd "$dir" && node -e 'const l=require("./package-lock.json");console.log(Object.keys(l.packages).filter(Boolean).map(p=>p.slice(13)+"@"+l.packages[p].version).join(", "))') into $dir"
