#!/bin/sh
# Instructions the cycle-level model executes for one SMS run of the throughput bench (clutter
# 64x64, paper hardware), counted by valgrind's callgrind inside the run's `run_timed` only
# (`sim::Runner::run_timed`, or `Gpu::run_timed` in a build where the GPU runs itself): loading
# the scene, building the BVH, tracing the rays and making the RT units' jobs from the traces
# (all on their own thread) are not counted. Wall
# time on a shared virtual machine swings by 15 % and more between runs minutes apart; this count
# moves by about 0.001 % between runs of one build (only waits for the tracing thread vary), so
# it compares two builds of the model where timing cannot.
# Usage: scripts/instructions.sh [--cache] [OTHER_THROUGHPUT_BINARY]
#   With an argument (a throughput bench binary of another build, e.g. copied from
#   target/release/deps/throughput-* before a change), counts both and prints the ratio.
#   --cache also simulates the first-level caches and prints their misses and callgrind's
#   estimated cycles (instructions + 10 x first-level misses + 100 x last-level misses): a change
#   that moves few instructions can still move the cache misses a lot (how long one SM's code and
#   data stay in the caches, say), and the ratio is then of estimated cycles.
# Needs valgrind (Debian: apt-get install valgrind); about a minute per build, three with --cache.
set -eu
cd "$(dirname "$0")/.."
command -v valgrind >/dev/null 2>&1 || { echo "valgrind not found (Debian: apt-get install valgrind)" >&2; exit 1; }
cache=no
if [ "${1:-}" = "--cache" ]; then
    cache=yes
    shift
fi
this=$(cargo bench -p tb --bench throughput --no-run 2>&1 | sed -n 's/.*Executable .*(\(.*\))$/\1/p' | tail -n 1)
[ -x "$this" ] || { echo "could not build the throughput bench" >&2; exit 1; }
if [ $# -gt 0 ] && [ ! -x "$1" ]; then
    echo "$1: not an executable throughput bench binary" >&2
    exit 1
fi
count() {
    log=$(mktemp)
    out=$(valgrind --tool=callgrind --callgrind-out-file=/dev/null --cache-sim=$cache \
        --toggle-collect='rtl::sim::runner::Runner::run_timed*' --toggle-collect='rtl::gpu::Gpu::run_timed*' \
        "$1" --once --serial 2>"$log")
    # "Collected : Ir [Dr Dw I1mr D1mr D1mw ILmr DLmr DLmw]" (the rest with --cache-sim=yes)
    set -- $(sed -n 's/.*Collected : \(.*\)$/\1/p' "$log")
    rm -f "$log"
    cycles=$(echo "$out" | sed -n 's/^once_run_cycles //p')
    [ $# -ge 1 ] && [ -n "$cycles" ] || { echo "no count (is it a throughput bench binary with --once?)" >&2; exit 1; }
    if [ "$cache" = yes ]; then
        est=$(( $1 + 10 * ($4 + $5 + $6) + 100 * ($7 + $8 + $9) ))
        echo "$1 $cycles $4 $(( $5 + $6 )) $est"
    else
        echo "$1 $cycles"
    fi
}
set -- "$this" "$@"
first=""
for bin in "$@"; do
    result=$(count "$bin") || exit 1
    set -- $result
    printf '%-60s %15s instructions, %s GPU cycles, %.0f per cycle\n' "$bin" "$1" "$2" "$(echo "$1 / $2" | bc -l)"
    metric=$1
    if [ "$cache" = yes ]; then
        printf '%-60s %15s I1 misses, %s D1 misses, %s estimated cycles\n' "" "$3" "$4" "$5"
        metric=$5
    fi
    if [ -z "$first" ]; then
        first=$metric
    else
        printf 'this build / other build: %.4f\n' "$(echo "$first / $metric" | bc -l)"
    fi
done
