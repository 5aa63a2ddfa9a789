#!/usr/bin/env bash
# Whole-process benchmark of `riskctl ssm` (and its Parquet paths): rows/s, CPU and peak memory.
#
#   scripts/bench-ssm.sh [PAIRS.csv]
#
# Without an argument the input is built from real freeway trajectories: 1,000,000 ego/partner
# pairs from the NGSIM US-101 CommonRoad scenarios (scripts/ngsim_pairs.py; set NGSIM_DIR, default
# ../shared/data/ngsim-us101). Files go to ${BENCH_DIR:-/tmp/riskscore-bench}. Needs GNU time.
set -euo pipefail
cd "$(dirname "$0")/.."
dir=${BENCH_DIR:-/tmp/riskscore-bench}
mkdir -p "$dir"
input=${1:-$dir/pairs1m.csv}
if [ ! -f "$input" ]; then
    python3 scripts/ngsim_pairs.py --data "${NGSIM_DIR:-../shared/data/ngsim-us101}" \
        --rows 1000000 --out "$input"
fi
cargo build --quiet --release -p host-tools --bin riskctl
riskctl=target/release/riskctl
rows=$(($(wc -l < "$input") - 1))

# One run: label, then riskctl ssm arguments. Prints wall s, CPU s, rows/s and max RSS.
# The output of an earlier run is deleted first: replacing a 330 MB file makes the file system
# free its blocks inside the timed rename (0.2-0.5 s on this ext4 mount), which is not our work.
run() {
    local label=$1
    shift
    local log="$dir/time.log"
    local out=${*: -1}
    [ -f "$out" ] && rm -f "$out" && sync
    /usr/bin/time -f '%e %U %S %M' -o "$log" "$riskctl" ssm "$@" 2>/dev/null
    read -r wall user sys rss < "$log"
    awk -v l="$label" -v w="$wall" -v u="$user" -v s="$sys" -v m="$rss" -v n="$rows" 'BEGIN {
        printf "%-34s %7.2f s wall %7.2f s CPU %10.0f rows/s wall %7.1f MB max RSS\n",
               l, w, u + s, n / w, m / 1024 }'
}

echo "input: $input ($rows rows, $(du -h "$input" | cut -f1)), $(nproc) cores, load $(cut -d' ' -f1-3 /proc/loadavg)"
cat "$input" > /dev/null # page cache
run "csv -> csv" -i "$input" -o "$dir/out.csv"
run "csv -> csv (1 thread)" -i "$input" -o "$dir/out1.csv" --threads 1
run "csv -> /dev/null" -i "$input" -o /dev/null
run "csv -> parquet" -i "$input" -o "$dir/out.parquet"
run "parquet -> parquet" -i "$dir/out.parquet" -o "$dir/out2.parquet"
run "parquet -> csv" -i "$dir/out.parquet" -o "$dir/out3.csv"
cmp -s "$dir/out.csv" "$dir/out1.csv" && echo "1-thread and parallel outputs are identical"
