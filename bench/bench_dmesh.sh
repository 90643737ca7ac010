#!/bin/bash
# bench_dmesh.sh -- distributed-mesh benchmark (issue #5, recorded in
# docs/BENCHMARKS.md): generate a box3d of >= 10 M tetrahedra (N = 120 gives
# 10.4 M), then on P ranks (default 2) time read, distribute (scatter,
# PT-Scotch partition, migration and ghost build: the per-step split is
# printed by the library at verbosity 1), redistribution and halo bandwidth,
# with the peak memory of every rank per step; then `padapt partition` on the
# same file (-v 2: per-rank time and memory of each command step).
#
#   bench/bench_dmesh.sh [BUILD_DIR] [N] [P]
#
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
mesh="$work/box3d_$n.meshb"
if [ ! -f "$mesh" ]; then
  echo "== generating box3d $n"
  /usr/bin/time -f "generate: %e s, %M KB max RSS" \
    "$build/bin/padapt" generate box3d "$n" "$mesh"
fi
echo "== bench_dmesh on $np ranks ($(nproc) cores)"
mpiexec -n "$np" "$work/bench_dmesh" "$mesh" 1
echo "== padapt partition on $np ranks"
mpiexec -n "$np" "$build/bin/padapt" -v 2 partition "$mesh" \
  -out "$work/part" -overlap 1
ls -l "$work"/part.* | head -n 8
