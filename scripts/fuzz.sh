#!/usr/bin/env bash
# Fuzzes one reader: scripts/fuzz.sh TARGET SECONDS [libFuzzer options...]
#
# TARGET is a folder of tests/fuzz/corpus (obj, dxf, ply, glb, scene, probe, assimp_gltf,
# assimp_dae, ...; docs/fuzzing.md). Builds the libFuzzer binary with clang, ASan and UBSan
# (the fuzz preset, build/fuzz), runs it for SECONDS from the target's corpus, and copies every
# finding (crash, timeout, out of memory) into the corpus, where the CTest replay
# (fuzz_replay.TARGET) keeps it as a regression case; fix the reader, then commit the file.
# New inputs that only add coverage go to build/fuzz/corpus/TARGET, not into the repository.
# Exit status: 0 no finding, 1 findings (listed), 2 usage.
set -euo pipefail

if [[ $# -lt 2 || ! $2 =~ ^[0-9]+$ ]]; then
    echo "usage: scripts/fuzz.sh TARGET SECONDS [libFuzzer options...]" >&2
    exit 2
fi
target=$1
seconds=$2
shift 2
root=$(cd "$(dirname "$0")/.." && pwd)
corpus=$root/tests/fuzz/corpus/$target
if [[ ! -d $corpus ]]; then
    echo "scripts/fuzz.sh: no corpus folder $corpus (targets: $(ls "$root/tests/fuzz/corpus" | grep -v README | tr '\n' ' '))" >&2
    exit 2
fi

cd "$root"
cmake --preset fuzz >/dev/null
cmake --build --preset fuzz --target "fuzz_$target" -j1 >/dev/null
work=$root/build/fuzz/corpus/$target
findings=$root/build/fuzz/findings/$target
mkdir -p "$work" "$findings"

# -timeout: one input over 60 s is a hang (the readers' child processes have their own
# limits); -rss_limit_mb: the parent's memory (a reader's child is limited separately)
status=0
ASAN_OPTIONS=allocator_may_return_null=1 \
    "build/fuzz/tests/fuzz/fuzz_$target" -max_total_time="$seconds" -timeout=60 \
    -rss_limit_mb=4096 -print_final_stats=1 -artifact_prefix="$findings/" "$@" \
    "$work" "$corpus" || status=$?

found=0
for f in "$findings"/*; do
    [[ -f $f ]] || continue
    cp "$f" "$corpus/finding-$(sha1sum "$f" | cut -c1-12)"
    echo "finding: $f (copied into $corpus)"
    rm "$f"
    found=$((found + 1))
done
if [[ $found -gt 0 || $status -ne 0 ]]; then
    echo "scripts/fuzz.sh: $target: $found finding(s), fuzzer exit status $status" >&2
    exit 1
fi
