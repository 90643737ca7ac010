#!/bin/bash
# bench_dmesh.sh -- distributed-mesh benchmark (issue #5, recorded in
# docs/BENCHMARKS.md): generate a box3d of >= 10 M tetrahedra (N = 120 gives
# 10.4 M), then on P ranks (default 2) time read, distribute (scatter,
# PT-Scotch partition, migration and ghost build: the per-step split is
# printed by the library at verbosity 2), halo bandwidth at three field
# sizes, redistribution (2:1 weights) with its quality, locality reorderings,
# with the peak memory of every rank per step; then `padapt partition` on the
# same file (-v 2: per-rank time and memory of each command step). With
# BENCH_SCOTCH=1, also bench_scotch: PT-Scotch strategies on the dual graph
# (time, edge cut, imbalance), on 1 and on P ranks.
#
#   bench/bench_dmesh.sh [BUILD_DIR] [N] [P]
#
# Record the machine load (uptime) with the figures: on shared cores, times
# vary by up to 2x between runs; memory figures are stable.
# BUILD_DIR (default build) must hold a Release build of padapt.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
build=$(cd "${1:-$here/../build}" && pwd)
n=${2:-120}
np=${3:-2}
work=${BENCH_WORK:-/tmp/padapt-bench-dmesh}
mkdir -p "$work"
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
export OMPI_MCA_rmaps_base_oversubscribe=1 SCOTCH_PTHREAD_NUMBER=1
mpicc -O2 -std=c11 -I"$here/../include" "$here/bench_dmesh.c" \
  -L"$build/lib" -lpadapt -Wl,-rpath,"$build/lib" -o "$work/bench_dmesh"
mpicc -O2 -std=c11 -I"$here/../include" "$here/bench_scotch.c" \
  -L"$build/lib" -lpadapt -lptscotch -lscotch -lptscotcherr \
  -Wl,-rpath,"$build/lib" -o "$work/bench_scotch"
mesh="$work/box3d_$n.meshb"
if [ ! -f "$mesh" ]; then
  echo "== generating box3d $n"
  /usr/bin/time -f "generate: %e s, %M KB max RSS" \
    "$build/bin/padapt" generate box3d "$n" "$mesh"
fi
echo "== bench_dmesh on $np ranks ($(nproc) cores), load: $(uptime)"
mpiexec -n "$np" "$work/bench_dmesh" "$mesh" 1 2
echo "== padapt partition on $np ranks"
mpiexec -n "$np" "$build/bin/padapt" -v 2 partition "$mesh" \
  -out "$work/part" -overlap 1
ls -l "$work"/part.* | head -n 8
if [ "${BENCH_SCOTCH:-0}" = 1 ]; then
  for r in 1 "$np"; do
    echo "== bench_scotch on $r ranks, load: $(uptime)"
    mpiexec -n "$r" "$work/bench_scotch" "$mesh" "$np" 2
  done
fi
echo "load at the end: $(uptime)"
