#!/usr/bin/env bash
# Checkpoint and restart of the parallel `padapt adapt` (-checkpoint DIR,
# -restart DIR): a run killed during iteration K (rank 0 raises SIGKILL
# after iteration K's remeshing, before its checkpoint: test hook
# PADAPT_TEST_KILL_ITER, tools/cmd_adapt_parallel.c) and restarted from DIR writes
# exactly the mesh and metric of an uninterrupted run (cmp), at 4 and at 2
# processes. Leftovers of an interrupted checkpoint write (a partial next
# set, temporaries) do not disturb the restart and are removed by its next
# checkpoint; only the latest checkpoint is kept. A bad checkpoint -- none
# in DIR, a missing or altered rank file, a truncated or altered state file,
# another number of processes, other options -- is refused with a message
# naming the file (or the option), a non-zero exit and no output.
# Case: the unit cube (box3d 3) with the UGAWG polar-1 metric, 3 iterations
# at 4 processes, 2 at 2; under the sanitizers (PADAPT_SANITIZE=1) at 4
# processes only, and the bad checkpoints that reach other code.
set -u
: "${PADAPT:?}" "${MPIEXEC:?}"
fails=0
ok()  { echo "ok   $1"; }
bad() { echo "FAIL $1"; fails=$((fails + 1)); }
rm -rf ck* ref* out* ./*.txt bad* # an earlier run

"$PADAPT" generate box3d 3 cube.mesh > /dev/null || bad "generate"
"$PADAPT" metric ugawg-polar1 cube.mesh cube.sol > /dev/null || bad "metric"
IN=(cube.mesh -met cube.sol)
KILL=2
NPS="4 2"
[ "${PADAPT_SANITIZE:-0}" = 1 ] && NPS="4"
run() { local np=$1; shift; timeout 300 "$MPIEXEC" -n "$np" "$PADAPT" adapt "${IN[@]}" "$@"; }

for np in $NPS; do
  run "$np" -out ref$np.mesh > ref$np.txt 2>&1 || { bad "np=$np: reference run"; cat ref$np.txt; continue; }
  nit=$(grep -c "^  iter " ref$np.txt)
  [ "$nit" -ge "$KILL" ] || bad "np=$np: $nit iterations, the kill needs $KILL"
  PADAPT_TEST_KILL_ITER=$KILL run "$np" -out out$np.mesh -checkpoint ck$np > kill$np.txt 2>&1
  rc=$?
  if [ $rc -eq 0 ]; then bad "np=$np: the killed run exited with 0"; fi
  [ ! -e out$np.mesh ] || bad "np=$np: the killed run wrote its output"
  grep -qx "set iter-$((KILL - 1))" ck$np/checkpoint \
    && ok "np=$np: killed in iteration $KILL (status $rc), checkpoint of iteration $((KILL - 1))" \
    || bad "np=$np: no checkpoint of iteration $((KILL - 1)): $(ls ck$np)"
  # an interrupted write of the next checkpoint: a partial set, temporaries
  head -c 100 ck$np/iter-$((KILL - 1)).0.meshb > ck$np/iter-$KILL.0.meshb
  echo partial > ck$np/iter-$KILL.1.meshb.tmp.99999
  echo partial > ck$np/checkpoint.tmp.99999
  run "$np" -out out$np.mesh -restart ck$np -checkpoint ck$np > restart$np.txt 2>&1 \
    || { bad "np=$np: restart failed"; cat restart$np.txt; continue; }
  first=$(grep -m1 "^  iter " restart$np.txt | awk '{print $2}')
  [ "$first" = "$KILL:" ] && ok "np=$np: the restart began with iteration $KILL" \
    || bad "np=$np: the restart began with iteration '$first'"
  if cmp ref$np.mesh out$np.mesh && cmp ref$np.sol out$np.sol; then
    ok "np=$np: restarted output identical to the uninterrupted run's"
  else bad "np=$np: restarted output differs from the uninterrupted run's"; fi
  left=$(cd ck$np && ls | grep -v "^iter-$nit\." | grep -vx checkpoint)
  [ -z "$left" ] && grep -qx "set iter-$nit" ck$np/checkpoint \
    && ok "np=$np: only the latest checkpoint (iteration $nit) is left" \
    || bad "np=$np: checkpoint directory holds: $left"
done

# The bad checkpoints are altered copies of the last one written at the
# fewest processes (fewer processes start faster).
np=${NPS##* }
last=$((np - 1))
# refused DESCRIPTION NP FRAGMENT1 FRAGMENT2 ARGS...: fails with both
# fragments in its message, and writes nothing.
refused() {
  local d=$1 n=$2 f1=$3 f2=$4; shift 4
  rm -f badout.mesh badout.sol
  if run "$n" -out badout.mesh "$@" > bad.txt 2>&1; then bad "$d: accepted"
  elif ! grep -qF -- "$f1" bad.txt || ! grep -qF -- "$f2" bad.txt; then
    bad "$d: message lacks '$f1' or '$f2': $(grep padapt: bad.txt | head -3)"
  elif [ -e badout.mesh ] || [ -e badout.sol ]; then bad "$d: output written"
  elif grep -q "Sanitizer\|runtime error" bad.txt; then bad "$d: sanitizer report"
  else ok "$d: $(grep padapt: bad.txt | grep -v 'not read' | head -1)"; fi
}
# a fresh copy of that checkpoint in ckbad; prints its set's name
fresh() { rm -rf ckbad && cp -r ck$np ckbad && sed -n 's/^set //p' ckbad/checkpoint; }

mkdir -p ckempty
refused "no checkpoint in DIR" 1 ckempty/checkpoint "cannot open" -restart ckempty
set=$(fresh); rm ckbad/$set.$last.meshb
refused "missing rank file" $np ckbad/$set.$last.meshb "missing" -restart ckbad
set=$(fresh); sed -i 's/^loop.nostep .*/loop.nostep x/' ckbad/checkpoint
refused "altered state file" $np ckbad/checkpoint "bad line" -restart ckbad
set=$(fresh)
refused "another number of processes" 1 ckbad/checkpoint "$np processes" -restart ckbad
if [ "${PADAPT_SANITIZE:-0}" != 1 ]; then # the same code paths as above
  set=$(fresh); /usr/bin/python3 -c "
f = open('ckbad/$set.$last.meshb', 'r+b'); f.seek(300); b = f.read(1); f.seek(300); f.write(bytes([b[0] ^ 1]))"
  refused "altered rank file" $np ckbad/$set.$last.meshb "checksum" -restart ckbad
  set=$(fresh); head -n 12 ckbad/checkpoint > t.txt && mv t.txt ckbad/checkpoint
  refused "truncated state file" $np ckbad/checkpoint "truncated" -restart ckbad
  set=$(fresh); echo "different" >> ckbad/$set.manifest
  refused "manifest of another write" $np ckbad/$set.manifest "checksum" -restart ckbad
  set=$(fresh)
  refused "other options" $np ckbad/checkpoint "max_iter" -restart ckbad -max-iter 7
fi
! grep -l "Sanitizer\|runtime error" ./*.txt && ok "no sanitizer report" \
  || bad "sanitizer reports (files above)"
echo "$fails failed"
[ $fails -eq 0 ]
