# Sourced by the ssm benchmarks: sets $dir (${BENCH_DIR:-/tmp/riskscore-bench}) and $input (the
# first argument, or 1,000,000 real US-101 pairs made once by scripts/ngsim_pairs.py).
dir=${BENCH_DIR:-/tmp/riskscore-bench}
mkdir -p "$dir"
input=${1:-$dir/pairs1m.csv}
if [ ! -f "$input" ]; then
    python3 scripts/ngsim_pairs.py --data "${NGSIM_DIR:-../shared/data/ngsim-us101}" \
        --rows 1000000 --out "$input"
fi
