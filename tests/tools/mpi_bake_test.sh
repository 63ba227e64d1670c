#!/usr/bin/env bash
# The bake shared over MPI ranks (docs/design.md#the-distributed-bake), through mpirun with
# oversubscribed ranks:
#   equivalence  bakes by 1, 2 and 4 ranks against the bake of one process without mpirun.
#                The exported PLY is the same, byte for byte: the direct light alone at 1, 2
#                and 4 ranks without discontinuity meshing (the exact vertex irradiance summed
#                over the ranks), and with converged interreflection (each rank makes its share
#                of the hemicubes' rows and receives the others', so every rank shoots the same
#                rows in the same order) at 2 and 4; and the default bake, discontinuity
#                meshing and interreflection on (shadow segments gathered, the meshing and the
#                exact evaluations shared by region; each region's mesh in an order of its own
#                positions, not of the mesher's memory addresses), at 2 and 4.
#   killed       a rank killed mid-bake (SIGKILL at its first exchange, ABRAD_TEST_KILL_RANK)
#                fails the job: a non-zero status, rank 0 says nothing was stored, and the
#                database keeps every byte; and a subcommand other than bake refuses to run as
#                one of several ranks (exit 2)
# Usage: mpi_bake_test.sh ABRAD WITH_MPI LSAN_SUPPRESSIONS WORK_DIR equivalence|killed
# Exit 77 (skipped) when the build has no MPI or mpirun is missing.
set -euo pipefail
abrad=$1 with_mpi=$2 suppressions=$3 work=$4 case=$5
if [[ $with_mpi != ON ]]; then
    echo "skipped: this build has no MPI (ABRAD_MPI found no Open MPI)"
    exit 77
fi
if ! command -v mpirun >/dev/null; then
    echo "skipped: mpirun is not on the PATH (Debian: openmpi-bin)"
    exit 77
fi
# CI runs as root, which mpirun refuses unless told; 4 ranks on 2 cores need oversubscription.
# Open MPI keeps some allocations to the end: LeakSanitizer ignores those of its libraries only
# (lsan_mpi.supp). Their stacks need the slow unwinder (the fast one stops in the first frame
# of an MCA component, which is unloaded before the leak check and so has no module name); it
# is slow, so only the runs that start MPI (2 and 4 ranks) use it.
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
lsan_mpi="suppressions=$suppressions:print_suppressions=0:fast_unwind_on_malloc=0${LSAN_OPTIONS:+:$LSAN_OPTIONS}"
rm -rf "$work"
mkdir -p "$work"

fail() {
    echo "FAIL: $*"
    exit 1
}

# A room with 2 ceiling panels (4 light triangles) and a piece of furniture
"$abrad" generate --rooms 1 1 --cell 2 --lights 2 --furniture 1 --db "$work/scene.visdb" >"$work/generate.log" 2>&1 ||
    { cat "$work/generate.log"; fail "generate"; }

# bake_and_export NAME RANKS BAKE_OPTIONS...: RANKS 0 = without mpirun
bake_and_export() {
    local name=$1 ranks=$2
    shift 2
    cp "$work/scene.visdb" "$work/$name.visdb"
    local launch=()
    [[ $ranks == 0 ]] || launch=(mpirun --oversubscribe -np "$ranks")
    ((ranks < 2)) || launch=(env "LSAN_OPTIONS=$lsan_mpi" "${launch[@]}")
    "${launch[@]}" "$abrad" bake --db "$work/$name.visdb" "$@" >"$work/$name.log" 2>&1 ||
        { cat "$work/$name.log"; fail "bake $name"; }
    if ((ranks > 1)); then  # the bake records how many ranks shared it
        "$abrad" info --db "$work/$name.visdb" | grep " ranks=$ranks\b" >/dev/null ||
            { cat "$work/$name.log"; fail "$name did not run as $ranks ranks"; }
    fi
    "$abrad" export --db "$work/$name.visdb" --format ply --output "$work/$name.ply" \
        >>"$work/$name.log" 2>&1 || { cat "$work/$name.log"; fail "export $name"; }
}

