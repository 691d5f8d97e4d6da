#!/bin/sh
# What tracing costs when it is off (issue 5): the same SMS cycle-level run with a NullSink,
# timed in the normal build and in one with rtl's probe calls compiled out (feature `untraced`),
# alternating builds so both see the same machine load. Prints both best times and the ratio.
# Usage: scripts/trace-overhead.sh [ROUNDS]   (default 3; each round runs each build 3 times)
set -eu
cd "$(dirname "$0")/.."
rounds=${1:-3}
exe() {
    cargo bench -p tb --bench throughput --no-run "$@" 2>&1 |
        sed -n 's/.*Executable .*(\(.*\))$/\1/p' | tail -n 1
}
traced=$(exe)
untraced=$(exe --features untraced)
[ -x "$traced" ] && [ -x "$untraced" ] || { echo "could not build the benches" >&2; exit 1; }
log=$(mktemp)
i=0
while [ "$i" -lt "$rounds" ]; do
    "$traced" --overhead >>"$log"
    "$untraced" --overhead >>"$log"
    i=$((i + 1))
done
awk '
    { t = $3 + 0; if (!($2 in best) || t < best[$2]) best[$2] = t }
    END {
        printf "NullSink run, normal build:            %.4f s (best of %d)\n", best["traced"], NR / 2 * 3
        printf "same run, probe calls compiled out:    %.4f s\n", best["untraced"]
        printf "tracing off costs %+.2f %% of run time\n", (best["traced"] / best["untraced"] - 1) * 100
    }' "$log"
rm -f "$log"
