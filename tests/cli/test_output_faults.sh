#!/usr/bin/env bash
# Outputs are all or nothing. A command whose outputs cannot all be written
# (-outsol or -json into a missing directory, or failing while being written
# after the mesh was; an output path that is a symbolic link, a directory or
# /dev/null; a SIGTERM or SIGINT during the adaptation or while the
# temporaries exist) exits non-zero, leaves the files previously at its
# output paths byte for byte, and leaves no temporary "*.tmp.*" behind.
set -u
: "${PADAPT:?PADAPT must point to the padapt binary}" "${MPIEXEC:?}"
fails=0
ok()  { echo "ok   $1"; }
bad() { echo "FAIL $1"; fails=$((fails + 1)); }
sum() { cksum < "$1" 2> /dev/null; }
no_temps() { ! ls ./*.tmp.* > /dev/null 2>&1; }
rm -rf ./*.tmp.* out.* new.* link.mesh dir.mesh ro hold.flag # an earlier run

"$PADAPT" generate box2d 10 sq.mesh || bad "generate"
"$PADAPT" generate box3d 10 cube.mesh || bad "generate"
# the previous outputs, which every failure below must leave as they are
"$PADAPT" adapt sq.mesh -hsiz 0.1 -out out.mesh -json out.json > /dev/null \
  || bad "first adaptation"
ref="$(sum out.mesh) $(sum out.sol) $(sum out.json)"
unchanged() { [ "$(sum out.mesh) $(sum out.sol) $(sum out.json)" = "$ref" ]; }

# check DESCRIPTION FRAGMENT RC: the last command exited with RC, non-zero
# and not a crash, printed FRAGMENT, left the previous outputs and no
# temporary, and created none of new.mesh new.sol new.json.
check() {
  local d=$1 frag=$2 rc=$3
  if [ "$rc" -eq 0 ]; then bad "$d: exit status 0"
  elif [ "$rc" -gt 128 ]; then bad "$d: crashed (status $rc): $(head -c 300 err.txt)"
  elif ! grep -qF -- "$frag" err.txt; then bad "$d: message lacks '$frag': $(head -c 300 err.txt)"
  elif grep -q "AddressSanitizer\|runtime error" err.txt; then bad "$d: sanitizer report"
  elif ! unchanged; then bad "$d: a previous output changed"
  elif ls new.mesh new.sol new.json > /dev/null 2>&1; then bad "$d: a new output was written"
  elif ! no_temps; then bad "$d: a temporary was left: $(ls ./*.tmp.*)"
  else ok "$d"; fi
}
adapt() { "$PADAPT" adapt sq.mesh -hsiz 0.05 "$@" > /dev/null 2> err.txt; }

# Outputs that cannot be written, found before the work starts.
adapt -out out.mesh -outsol nodir/out.sol; check "-outsol into a missing directory" "nodir" $?
adapt -out out.mesh -json nodir/out.json; check "-json into a missing directory" "nodir" $?
adapt -out out.mesh -outsol out.mesh; check "one path for two outputs" "out.mesh" $?
if [ "$(id -u)" != 0 ]; then # root writes anywhere
  mkdir -p ro && chmod 555 ro
  adapt -out out.mesh -json ro/out.json; check "-json into a read-only directory" "ro" $?
fi

# Outputs failing while being written, after the mesh was: the temporary
# name of the file is taken (a directory), which only the write finds.
# `exec` keeps the PID of the shell, so the name "PATH.tmp.PID" is known.
late() { # PATH, adapt arguments...
  local taken=$1; shift
  bash -c 'mkdir "$1.tmp.$$" && shift && exec "$@"' _ "$taken" \
    "$PADAPT" adapt sq.mesh -hsiz 0.05 "$@" > /dev/null 2> err.txt
  local rc=$?
  rmdir "$taken".tmp.*
  return $rc
}
late out.sol -out out.mesh -json out.json; check "-outsol failing after the mesh was written" "out.sol" $?
late out.json -out out.mesh -json out.json; check "-json failing after the mesh and metric were written" "out.json" $?
late new.json -out new.mesh -json new.json; check "-json failing, new outputs" "new.json" $?

# Output paths that exist and are not regular files.
ln -s out.mesh link.mesh
adapt -out link.mesh; check "-out a symbolic link" "symbolic link" $?
[ -L link.mesh ] || bad "the symbolic link was replaced"
adapt -out new.mesh -json /dev/null; check "-json /dev/null" "/dev/null: exists and is a character device" $?
[ -c /dev/null ] || bad "/dev/null is no longer a device"
mkdir dir.mesh
"$PADAPT" convert sq.mesh dir.mesh > /dev/null 2> err.txt; check "convert into a directory" "dir.mesh" $?

# On several ranks: the outputs are written by rank 0 after a collective
# loop; a failure is seen by every rank.
"$MPIEXEC" -n 2 "$PADAPT" adapt sq.mesh -hsiz 0.05 -out out.mesh \
  -json nodir/out.json > /dev/null 2> err.txt
check "-json into a missing directory on 2 ranks" "nodir" $?

# SIGTERM during the adaptation (about 8 s in a release build).
"$PADAPT" adapt cube.mesh -hsiz 0.03 -out out.mesh -json out.json > /dev/null 2> err.txt &
pid=$!
sleep 1
if kill -0 $pid 2> /dev/null; then
  kill -TERM $pid
  wait $pid
  rc=$?
  [ $rc -eq 143 ] && unchanged && no_temps && ok "SIGTERM during the adaptation" \
    || bad "SIGTERM during the adaptation: status $rc, previous outputs $(unchanged && echo kept || echo changed)"
else
  wait $pid
  bad "the adaptation ended before the signal: make it longer"
fi

# A signal while every temporary exists, just before the renames: the test
# hook PADAPT_TEST_PAUSE makes the CLI create hold.flag then wait.
# Background jobs of a script ignore SIGINT: the python wrapper restores
# its default action, as in an interactive shell.
for sig in TERM INT; do
  rm -f hold.flag
  PADAPT_TEST_PAUSE=written PADAPT_TEST_PAUSE_FLAG=hold.flag /usr/bin/python3 -c \
    'import os, signal, sys; signal.signal(signal.SIGINT, signal.SIG_DFL); os.execv(sys.argv[1], sys.argv[1:])' \
    "$PADAPT" adapt sq.mesh -hsiz 0.05 -out out.mesh -json out.json > /dev/null 2> err.txt &
  pid=$!
  for _ in $(seq 600); do [ -s hold.flag ] && break; sleep 0.1; done
  ntmp=$(ls ./*.tmp.* 2> /dev/null | wc -l)
  kill -$sig $pid
  wait $pid
  rc=$?
  want=$((128 + $(kill -l $sig)))
  if [ ! -e hold.flag ]; then bad "SIG$sig while writing: the hook never held"
  elif [ "$ntmp" -ne 3 ]; then bad "SIG$sig while writing: $ntmp temporaries, expected 3"
  elif [ $rc -ne $want ]; then bad "SIG$sig while writing: status $rc, expected $want"
  elif ! unchanged; then bad "SIG$sig while writing: a previous output changed"
  elif ! no_temps; then bad "SIG$sig while writing: a temporary was left"
  else ok "SIG$sig while the temporaries exist"; fi
done

# And the same outputs, written for real, replace the previous ones.
"$PADAPT" adapt sq.mesh -hsiz 0.05 -out out.mesh -json out.json > /dev/null \
  && ! unchanged && no_temps && ok "a successful run replaces the outputs" \
  || bad "a successful run did not replace the outputs"
echo "$fails failed"
[ $fails -eq 0 ]