case $case in
equivalence)
    bake_and_export dm-off-alone 0 --bounces 0 --dm off
    for ranks in 1 2 4; do
        bake_and_export "dm-off-np$ranks" "$ranks" --bounces 0 --dm off
        cmp "$work/dm-off-alone.ply" "$work/dm-off-np$ranks.ply" ||
            fail "--dm off: $ranks ranks export another PLY than one process"
    done
    echo "--dm off: 1, 2 and 4 ranks export the PLY of one process, byte for byte"
    bake_and_export lit-alone 0 --dm off
    for ranks in 2 4; do  # (one rank runs without MPI: the first loop shows it)
        bake_and_export "lit-np$ranks" "$ranks" --dm off
        cmp "$work/lit-alone.ply" "$work/lit-np$ranks.ply" ||
            fail "--dm off, interreflection: $ranks ranks export another PLY than one process"
    done
    # The interreflection did run and did light the ceiling (not a direct-only bake twice)
    # (info into a file: grep -q in a pipe would end it early, and pipefail would see SIGPIPE)
    "$abrad" info --db "$work/lit-np4.visdb" >"$work/lit-np4.info"
    grep -q " indirect_shots=[1-9]" "$work/lit-np4.info" ||
        fail "the 4-rank bake has no interreflection statistics"
    cmp -s "$work/lit-alone.ply" "$work/dm-off-alone.ply" &&
        fail "the bake with interreflection exports the direct-only PLY"
    echo "--dm off, interreflection: 2 and 4 ranks export the PLY of one process, byte for byte"
    bake_and_export dm-on-alone 0
    for ranks in 2 4; do
        bake_and_export "dm-on-np$ranks" "$ranks"
        cmp "$work/dm-on-alone.ply" "$work/dm-on-np$ranks.ply" ||
            fail "--dm on: $ranks ranks export another PLY than one process"
        # The ranks shared the meshing (each meshed its regions and sent them), not each all
        grep -q "per stage:.* mesh [1-9]" "$work/dm-on-np$ranks.log" ||
            { cat "$work/dm-on-np$ranks.log"; fail "$ranks ranks did not share the meshing"; }
    done
    echo "--dm on, interreflection: 2 and 4 ranks export the PLY of one process, byte for byte"
    ;;
killed)
    before=$(sha256sum <"$work/scene.visdb")
    status=0
    LSAN_OPTIONS=$lsan_mpi ABRAD_TEST_KILL_RANK=1 mpirun --oversubscribe -np 2 "$abrad" bake --db "$work/scene.visdb" \
        --bounces 0 >"$work/killed.log" 2>&1 || status=$?
    cat "$work/killed.log"
    ((status != 0)) || fail "the job with a killed rank exited 0"
    grep -q "rank 1" "$work/killed.log" || fail "no message names rank 1"
    grep -q "the bake is not stored" "$work/killed.log" || fail "rank 0 did not say it stored nothing"
    [[ $(sha256sum <"$work/scene.visdb") == "$before" ]] || fail "the database changed"
    "$abrad" info --db "$work/scene.visdb" | grep "bakes (0)" >/dev/null || fail "a bake was stored"
    echo "a killed rank failed the job (status $status); the database is as it was"
    # Only bake runs as ranks: another subcommand launched as one of several is refused
    status=0
    OMPI_COMM_WORLD_SIZE=2 "$abrad" info --db "$work/scene.visdb" >"$work/info.log" 2>&1 || status=$?
    ((status == 2)) && grep -q "only abrad bake runs as several MPI ranks" "$work/info.log" ||
        { cat "$work/info.log"; fail "info as one of 2 ranks: status $status"; }
    ;;
*)
    fail "unknown case '$case'"
    ;;
esac
