#!/usr/bin/env bash
# alloc_faults.sh -- fault injection on several processes: the k-th
# allocation of padapt's allocator fails on every rank
# (PADAPT_TEST_FAIL_ALLOC=k) during a small adaptation, for k growing
# geometrically until a run gets through. Prints, per k, how the run ended:
# "clean" (exit 1 with "out of memory", previous output untouched), "hang"
# (killed after TIMEOUT s), "crash" (any other status) or "through" (exit 0).
# With FAIL_RANK=r only rank r fails (PADAPT_TEST_FAIL_RANK), the others
# carry on. tests/cli/test_alloc_faults.sh runs a sparser sweep in make check.
#
#   bash bench/alloc_faults.sh [BUILD_DIR] [WORK_DIR]
#
# Environment: NP (default 2), TIMEOUT (default 60), GROWTH (default 1.5),
# FAIL_RANK (default: every rank).
set -u
# the piece loop itself at every size (padapt adapt -serial-below)
export PADAPT_SERIAL_BELOW=${PADAPT_SERIAL_BELOW:-0}
BUILD=${1:-build}
WORK=${2:-/tmp/padapt-alloc-faults}
PADAPT=${PADAPT:-$(cd "$BUILD/bin" && pwd)/padapt}
NP=${NP:-2}
TIMEOUT=${TIMEOUT:-60}
export PADAPT_TEST_FAIL_RANK=${FAIL_RANK:-}
GROWTH=${GROWTH:-1.5}
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
export OMPI_MCA_rmaps_base_oversubscribe=1 SCOTCH_PTHREAD_NUMBER=1
mkdir -p "$WORK" && cd "$WORK" || exit 1
"$PADAPT" generate box2d 10 in.mesh > /dev/null || exit 1
echo previous > out.mesh
echo "# alloc_faults: np $NP, failing rank ${FAIL_RANK:-all}, box2d 10 -> -hsiz 0.05, $(date -u +%Y-%m-%dT%H:%M:%SZ), binary $PADAPT"
k=1
declare -A n
while :; do
  PADAPT_TEST_FAIL_ALLOC=$k timeout "$TIMEOUT" mpiexec -n "$NP" "$PADAPT" adapt \
    in.mesh -hsiz 0.05 -out out.mesh > "log.$k" 2>&1
  rc=$?
  if [ $rc -eq 0 ]; then r=through
  elif [ $rc -eq 124 ]; then r=hang
  elif [ $rc -eq 1 ] && grep -q "out of memory" "log.$k" &&
       [ "$(cat out.mesh)" = previous ]; then r=clean
  else r="crash ($rc)"
  fi
  echo "k=$k $r"
  n[$r]=$(( ${n[$r]:-0} + 1 ))
  [ $rc -eq 0 ] && break
  k=$(awk -v k="$k" -v g="$GROWTH" 'BEGIN { printf "%d", k * g + 1 }')
done
for r in "${!n[@]}"; do echo "# $r: ${n[$r]}"; done
