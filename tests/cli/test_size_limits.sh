#!/usr/bin/env bash
# A metric whose output would not fit in memory is refused before any work
# (issue #19): the unit cube at -hsiz 0.001 (about 8.5e9 tetrahedra), a .sol
# with a size of 1e-300 at one vertex, and a size that fits the machine but
# not -mem, sequentially and on 2 processes. Each must exit non-zero within
# seconds with a message giving the estimate and the bound, write nothing,
# and leave a previous output untouched; a size that fits still adapts.
set -u
: "${PADAPT:?PADAPT must point to the padapt binary}"
MPIEXEC=${MPIEXEC:-mpiexec}
fails=0
fail() { echo "FAIL $*"; fails=$((fails + 1)); }

"$PADAPT" generate box3d 4 cube.mesh > /dev/null || exit 1
# a scalar size per vertex, 0.2 everywhere but 1e-300 at vertex 7
nv=$(awk '/^ *Vertices/ {getline; print $1; exit}' cube.mesh)
{
  printf 'MeshVersionFormatted 2\nDimension 3\nSolAtVertices\n%d\n1 1\n' "$nv"
  for i in $(seq 1 "$nv"); do
    if [ "$i" -eq 7 ]; then echo 1e-300; else echo 0.2; fi
  done
  echo End
} > tiny.sol
echo "previous" > out.mesh
before=$(md5sum out.mesh)

refused() { # name fragment command...
  local name=$1 frag=$2; shift 2
  local t0=$SECONDS
  "$@" > log.txt 2>&1
  local rc=$?
  if [ $rc -eq 0 ]; then fail "$name: exit status 0"
  elif [ $rc -gt 128 ]; then fail "$name: crashed ($rc)"
  elif ! grep -q "asks for about\|unbounded number" log.txt; then
    fail "$name: no estimate in the message: $(grep -m2 padapt: log.txt)"
  elif ! grep -qF -- "$frag" log.txt; then
    fail "$name: the message does not name '$frag': $(grep -m1 'padapt:' log.txt)"
  elif [ "$(md5sum out.mesh)" != "$before" ] || ls out.mesh.tmp.* out.sol > /dev/null 2>&1; then
    fail "$name: an output was written"
  elif [ $((SECONDS - t0)) -gt 60 ]; then fail "$name: took $((SECONDS - t0)) s"
  else echo "ok   $name: $(grep -m1 -o 'asks for about [^:]*' log.txt)"
  fi
}

refused "seq -hsiz 0.001" "available memory" \
  "$PADAPT" adapt cube.mesh -hsiz 0.001 -out out.mesh
refused "seq size 1e-300" "tetrahedra" \
  "$PADAPT" adapt cube.mesh -met tiny.sol -out out.mesh
refused "np2 -hsiz 0.001" "available memory" \
  "$MPIEXEC" -n 2 "$PADAPT" adapt cube.mesh -hsiz 0.001 -out out.mesh
refused "np2 -mem 5" "-mem 5" \
  "$MPIEXEC" -n 2 "$PADAPT" adapt cube.mesh -hsiz 0.05 -mem 5 -out out.mesh

if "$PADAPT" adapt cube.mesh -hsiz 0.2 -out fits.mesh > log.txt 2>&1 && [ -s fits.mesh ]; then
  echo "ok   a size that fits adapts"
else
  fail "a size that fits: $(tail -2 log.txt)"
fi
[ $fails -eq 0 ] && echo "all checks passed" || { echo "$fails check(s) failed"; exit 1; }
