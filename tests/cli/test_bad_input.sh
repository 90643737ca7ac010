#!/usr/bin/env bash
# Every file of the bad-input corpus (tests/data/bad/, listed with the error
# fragment it must produce in *.expected) must make padapt fail cleanly: exit
# status != 0, a message naming the file and the fragment (line or entity),
# and no output file. Mesh files go through `padapt convert F out.mesh`;
# solution files through `padapt stats base{2,3}d.mesh -met F` (sol_3d_* use
# the 3D base mesh).
#
# Then outputs that are inputs: a command given an output path that resolves
# to one of its input files (the same path, another spelling, a hard or
# symbolic link, a file derived from OUT such as OUT.sol, a file of a
# distributed set), or two outputs that resolve to one file, must fail before
# any work with a message saying so, and leave every file as it was. Last,
# meshes with a duplicated or folded element given to `adapt` (at 1 to 4
# processes) and `stats`: refused the same way, never a crash.
set -u
: "${PADAPT:?PADAPT must point to the padapt binary}"
bad="${PADAPT_TESTDATA:?}/bad"
fails=0; n=0
shopt -s nullglob
for list in "$bad"/*.expected; do
  while IFS=$'\t' read -r file fragment; do
    [ -z "$file" ] && continue
    case "$file" in \#*) continue ;; esac
    n=$((n + 1))
    rm -f out.mesh out.mesh.tmp.* err.txt
    case "$file" in
      *.sol|*.solb)
        base="$bad/base2d.mesh"; case "$file" in sol_3d_*) base="$bad/base3d.mesh" ;; esac
        "$PADAPT" stats "$base" -met "$bad/$file" -json out.mesh > /dev/null 2> err.txt ;;
      *)
        "$PADAPT" convert "$bad/$file" out.mesh > /dev/null 2> err.txt ;;
    esac
    rc=$?
    msg=$(head -c 2000 err.txt)
    if [ $rc -eq 0 ]; then
      echo "FAIL $file: exit status 0"; fails=$((fails + 1))
    elif [ $rc -gt 128 ]; then
      echo "FAIL $file: crashed (status $rc): $msg"; fails=$((fails + 1))
    elif ! grep -qF -- "$file" err.txt; then
      echo "FAIL $file: message does not name the file: $msg"; fails=$((fails + 1))
    elif ! grep -qF -- "$fragment" err.txt; then
      echo "FAIL $file: message lacks '$fragment': $msg"; fails=$((fails + 1))
    elif ls out.mesh out.mesh.tmp.* > /dev/null 2>&1; then
      echo "FAIL $file: an output file was left behind"; fails=$((fails + 1))
    elif grep -q "AddressSanitizer\|runtime error" err.txt; then
      echo "FAIL $file: sanitizer report: $msg"; fails=$((fails + 1))
    else
      echo "ok   $file: $(head -n 1 err.txt)"
    fi
  done < "$list"
done
if [ $n -lt 10 ]; then echo "FAIL: only $n corpus entries found"; fails=$((fails + 1)); fi

# ---- outputs that are inputs ----
: "${MPIEXEC:?MPIEXEC must point to mpiexec}"
rm -rf io && mkdir io && cd io || exit 1
"$PADAPT" generate box2d 4 sq.mesh > /dev/null
"$PADAPT" metric uniform:0.3 sq.mesh m.sol > /dev/null
cp m.sol f.sol
ln sq.mesh hard.mesh
ln -s sq.mesh link.mesh
ln m.sol hard.svg
mkdir sub ck
printf 'parameters\n0\n' > p.padapt
"$PADAPT" partition sq.mesh -out set.meshb > /dev/null
cp sq.mesh ck/iter-1.mesh
snapshot() { find . -type f -o -type l | LC_ALL=C sort | while read -r f; do
  printf '%s %s\n' "$f" "$(cksum < "$f")"; done; }
before=$(snapshot)
# refused FRAGMENT NP ARGS...: padapt ARGS (under mpiexec -n NP when NP > 0)
refused() {
  local frag=$1 np=$2; shift 2
  n=$((n + 1))
  if [ "$np" -gt 0 ]; then
    "$MPIEXEC" -n "$np" "$PADAPT" "$@" > /dev/null 2> err.txt
  else
    "$PADAPT" "$@" > /dev/null 2> err.txt
  fi
  local rc=$? msg
  msg=$(grep -m 1 padapt: err.txt)
  rm -f err.txt
  local after
  after=$(snapshot)
  [ $rc -ne 0 ] || before=$after
  if [ $rc -eq 0 ]; then
    echo "FAIL [np $np] $*: exit status 0"; fails=$((fails + 1))
  elif [ $rc -gt 128 ]; then
    echo "FAIL [np $np] $*: crashed (status $rc): $msg"; fails=$((fails + 1))
  elif ! printf '%s' "$msg" | grep -qF -- "$frag"; then
    echo "FAIL [np $np] $*: message lacks '$frag': $msg"; fails=$((fails + 1))
  elif [ "$after" != "$before" ]; then
    echo "FAIL [np $np] $*: files changed:"; diff <(echo "$before") <(echo "$after")
    fails=$((fails + 1)); before=$after
  else
    echo "ok   [np $np] $*: $msg"
  fi
}
is_in="(the same file): refusing to overwrite an input"
same="are the same file"
refused "$is_in" 0 adapt sq.mesh -hsiz 0.3 -out a.mesh -json sq.mesh
refused "$is_in" 0 adapt sq.mesh -hsiz 0.3 -out ./sq.mesh
refused "$is_in" 0 adapt sq.mesh -hsiz 0.3 -out sub/../sq.mesh
refused "$is_in" 0 adapt sq.mesh -hsiz 0.3 -out hard.mesh
refused "$is_in" 0 adapt link.mesh -hsiz 0.3 -out sq.mesh
refused "$is_in" 0 adapt sq.mesh -met m.sol -out m.mesh
refused "$is_in" 0 adapt sq.mesh -met m.sol -out o.mesh -outsol ./m.sol
refused "$is_in" 0 adapt sq.mesh -hsiz 0.3 -field f.sol -out o.mesh -outfield ./f.sol
refused "$is_in" 0 adapt sq.mesh -hsiz 0.3 -out o.mesh -f p.padapt -json p.padapt
refused "$same" 0 adapt sq.mesh -hsiz 0.3 -out o.mesh -json ./o.sol
refused "$same" 0 adapt sq.mesh -hsiz 0.3 -out o.mesh -json sub/../o.mesh
refused "$is_in" 0 adapt set.meshb -hsiz 0.3 -distributed-output -out set.meshb
refused "$is_in" 0 adapt set.meshb -hsiz 0.3 -out set.0.meshb
refused "in the checkpoint directory" 0 adapt ck/iter-1.mesh -hsiz 0.3 -out o.mesh -checkpoint ck
refused "$is_in" 0 partition sq.mesh -out sq.mesh
refused "$is_in" 0 stats sq.mesh -json sq.mesh
refused "$is_in" 0 stats sq.mesh -met m.sol -json ./m.sol
refused "$is_in" 0 convert sq.mesh hard.mesh
refused "$is_in" 0 metric uniform:0.2 sq.mesh ./sq.mesh
refused "$is_in" 0 metric intersect sq.mesh m.sol f.sol m.sol
refused "$is_in" 0 metric hessian sq.mesh -field f.sol -target 50 f.sol
refused "$is_in" 0 levelset sphere:0.3 link.mesh hard.mesh
refused "$is_in" 0 plot sq.mesh hard.svg -met m.sol
refused "$is_in" 2 adapt sq.mesh -hsiz 0.3 -out a.mesh -json sq.mesh
refused "$is_in" 2 adapt set.meshb -hsiz 0.3 -distributed-output -out ./set.meshb
refused "$same" 3 adapt sq.mesh -hsiz 0.3 -out o.mesh -json o.sol
refused "$is_in" 4 metric hessian sq.mesh -field f.sol -target 50 ./f.sol

# ---- meshes the remeshers crashed on, given to adapt and stats ----
# `padapt adapt` of a tetrahedron listed twice segfaulted, and `padapt
# stats` called it valid; folded elements reached the remeshers too.
for np in 0 1 2 3 4; do
  refused "elements 1 and 2 have the same vertices" $np adapt "$bad/check_dup3d.mesh" -hsiz 0.3 -out o.mesh
done
for np in 0 2; do
  refused "elements 1 and 2 have the same vertices" $np adapt "$bad/check_dup2d.mesh" -hsiz 0.3 -out o.mesh
  refused "elements 1 and 2 overlap" $np adapt "$bad/check_fold_face3d.mesh" -hsiz 0.3 -out o.mesh
  refused "around vertex 1 turn 2 times" $np adapt "$bad/check_fold_vertex2d.mesh" -hsiz 0.3 -out o.mesh
done
refused "elements 1 and 2 have the same vertices" 0 stats "$bad/check_dup3d.mesh"
# the one exception to "no output on failure" (outputs.md): the report of
# stats, whose verdict is that the mesh is invalid
n=$((n + 1))
"$PADAPT" stats "$bad/check_dup3d.mesh" -json rep.json > /dev/null 2>&1
rc=$?
if [ $rc -eq 1 ] && grep -q '"valid": false' rep.json; then
  echo "ok   stats -json of an invalid mesh: status 1, the report says invalid"
else
  echo "FAIL stats -json of an invalid mesh: status $rc, report: $(head -c 200 rep.json 2>&1)"
  fails=$((fails + 1))
fi
rm -f rep.json
cd ..
echo "$((n - fails)) passed, $fails failed"
[ $fails -eq 0 ]
