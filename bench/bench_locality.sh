#!/bin/bash
# bench_locality.sh -- locality renumbering after an adaptation (issue #21
# item 3, recorded in docs/BENCHMARKS.md): builds bench_locality.c against
# BUILD_DIR's libpadapt (-O3), then runs it at each process count of PROCS
# (default "1 2"), one after the other: rod3d adapted to -hsiz H (default
# 0.03, 0.8 M tetrahedra), re-read per ordering {as adapted, Hilbert,
# Scotch}, halo / element sweeps / next adaptation (0.8 H) timed on each,
# REPS interleaved repetitions (default 3), medians with [min, max].
#
#   bench/bench_locality.sh [BUILD_DIR] [H] [REPS]
#
# Record the machine load (uptime, printed before and after) with the
# figures: on shared cores times vary by up to 2x between runs.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
build=$(cd "${1:-$here/../build}" && pwd)
h=${2:-0.03}
reps=${3:-3}
work=${BENCH_WORK:-/tmp/padapt-bench-locality}
mkdir -p "$work"
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
export OMPI_MCA_rmaps_base_oversubscribe=1 SCOTCH_PTHREAD_NUMBER=1
mpicc -O3 -std=c11 -I"$here/../include" "$here/bench_locality.c" \
  -L"$build/lib" -lpadapt -Wl,-rpath,"$build/lib" -o "$work/bench_locality"
for np in ${PROCS:-1 2}; do
  echo "== bench_locality on $np ranks ($(nproc) cores), commit" \
    "$(git -C "$here" rev-parse --short HEAD 2>/dev/null || echo '?'), load: $(uptime)"
  mpiexec -n "$np" "$work/bench_locality" -mesh "$here/../tests/data/rod3d.mesh" \
    -hsiz "$h" -reps "$reps" -work "$work"
done
echo "load at the end: $(uptime)"
