#!/usr/bin/env bash
# The many-core measurements of docs/decisions/0004-parallel-passes.md, prepared as one short run for a lent
# machine (one call of the device tool: at most 10 minutes, so every stage has its own time limit).
#
#   bash benchmarks/sixteen_cores.sh [OUT]        # from the repository's root; OUT: where the logs go
#
# Needs numpy, scipy, numba, h5py and click (the lent machines have them; granwave itself is read
# from this checkout, not installed). Stages, each cut off at its limit with what it printed kept:
#   1. the machine: CPU, cores, numba and numpy versions;
#   2. the 600-grain packing at p = 1e-4 that the benchmarks tile (this also compiles the kernels);
#   3. scale.py: DEM and time domain, threads 1 and all cores, best of 3, with the one-thread DEM
#      rate alone on each CPU in turn (--each-cpu: the ratio against the fastest, median and
#      slowest CPU, so that it does not depend on where the one-thread run landed) and the ceiling
#      (--ceiling: as many one-thread processes at once, each on a thread's share);
#   4. dem_team_times.py: where a team step goes at all cores (passes, barriers, imbalance).
# Every stage appends to OUT/log.txt.
set -uo pipefail
out=${1:-${OUT:-/tmp/sixteen_cores}}
mkdir -p "$out"
export PYTHONPATH="$PWD${PYTHONPATH:+:$PYTHONPATH}" PYTHONUNBUFFERED=1
cores=$(nproc)
log="$out/log.txt"
t0=$SECONDS

stage() {  # stage LIMIT_S TITLE COMMAND...: run COMMAND under a time limit, its output into the log
    local limit=$1 title=$2
    shift 2
    echo "== $title (limit ${limit} s, at $((SECONDS - t0)) s)" | tee -a "$log"
    timeout "$limit" "$@" 2>&1 | tee -a "$log"
    echo "== exit ${PIPESTATUS[0]} after $((SECONDS - t0)) s" | tee -a "$log"
}

stage 20 "machine" bash -c "date -u; lscpu | grep -E 'Model name|^CPU\(s\)|Thread|Core|Socket|NUMA|L2|L3'; \
python3 -c 'import numba, numpy; print(\"numba\", numba.__version__, \"numpy\", numpy.__version__)'"
stage 180 "600-grain packing, p = 1e-4" python3 -m granwave prepare-packing --pressure 1e-4 --seed 0 \
    --output "$out/p600.h5"
[ -s "$out/p600.h5" ] || { echo "no packing: stopping" | tee -a "$log"; exit 1; }
stage 240 "scale.py, threads 1 and $cores" python3 benchmarks/scale.py --threads "1,$cores" --no-lammps \
    --repeat 3 --engines-only --packing "$out/p600.h5" --each-cpu --ceiling
stage 90 "dem_team_times.py, threads 1 and $cores" python3 benchmarks/dem_team_times.py \
    --threads "1,$cores" --repeat 3 --packing "$out/p600.h5"
echo "== done in $((SECONDS - t0)) s" | tee -a "$log"
