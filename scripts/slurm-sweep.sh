#!/bin/sh
# A sweep (or ablation) on a Slurm cluster: a job array of N shards, each computing its share of
# the results into one shared cache folder, then a job that runs after all of them and writes the
# report from the cache alone. Usage (docs/cluster.md):
#
#   scripts/slurm-sweep.sh N OUT [sms sweep arguments...]
#   SMS_COMMAND=ablate scripts/slurm-sweep.sh 8 /shared/out/ablate --quick
#
# OUT must be on a file system every node sees (the cache is OUT/cache). Extra sbatch options
# (partition, time limit, memory) go in SBATCH_OPTS, e.g. SBATCH_OPTS="--partition=cpu --time=4:00:00".
# SMS is the sms binary (default: target/release/sms beside this script's folder).
#
# The jobs need nothing from the submitting shell's environment (they run under
# --export=NONE too): the binary, OUT and the scene data folder (SMS_SCENES_DIR, unless the
# arguments give --scenes-dir) are written into each job's command line, every value quoted.
set -eu

if [ $# -lt 2 ]; then
    echo "usage: $0 SHARDS OUT [sms sweep arguments...]" >&2
    exit 2
fi
shards=$1
out=$2
shift 2
case $shards in
    '' | *[!0-9]* | 0) echo "$0: SHARDS must be a positive whole number, not '$shards'" >&2; exit 2 ;;
esac
here=$(cd "$(dirname "$0")/.." && pwd)
sms=${SMS:-$here/target/release/sms}
command=${SMS_COMMAND:-sweep}
[ -x "$sms" ] || { echo "$0: no sms binary at $sms (cargo build --release -p tb, or set SMS)" >&2; exit 2; }
mkdir -p "$out/slurm"
out=$(cd "$out" && pwd)

# A value quoted for the job's shell: in single quotes, each ' written as '\''.
quote() {
    printf "'%s'" "$(printf '%s' "$1" | sed "s/'/'\\\\''/g")"
}

# The arguments, quoted once for the job scripts' shell; the scene folder made explicit.
quoted=""
scenes_dir_given=no
for a in "$@"; do
    case $a in --scenes-dir | --scenes-dir=*) scenes_dir_given=yes ;; esac
    quoted="$quoted $(quote "$a")"
done
if [ $scenes_dir_given = no ] && [ -n "${SMS_SCENES_DIR:-}" ]; then
    quoted="$quoted --scenes-dir $(quote "$SMS_SCENES_DIR")"
fi
run="exec $(quote "$sms") $command --out $(quote "$out") --cache $(quote "$out/cache")"

# Every shard: the same arguments plus --shard K/N (Slurm numbers array tasks 0..N-1 here and
# sets SLURM_ARRAY_TASK_ID in every task, whatever --export says).
array=$(sbatch --parsable ${SBATCH_OPTS:-} --job-name=sms-$command --array=0-$((shards - 1)) \
    --output="$out/slurm/shard-%a.log" --wrap="$run --shard \$SLURM_ARRAY_TASK_ID/$shards$quoted")
# The report, once every shard has succeeded.
collect=$(sbatch --parsable ${SBATCH_OPTS:-} --job-name=sms-$command-collect --dependency=afterok:$array \
    --output="$out/slurm/collect.log" --wrap="$run --collect$quoted")
echo "submitted shards $array (0..$((shards - 1))) and collect $collect; report: $out/summary.md, logs: $out/slurm/"
