#!/usr/bin/env bash
# `padapt adapt -serial-below N`: on several processes, a job whose input
# and expected output both have fewer than N elements is adapted by rank 0
# alone, with the output of one process byte for byte; above N, or with
# -serial-below 0 (or PADAPT_SERIAL_BELOW=0, which the rest of the suite
# sets), the piece loop shares it out. 3D at 2 and 3 processes, and 2D.
set -u
: "${PADAPT:?}" "${MPIEXEC:?}"
fails=0
ok()  { echo "ok   $1"; }
bad() { echo "FAIL $1"; fails=$((fails + 1)); }
unset PADAPT_SERIAL_BELOW

"$PADAPT" generate box3d 6 cube.mesh > /dev/null || bad "generate box3d"
"$PADAPT" generate box2d 10 square.mesh > /dev/null || bad "generate box2d"
# 1 296 tets -> about 5 k; 200 triangles -> about 25 k: below the defaults
for c in "cube.mesh 0.12" "square.mesh 0.01"; do
  set -- $c
  in=$1 h=$2
  "$PADAPT" adapt "$in" -hsiz "$h" -out one.mesh -nosol > one.txt 2>&1 \
    || bad "$in: one process failed"
  for np in 2 3; do
    rm -f two.mesh
    "$MPIEXEC" -n $np "$PADAPT" -v 1 adapt "$in" -hsiz "$h" -out two.mesh \
      -nosol > two.txt 2> two.err
    grep -q "rank 0 adapts alone" two.err && ! grep -q -- "-- ITERATIONS" two.txt \
      && ok "$in np=$np: rank 0 adapts alone" \
      || { bad "$in np=$np: the small job was shared out"; head -3 two.err; }
    cmp -s one.mesh two.mesh && ok "$in np=$np: the output of one process" \
      || bad "$in np=$np: the output differs from one process's"
  done
  for way in "-serial-below 0" "-serial-below 100" "env"; do
    rm -f two.mesh
    if [ "$way" = env ]; then
      PADAPT_SERIAL_BELOW=0 "$MPIEXEC" -n 2 "$PADAPT" -v 1 adapt "$in" \
        -hsiz "$h" -out two.mesh -nosol > two.txt 2> two.err
    else
      "$MPIEXEC" -n 2 "$PADAPT" -v 1 adapt "$in" -hsiz "$h" $way \
        -out two.mesh -nosol > two.txt 2> two.err
    fi
    grep -q -- "-- ITERATIONS" two.txt && ! grep -q "adapts alone" two.err \
      && [ -s two.mesh ] && ok "$in ($way): the piece loop shares it out" \
      || bad "$in ($way): not shared out"
  done
done
"$MPIEXEC" -n 2 "$PADAPT" adapt cube.mesh -hsiz 0.1 -serial-below -5 \
  -out x.mesh > bad.txt 2>&1 && bad "a negative bound is accepted" \
  || ok "a negative bound is refused"
[ ! -e x.mesh ] && ok "nothing written for a bad bound" || bad "x.mesh written"
echo "$fails failed"
[ "$fails" -eq 0 ]
