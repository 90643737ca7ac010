#!/usr/bin/env bash
# The reintegration of the parallel loop splices a rebuilt part into the
# distributed mesh when few elements change (src/dmesh/splice.c) and
# rebuilds the whole mesh otherwise; both give the same mesh. Here the same
# adaptation runs with the default choice, with the rebuild forced
# (PADAPT_REINTEGRATE=rebuild) and with the splice forced wherever it
# applies (=splice), at 1 to 4 processes, 2D and 3D: the written mesh and
# metric must be byte-identical, and so must every file of a distributed
# output set (each rank's part, in its local numbering). With several
# processes the default run must have spliced at least once (-v 2 says
# which way each iteration went), the forced rebuild never.
set -u
: "${PADAPT:?}" "${MPIEXEC:?}" "${PADAPT_TESTDATA:?}"
fails=0
ok()  { echo "ok   $1"; }
bad() { echo "FAIL $1"; fails=$((fails + 1)); }

# The plate: one iteration meets its metric at 2 to 4 processes, so only
# the forced splice (of the whole first iteration) is exercised in 2D; the
# cube's pieces leave work for a second iteration, which the default run
# splices.
cp "$PADAPT_TESTDATA/plate2d.mesh" plate.mesh || bad "copy the 2D input"
"$PADAPT" generate box3d 10 cube.mesh > /dev/null || bad "generate 3D"

run() { # how np in hsiz out: how is default, rebuild or splice
  local how=$1 np=$2 in=$3 h=$4 out=$5
  rm -rf "$out" && mkdir -p "$out"
  if [ "$how" = default ]; then unset PADAPT_REINTEGRATE
  else export PADAPT_REINTEGRATE=$how; fi
  "$MPIEXEC" -n "$np" "$PADAPT" -v 2 adapt "$in" -hsiz "$h" -pieces 2 \
    -out "$out/out.mesh" > "$out/log" 2>&1 &&
  "$MPIEXEC" -n "$np" "$PADAPT" adapt "$in" -hsiz "$h" -pieces 2 \
    -out "$out/set.meshb" -distributed-output > "$out/log2" 2>&1
  local rc=$?
  unset PADAPT_REINTEGRATE
  return $rc
}

for np in 1 2 3 4; do
  for c in "2D plate.mesh 0.01" "3D cube.mesh 0.05"; do
    set -- $c
    name="$1 np=$np"
    for how in default rebuild splice; do
      run $how "$np" "$2" "$3" "$how" || bad "$name: $how run failed"
    done
    same=1
    for how in default splice; do
      for f in rebuild/*; do
        b=$(basename "$f")
        case $b in log*) continue ;; esac
        cmp -s "$f" "$how/$b" || { same=0; echo "  $how/$b differs"; }
      done
    done
    [ $same = 1 ] && ok "$name: identical files, default, rebuild and splice" \
      || bad "$name: the files differ"
    if [ "$np" -gt 1 ] && [ "$1" = 3D ]; then
      grep -q "reintegrate: splice" default/log \
        && ok "$name: the default run spliced" \
        || bad "$name: the default run never spliced"
    fi
    grep -q "reintegrate: records .* splice" rebuild/log \
      && bad "$name: the forced rebuild spliced" \
      || ok "$name: the forced rebuild never spliced"
  done
done
echo "$fails failed"
[ "$fails" -eq 0 ]
