#!/usr/bin/env bash
# An iteration whose pieces all come back unchanged skips the rebuild of
# the distributed mesh (pa_dmesh_adapt). With -noinsert -noswap -nomove the
# built-in remesher changes nothing, so after the first iteration (whose
# skin bisection refines the pieces' borders) every piece comes back as it
# was given: the loop must say so, end, and leave a valid mesh of the
# whole cube.
set -u
: "${PADAPT:?}" "${MPIEXEC:?}"
fails=0
ok()  { echo "ok   $1"; }
bad() { echo "FAIL $1"; fails=$((fails + 1)); }
json() { /usr/bin/python3 -c "import json,sys; print(json.load(open(sys.argv[1]))[sys.argv[2]])" "$1" "$2"; }

"$PADAPT" generate box3d 6 cube.mesh > /dev/null || bad "generate"
for np in 2 3; do
  rm -f out.mesh s.json
  # the metric is missed: a warning, and the valid mesh is written
  "$MPIEXEC" -n $np "$PADAPT" adapt cube.mesh -hsiz 0.1 -noinsert -noswap \
    -nomove -out out.mesh -nosol -v 1 > log.txt 2>&1
  grep -q "every piece came back unchanged, no rebuild" log.txt \
    && ok "np=$np: the unchanged iteration is not rebuilt" \
    || bad "np=$np: no iteration skipped its rebuild"
  grep -q "the loop ends" log.txt && ok "np=$np: the loop ends" \
    || bad "np=$np: the loop did not end by its rule"
  "$PADAPT" stats out.mesh -json s.json > /dev/null 2>&1 \
    && [ "$(json s.json valid)" = True ] && [ "$(json s.json volume)" = 1 ] \
    && ok "np=$np: valid output of volume 1" \
    || { bad "np=$np: output invalid or incomplete"; tail -5 log.txt; }
done
echo "$fails failed"
[ "$fails" -eq 0 ]
