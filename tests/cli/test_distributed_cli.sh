#!/usr/bin/env bash
# Distributed sets through the CLI: `padapt partition` on 3 ranks writes
# OUT.<r>.meshb + OUT.pvtu; every command that reads a mesh accepts the set,
# on any number of ranks, and gets the original mesh back.
set -u
: "${PADAPT:?}" "${MPIEXEC:?}"
fails=0
ok()  { echo "ok   $1"; }
bad() { echo "FAIL $1"; fails=$((fails + 1)); }
json() { /usr/bin/python3 -c "import json,sys; print(json.load(open(sys.argv[1]))[sys.argv[2]])" "$1" "$2"; }

"$PADAPT" generate box3d 6 cube.mesh || bad "generate"
"$PADAPT" stats cube.mesh -json ref.json > /dev/null || bad "stats of the input"
"$MPIEXEC" -n 3 "$PADAPT" partition cube.mesh -out part.meshb -overlap 1 > part.txt 2>&1 \
  && ok "partition on 3 ranks" || { bad "partition"; cat part.txt; }
for r in 0 1 2; do [ -s part.$r.meshb ] || bad "missing part.$r.meshb"; done
[ -s part.pvtu ] && ok "pvtu written" || bad "no part.pvtu"
grep -qi "imbalance" part.txt && ok "partition report" || bad "no imbalance in the report"
for np in 1 2 4; do
  rm -f s.json g.mesh
  "$MPIEXEC" -n $np "$PADAPT" stats part.meshb -json s.json > /dev/null 2>&1 \
    && [ "$(json s.json elements)" = "$(json ref.json elements)" ] \
    && [ "$(json s.json vertices)" = "$(json ref.json vertices)" ] \
    && [ "$(json s.json volume)" = "$(json ref.json volume)" ] \
    && ok "stats of the set on $np ranks" || bad "stats of the set on $np ranks"
  "$MPIEXEC" -n $np "$PADAPT" convert part.meshb g.mesh > /dev/null 2>&1 \
    && "$PADAPT" stats g.mesh -json g.json > /dev/null \
    && [ "$(json g.json elements)" = "$(json ref.json elements)" ] \
    && [ "$(json g.json boundary)" = "$(json ref.json boundary)" ] \
    && ok "convert the set on $np ranks" || bad "convert the set on $np ranks"
done
# A missing rank file is a clear error on every rank count, never a hang.
rm -f part.1.meshb
for np in 1 3; do
  if timeout 60 "$MPIEXEC" -n $np "$PADAPT" stats part.meshb > out.txt 2>&1; then
    bad "missing rank file accepted on $np ranks"
  elif grep -q "part.1.meshb" out.txt; then ok "missing rank file named ($np ranks)"
  else bad "missing rank file: $(head -3 out.txt)"; fi
done
echo "$fails failed"
[ $fails -eq 0 ]
