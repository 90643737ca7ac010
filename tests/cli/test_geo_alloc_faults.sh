#!/usr/bin/env bash
# Fault injection with a CAD model: the k-th allocation of padapt's
# allocator fails (PADAPT_TEST_FAIL_ALLOC=k) during `padapt adapt -geo` of a
# plate with a hole (a .geo on OpenCASCADE, meshed coarsely by the gmsh
# command line), for k on a geometric ladder to 4000: sequentially, and on 2
# processes on every rank and on rank 1 only (the other rank carries on: a
# collective entered without agreeing first hangs). Each run must either end
# in a clean error (exit status 1, an "out of memory" message, no crash nor
# sanitizer report, no hang, the previous output untouched, no temporary
# left) or get through (some allocations may fail without harm) with the
# output of the run without fault on that many processes, byte for byte:
# the classification, the points on the model and the physical names are
# never dropped silently. Skipped (exit 0, said) when padapt was built
# without Gmsh's library or the gmsh command line is missing.
set -u
: "${PADAPT:?PADAPT must point to the padapt binary}"
MPIEXEC=${MPIEXEC:-mpiexec}
fails=0
fail() { echo "FAIL $*"; fails=$((fails + 1)); }

if "$PADAPT" adapt none.msh -geo none.geo -hsiz 1 2>&1 |
   grep -q "built without Gmsh's library"; then
  echo "skipped: padapt was built without Gmsh's library"; exit 0
fi
command -v gmsh > /dev/null || { echo "skipped: no gmsh command line"; exit 0; }

cat > plate.geo << 'GEO'
SetFactory("OpenCASCADE");
Rectangle(1) = {0, 0, 0, 1, 1};
Disk(2) = {0.5, 0.5, 0, 0.25};
BooleanDifference{ Surface{1}; Delete; }{ Surface{2}; Delete; }
Physical Curve("hole") = {5};
Physical Surface("plate") = {1};
GEO
gmsh -2 -clmax 0.3 -clcurv 0 plate.geo -format msh41 -o in.msh > /dev/null || exit 1
ARGS=(adapt in.msh -geo plate.geo -hsiz 0.06 -out out.msh)

run() { # np k
  rm -f log.txt
  if [ "$1" -gt 1 ]; then
    PADAPT_TEST_FAIL_ALLOC=$2 timeout 60 "$MPIEXEC" -n "$1" "$PADAPT" "${ARGS[@]}" > log.txt 2>&1
  else
    PADAPT_TEST_FAIL_ALLOC=$2 timeout 60 "$PADAPT" "${ARGS[@]}" > log.txt 2>&1
  fi
}

sweep() { # np, then the values of k
  local np=$1 nfail=0 nthrough=0 k rc
  shift
  run "$np" 0 || { fail "np=$np: the run without fault failed: $(tail -2 log.txt)"; return; }
  mv out.msh ref.msh
  echo previous > out.msh
  for k in "$@"; do
    run "$np" "$k"
    rc=$?
    if grep -q "AddressSanitizer\|runtime error\|LeakSanitizer" log.txt; then
      fail "np=$np k=$k: sanitizer report: $(grep -m1 'Sanitizer\|runtime error' log.txt)"
      return
    fi
    if [ $rc -eq 0 ]; then
      cmp -s out.msh ref.msh ||
        fail "np=$np k=$k: exit 0 with an output other than the run without fault"
      nthrough=$((nthrough + 1))
      echo previous > out.msh
      continue
    fi
    nfail=$((nfail + 1))
    if [ $rc -ne 1 ]; then fail "np=$np k=$k: exit status $rc (crash or hang)"; return; fi
    if ! grep -q "out of memory" log.txt; then
      fail "np=$np k=$k: no 'out of memory' message: $(grep -m1 padapt: log.txt)"; return
    fi
    if [ "$(cat out.msh)" != "previous" ] || ls ./*.tmp.* > /dev/null 2>&1; then
      fail "np=$np k=$k: the previous output changed or a temporary was left"; return
    fi
  done
  [ $nfail -gt 0 ] && [ $nthrough -gt 0 ] ||
    fail "np=$np: $nfail clean failures, $nthrough runs through: the ladder misses the run"
  echo "ok   np=$np${PADAPT_TEST_FAIL_RANK:+ (rank $PADAPT_TEST_FAIL_RANK failing)}: $nfail injected failures ended cleanly, $nthrough got through with the output of the run without fault"
}

# k growing by a factor g from 1 to 4000 (each run loads the model: about
# 0.2 s of CPU)
geometric() { awk -v g="$1" 'BEGIN { for (k = 1; k <= 4000; k = int(k * g) + 1) print k }'; }

if [ "${PADAPT_SANITIZE:-0}" = 1 ]; then
  sweep 1 $(geometric 2)
  PADAPT_TEST_FAIL_RANK=1 sweep 2 $(geometric 3)
else
  sweep 1 $(geometric 1.3)
  sweep 2 $(geometric 2)
  PADAPT_TEST_FAIL_RANK=1 sweep 2 $(geometric 2)
fi
[ $fails -eq 0 ] && echo "all checks passed" || { echo "$fails check(s) failed"; exit 1; }
