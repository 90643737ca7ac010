#!/usr/bin/env bash
# A distributed set is read back only if it is the set its manifest
# describes. Writes a set on 3 ranks over an older sequential file of the
# same name, then a set of the same name on 2 ranks (by the parallel
# adaptation): the older file and the rank-2 files are gone, the set reads
# back on 1 and 2 ranks. A stale rank file of the 3-rank set, a rank file
# with one byte changed, the manifest of the other write or a missing rank
# file are refused by a message naming the file. A write that fails on one
# rank, or is interrupted by SIGTERM while its temporaries exist, leaves the
# previous set as it was and no temporary.
set -u
: "${PADAPT:?}" "${MPIEXEC:?}"
fails=0
ok()  { echo "ok   $1"; }
bad() { echo "FAIL $1"; fails=$((fails + 1)); }
json() { /usr/bin/python3 -c "import json,sys; print(json.load(open(sys.argv[1]))[sys.argv[2]])" "$1" "$2"; }
sums() { cat set.*.meshb set.manifest | cksum; }
no_temps() { ! ls ./*.tmp.* > /dev/null 2>&1; }
rm -rf ./*.tmp.* set.* stale.* good.* away.meshb hold.flag # an earlier run

# refused DESCRIPTION FILE FRAGMENT COMMAND...: fails, names FILE and FRAGMENT.
refused() {
  local d=$1 file=$2 frag=$3; shift 3
  if timeout 120 "$@" > out.txt 2>&1; then bad "$d: accepted"
  elif ! grep -qF -- "$file" out.txt || ! grep -qF -- "$frag" out.txt; then
    bad "$d: message lacks '$file' or '$frag': $(grep padapt: out.txt | head -2)"
  else ok "$d: $(grep -m1 padapt: out.txt)"; fi
}

"$PADAPT" generate box3d 5 cube.mesh || bad "generate"
"$PADAPT" generate box2d 4 sq.mesh || bad "generate"
"$PADAPT" convert sq.mesh set.meshb || bad "older sequential set.meshb"
"$MPIEXEC" -n 3 "$PADAPT" partition cube.mesh -out set.meshb > out.txt 2>&1 \
  && ok "set written on 3 ranks" || { bad "partition on 3 ranks"; cat out.txt; }
[ ! -e set.meshb ] && ok "the older set.meshb is removed" || bad "set.meshb still shadows the set"
cp set.1.meshb stale.1.meshb
cp set.manifest stale.manifest
"$MPIEXEC" -n 2 "$PADAPT" adapt cube.mesh -hsiz 0.25 -out set.meshb -distributed-output \
  -json a.json > out.txt 2>&1 && ok "set written on 2 ranks" || { bad "adapt on 2 ranks"; cat out.txt; }
[ ! -e set.2.meshb ] && [ ! -e set.2.vtu ] && grep -qx "ranks 2" set.manifest \
  && ok "rank 2 files of the 3-rank set removed" || bad "stale rank 2 files or manifest"
"$PADAPT" stats set.meshb -json s.json > /dev/null 2> out.txt \
  && [ "$(json s.json elements)" = "$(json a.json elements)" ] \
  && ok "read back on 1 rank" || bad "read back on 1 rank: $(head -2 out.txt)"
ref=$(sums)

cp set.1.meshb good.1.meshb
cp stale.1.meshb set.1.meshb
refused "stale rank file, 1 rank" set.1.meshb "manifest" "$PADAPT" stats set.meshb
refused "stale rank file, 2 ranks" set.1.meshb "manifest" "$MPIEXEC" -n 2 "$PADAPT" stats set.meshb
cp good.1.meshb set.1.meshb
/usr/bin/python3 -c "
f = open('set.1.meshb', 'r+b'); f.seek(200); b = f.read(1); f.seek(200); f.write(bytes([b[0] ^ 1]))"
refused "one byte changed" set.1.meshb "checksum" "$PADAPT" convert set.meshb g.mesh
cp good.1.meshb set.1.meshb
cp set.manifest good.manifest
cp stale.manifest set.manifest
refused "manifest of another write" set.0.meshb "manifest" "$PADAPT" stats set.meshb
cp good.manifest set.manifest
mv set.1.meshb away.meshb
refused "missing rank file" set.1.meshb "missing" "$PADAPT" stats set.meshb
mv away.meshb set.1.meshb
[ "$(sums)" = "$ref" ] && "$PADAPT" stats set.meshb > /dev/null 2>&1 \
  && ok "restored set reads" || bad "restored set"

# A write that fails on rank 1 (its .vtu path is a directory) writes nothing.
rm set.1.vtu && mkdir set.1.vtu
refused "write failing on rank 1" set.1.vtu "directory" \
  "$MPIEXEC" -n 2 "$PADAPT" partition cube.mesh -out set.meshb
[ "$(sums)" = "$ref" ] && no_temps && ok "failed write: previous set kept, no temporary" \
  || bad "failed write changed the set or left temporaries: $(ls)"
rmdir set.1.vtu

# SIGTERM while every rank's temporaries exist (test hook, see tools/cli.h).
# mpiexec forwards the signal, then kills the ranks after
# odls_base_sigkill_timeout (1 s by default): on a loaded machine a rank may
# not have run its handler by then (a SIGKILL leaves temporaries behind).
export OMPI_MCA_odls_base_sigkill_timeout=20
rm -f hold.flag
PADAPT_TEST_PAUSE=written PADAPT_TEST_PAUSE_FLAG=hold.flag "$MPIEXEC" -n 2 \
  "$PADAPT" partition cube.mesh -out set.meshb > out.txt 2>&1 &
pid=$!
for _ in $(seq 600); do [ -s hold.flag ] && break; sleep 0.1; done
sleep 0.5 # rank 1 has written its files too
ntmp=$(ls ./*.tmp.* 2> /dev/null | wc -l)
kill -TERM $pid
wait $pid
rc=$?
if [ ! -e hold.flag ]; then bad "SIGTERM: the hook never held"
elif [ "$ntmp" -lt 6 ]; then bad "SIGTERM: $ntmp temporaries, expected 6"
elif [ $rc -eq 0 ]; then bad "SIGTERM: exit status 0"
elif [ "$(sums)" != "$ref" ]; then bad "SIGTERM: the previous set changed"
elif ! no_temps; then bad "SIGTERM: temporaries left: $(ls ./*.tmp.*)"
else ok "SIGTERM during a distributed write: previous set kept, no temporary"; fi
echo "$fails failed"
[ $fails -eq 0 ]
