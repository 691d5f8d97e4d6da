#!/bin/sh
# Builds `sms` and the throughput bench with profile-guided optimisation (PGO): an instrumented
# build runs a training set of `sms` runs and the throughput bench, LLVM merges the profiles,
# and a second build lays out and inlines the code by them. The model's results cannot change
# (the compiler reorders code, not arithmetic); this script checks it by comparing one run's JSON
# report of the normal build and the PGO build. On this project's machine the simulation loop
# executes 9 % fewer instructions with a fifth of the instruction-cache misses, 14 % fewer
# estimated cycles (scripts/instructions.sh --cache on the two bench binaries).
#
# Usage: scripts/pgo.sh          (about 8 minutes here the first time: two release builds and
#                                 the training; less when only the project's sources changed)
#   Leaves target/pgo/release/sms and prints the PGO bench binary's path. Needs the toolchain's
#   llvm-profdata: rustup component add llvm-tools (a distribution's llvm-profdata of another
#   LLVM version cannot read rustc's profiles). Uses target/pgo-gen and target/pgo; the normal
#   target/ build is untouched.
set -eu
cd "$(dirname "$0")/.."
root=$PWD
sysroot=$(rustc --print sysroot)
host=$(rustc -vV | sed -n 's/^host: //p')
profdata="$sysroot/lib/rustlib/$host/bin/llvm-profdata"
if [ ! -x "$profdata" ]; then
    echo "llvm-profdata of this toolchain not found at $profdata: run 'rustup component add llvm-tools'" >&2
    exit 1
fi
command -v python3 >/dev/null 2>&1 || { echo "python3 is needed to compare the reports" >&2; exit 1; }
gen=$root/target/pgo-gen
use=$root/target/pgo
data=$gen/profiles
log=$gen/build.log
mkdir -p "$gen"
: >"$log"

# Builds sms and the bench into $1 with RUSTFLAGS $2; prints the bench binary's path.
build() {
    RUSTFLAGS="$2" CARGO_TARGET_DIR="$1" cargo build --release -p tb --bin sms >>"$log" 2>&1 ||
        { echo "build failed, see $log" >&2; exit 1; }
    RUSTFLAGS="$2" CARGO_TARGET_DIR="$1" cargo bench -p tb --bench throughput --no-run >>"$log" 2>&1 ||
        { echo "bench build failed, see $log" >&2; exit 1; }
    grep 'Executable benches/throughput.rs' "$log" | tail -n 1 | sed 's/.*(\(.*\))$/\1/'
}

echo "1/4 instrumented build ($gen)" >&2
rm -rf "$data"
bench_gen=$(build "$gen" "-Cprofile-generate=$data")
# Profiles of build scripts and proc macros, written while building, are not wanted.
rm -rf "$data"

echo "2/4 training runs" >&2
sms_gen=$gen/release/sms
# Cycle level with and without SH stacks, both stack timings, two scenes; the functional level;
# the bench (which also times obvhs's traversal, so both sides of its ratio are optimised alike).
"$sms_gen" run --scene clutter --res 48x48 -c RB_8,RB_16,RB_8+SH_8,SMS --quiet --json >/dev/null
"$sms_gen" run --scene grid --res 32x32 -c RB_8,RB_8+SH_8+SK,SMS --stack-timing overlapped --quiet --json >/dev/null
"$sms_gen" run --scene wknd --res 32x32 -c RB_8,SMS --fidelity functional --quiet --json >/dev/null
"$bench_gen" >/dev/null

echo "3/4 merging profiles" >&2
"$profdata" merge -o "$gen/merged.profdata" "$data"

echo "4/4 optimised build ($use)" >&2
bench_use=$(build "$use" "-Cprofile-use=$gen/merged.profdata")

echo "checking: one run's report from the normal build and from the PGO build" >&2
cargo build --release -p tb --bin sms >>"$log" 2>&1 || { echo "normal build failed, see $log" >&2; exit 1; }
check="run --scene clutter --res 32x32 --spp 1 --bounces 3 -c RB_8,RB_8+SH_8,SMS --quiet --json"
# shellcheck disable=SC2086
"$root/target/release/sms" $check >"$gen/normal.json"
# shellcheck disable=SC2086
"$use/release/sms" $check >"$gen/pgo.json"
python3 - "$gen/normal.json" "$gen/pgo.json" <<'EOF'
import json, sys
def strip(o):
    if isinstance(o, dict):
        return {k: strip(v) for k, v in o.items() if "wall" not in k and "time" not in k and k != "seconds"}
    if isinstance(o, list):
        return [strip(v) for v in o]
    return o
a, b = (strip(json.load(open(p))) for p in sys.argv[1:3])
if a != b:
    sys.exit("the PGO build's report differs from the normal build's: do not use it")
EOF
echo "reports identical" >&2
case $bench_use in /*) ;; *) bench_use=$root/$bench_use ;; esac
echo "sms:   $use/release/sms"
echo "bench: $bench_use  (scripts/instructions.sh --cache $bench_use compares it with the normal build)"
