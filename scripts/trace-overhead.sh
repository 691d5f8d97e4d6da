#!/bin/sh
# What tracing costs when it is off: the same SMS cycle-level run with a NullSink,
# timed in the normal build and in one with rtl's probe calls compiled out (feature `untraced`),
# alternating builds so both see the same machine load. Prints the best wall and on-CPU times of
# each build and the ratios (on a loaded machine trust the on-CPU figure).
# Usage: scripts/trace-overhead.sh [ROUNDS]   (default 5; each round runs each build 3 times)
set -eu
cd "$(dirname "$0")/.."
rounds=${1:-5}
exe() {
    cargo bench -p tb --bench throughput --no-run "$@" 2>&1 |
        sed -n 's/.*Executable .*(\(.*\))$/\1/p' | tail -n 1
}
# Untraced first: building the bench also relinks target/release/sms, which must end up traced.
untraced=$(exe --features untraced)
traced=$(exe)
[ -x "$traced" ] && [ -x "$untraced" ] || { echo "could not build the benches" >&2; exit 1; }
log=$(mktemp)
i=0
while [ "$i" -lt "$rounds" ]; do
    "$traced" --overhead >>"$log"
    "$untraced" --overhead >>"$log"
    i=$((i + 1))
done
awk -v runs=$((rounds * 3)) '
    {
        if (!($2 in wall) || $3 < wall[$2]) wall[$2] = $3
        if (!($2 in cpu) || $4 < cpu[$2]) cpu[$2] = $4
    }
    END {
        printf "best of %d runs each      wall s    on-CPU s\n", runs
        printf "normal build, NullSink   %7.4f    %7.4f\n", wall["traced"], cpu["traced"]
        printf "probe calls compiled out %7.4f    %7.4f\n", wall["untraced"], cpu["untraced"]
        printf "tracing off costs %+.2f %% (wall), %+.2f %% (on-CPU) of run time\n",
            (wall["traced"] / wall["untraced"] - 1) * 100, (cpu["traced"] / cpu["untraced"] - 1) * 100
    }' "$log"
rm -f "$log"
