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

# Arguments quoted once for the job scripts' shell.
quoted=""
for a in "$@"; do
    quoted="$quoted '$(printf '%s' "$a" | sed "s/'/'\\\\''/g")'"
done

# Every shard: the same arguments plus --shard K/N (Slurm numbers array tasks 0..N-1 here).
array=$(sbatch --parsable ${SBATCH_OPTS:-} --job-name=sms-$command --array=0-$((shards - 1)) \
    --output="$out/slurm/shard-%a.log" --wrap="exec '$sms' $command --out '$out' --cache '$out/cache' \
--shard \$SLURM_ARRAY_TASK_ID/\$SLURM_ARRAY_TASK_COUNT$quoted")
# The report, once every shard has succeeded.
collect=$(sbatch --parsable ${SBATCH_OPTS:-} --job-name=sms-$command-collect --dependency=afterok:$array \
    --output="$out/slurm/collect.log" --wrap="exec '$sms' $command --out '$out' --cache '$out/cache' --collect$quoted")
echo "submitted shards $array (0..$((shards - 1))) and collect $collect; report: $out/summary.md, logs: $out/slurm/"
