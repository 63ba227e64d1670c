#!/usr/bin/env bash
# Fails when a C++ file is not formatted as the root .clang-format says (CTest: style.format).
# Checks every tracked *.cpp/*.h in a git checkout (git ls-files), else every *.cpp/*.h under
# the source tree outside build/ and hidden folders. Fix with: clang-format -i FILE...
#   scripts/check-format.sh [SOURCE_DIR]   (default: the folder above this script)
set -euo pipefail
src=${1:-$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)}
cd "$src"
clang_format=$(command -v clang-format-14 || command -v clang-format || true)
if [[ -z $clang_format ]]; then
    echo "check-format: clang-format not found (bash scripts/install-deps.sh installs it)" >&2
    exit 1
fi
files=()
if git rev-parse --is-inside-work-tree >/dev/null 2>&1; then
    mapfile -t files < <(git ls-files -- '*.cpp' '*.h')
else
    mapfile -t files < <(find . \( -path ./build -o -name '.*' -not -name . \) -prune -o \
                              -type f \( -name '*.cpp' -o -name '*.h' \) -print | sort)
fi
existing=()
for f in "${files[@]}"; do [[ -f $f ]] && existing+=("$f"); done  # deleted but not staged
if ((${#existing[@]} == 0)); then
    echo "check-format: no C++ files found under $src" >&2
    exit 1
fi
if ! "$clang_format" --dry-run --Werror --style=file "${existing[@]}"; then
    echo "check-format: the files above are not formatted; run clang-format -i on them" >&2
    exit 1
fi
echo "check-format: ${#existing[@]} files formatted ($("$clang_format" --version))"
