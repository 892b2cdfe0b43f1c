#!/usr/bin/env bash
# The measurements of issue 41 (the curve atlas, synthesis and the literature problems) in one go, on a
# machine with 16 cores: every job pinned to 2 cores (taskset, Numba threads 2), so each figure is "on 2
# cores" with nothing else on them. Writes its logs to $OUT (default ./issue41-logs).
#   bash benchmarks/run_issue41.sh [SEEDS]      (DESIGNS, TARGETS, JOBS: smaller runs; fewer than 16 cores: no pinning)
set -u
OUT=${OUT:-./issue41-logs}
SEEDS=${1:-10}
DESIGNS=${DESIGNS:-1000000}
TARGETS=${TARGETS:-6}
JOBS=${JOBS:-6}
pin() { if [ "$(nproc)" -ge 16 ]; then taskset -c "$@"; else shift; "$@"; fi; }
mkdir -p "$OUT"
export PYTHONPATH=$PWD EXPLORER_ATLAS_DIR=${EXPLORER_ATLAS_DIR:-/tmp/issue41-atlas} NUMBA_NUM_THREADS=2 \
       OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1
mkdir -p "$EXPLORER_ATLAS_DIR"
{ nproc; uptime; python -c "import numba, numpy, scipy, h5py; print('numba', numba.__version__, 'numpy', numpy.__version__, 'scipy', scipy.__version__)"; } > "$OUT/machine.txt" 2>&1
t0=$(date +%s)
# the three atlases at once, 2 cores each (the build time printed is each one's own)
for spec in "fourbar 0-1" "watt6 2-3" "stephenson6 4-5"; do
  set -- $spec
  ( pin "$2" python -m explorer.cli atlas build "$1" --designs "$DESIGNS" --force \
      > "$OUT/build-$1.log" 2>&1; python -m explorer.cli atlas info "$1" >> "$OUT/build-$1.log" 2>&1 ) &
done
wait %1
echo "fourbar atlas after $(( $(date +%s) - t0 )) s" >> "$OUT/machine.txt"
# warm the kernels' on-disk cache once (compilation is not the benchmarks')
pin 6-7 python benchmarks/bench_literature.py --problems timed-five --seeds 1 --seconds 1 > "$OUT/warm.log" 2>&1
wait
echo "atlases after $(( $(date +%s) - t0 )) s" >> "$OUT/machine.txt"
# the atlas's look-ups and polishes (2 cores) beside the literature problems (6 jobs x 2 cores)
pin 14-15 python benchmarks/bench_atlas.py --targets "$TARGETS" > "$OUT/atlas.log" 2>&1 &
python benchmarks/bench_literature.py --seeds "$SEEDS" --jobs "$JOBS" --cores 2 > "$OUT/literature.log" 2>&1
wait
echo "all after $(( $(date +%s) - t0 )) s" >> "$OUT/machine.txt"
uptime >> "$OUT/machine.txt"
