#!/usr/bin/env bash
# Fault injection: the k-th allocation of padapt's allocator fails
# (PADAPT_TEST_FAIL_ALLOC=k) during a small adaptation: sequentially for
# every k until the run needs no more allocations than k; on 2 processes for
# k growing geometrically, on every rank and on rank 1 only
# (PADAPT_TEST_FAIL_RANK=1: the other rank carries on, so any collective
# entered without agreeing first hangs). Every failed run must end in a clean
# error (exit status 1, an "out of memory" message, no crash nor sanitizer
# report, no hang), the previous output untouched and no temporary left; the
# first run that gets through writes a valid mesh. bench/alloc_faults.sh
# runs a denser sweep at any number of processes.
set -u
: "${PADAPT:?PADAPT must point to the padapt binary}"
MPIEXEC=${MPIEXEC:-mpiexec}
fails=0
fail() { echo "FAIL $*"; fails=$((fails + 1)); }

"$PADAPT" generate box2d 10 in.mesh > /dev/null || exit 1
echo previous > out.mesh

run() { # np k
  rm -f log.txt
  if [ "$1" -gt 1 ]; then
    PADAPT_TEST_FAIL_ALLOC=$2 timeout 60 "$MPIEXEC" -n "$1" "$PADAPT" adapt \
      in.mesh -hsiz 0.05 -out out.mesh > log.txt 2>&1
  else
    PADAPT_TEST_FAIL_ALLOC=$2 timeout 120 "$PADAPT" adapt in.mesh -hsiz 0.05 \
      -out out.mesh > log.txt 2>&1
  fi
}

sweep() { # np, then the values of k
  local np=$1 nfail=0 k
  shift
  for k in "$@"; do
    run "$np" "$k"
    local rc=$?
    if grep -q "AddressSanitizer\|runtime error\|LeakSanitizer" log.txt; then
      fail "np=$np k=$k: sanitizer report: $(grep -m1 'Sanitizer\|runtime error' log.txt)"
      return
    fi
    if [ $rc -eq 0 ]; then
      if [ "$(head -c 8 out.mesh)" = "previous" ] ||
         ! "$PADAPT" stats out.mesh > /dev/null 2>&1; then
        fail "np=$np k=$k: exit 0 without a valid output"
      else
        echo "ok   np=$np: $nfail injected failures ended cleanly; k=$k got through, valid output"
      fi
      echo previous > out.mesh
      return
    fi
    nfail=$((nfail + 1))
    if [ $rc -ne 1 ]; then fail "np=$np k=$k: exit status $rc (crash or hang)"; return; fi
    if ! grep -q "out of memory" log.txt; then
      fail "np=$np k=$k: no 'out of memory' message: $(grep -m1 padapt: log.txt)"; return
    fi
    if [ "$(cat out.mesh)" != "previous" ] || ls ./*.tmp.* > /dev/null 2>&1; then
      fail "np=$np k=$k: the previous output changed or a temporary was left"; return
    fi
  done
  fail "np=$np: every injected failure failed the run (more allocations than swept)"
}

# k growing by a factor g from 1 to 4000
geometric() { awk -v g="$1" 'BEGIN { for (k = 1; k <= 4000; k = int(k * g) + 1) print k }'; }

# every k sequentially; every third under the sanitizers (each run is
# slower there); a ladder doubling k on 2 processes, on both ranks and on
# rank 1 alone; under the sanitizers a sparser ladder on rank 1 alone
step=1
[ "${PADAPT_SANITIZE:-0}" = 1 ] && step=3
sweep 1 $(seq 1 "$step" 2000)
if [ "${PADAPT_SANITIZE:-0}" = 1 ]; then
  PADAPT_TEST_FAIL_RANK=1 sweep 2 $(geometric 3)
else
  sweep 2 $(geometric 2)
  PADAPT_TEST_FAIL_RANK=1 sweep 2 $(geometric 2)
fi
[ $fails -eq 0 ] && echo "all checks passed" || { echo "$fails check(s) failed"; exit 1; }
