#!/usr/bin/env bash
# Every file of the bad-input corpus (tests/data/bad/, listed with the error
# fragment it must produce in *.expected) must make padapt fail cleanly: exit
# status != 0, a message naming the file and the fragment (line or entity),
# and no output file. Mesh files go through `padapt convert F out.mesh`;
# solution files through `padapt stats base{2,3}d.mesh -met F` (sol_3d_* use
# the 3D base mesh).
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
echo "$((n - fails)) passed, $fails failed"
[ $fails -eq 0 ]
