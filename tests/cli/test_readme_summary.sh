#!/usr/bin/env bash
# The command line summary of README.md runs as written, in order, in an
# empty directory: every file a command reads is one an earlier command
# made (it used a u.sol that no command makes), and every command succeeds.
set -u
: "${PADAPT:?PADAPT must point to the padapt binary}" "${MPIEXEC:?}" "${PADAPT_SRC:?}"
rm -rf summary && mkdir summary && cd summary || exit 1
# the first ```sh block after the heading; padapt and mpiexec as built here
sed -n '/^## Command line summary/,$p' "$PADAPT_SRC/README.md" |
  sed -n '/^```sh/,/^```$/p' | sed '1d;$d' > summary.sh
n=$(grep -c . summary.sh)
if [ "$n" -lt 10 ]; then echo "FAIL: the summary has $n commands"; exit 1; fi
fails=0
while IFS= read -r line; do
  cmd=${line%%#*} # the comment
  [ -z "${cmd// /}" ] && continue
  set -- $cmd
  case "$1" in
    padapt) shift; "$PADAPT" "$@" > out.txt 2>&1 ;;
    mpiexec) np=$3; shift 4; "$MPIEXEC" -n "$np" "$PADAPT" "$@" > out.txt 2>&1 ;;
    *) echo "FAIL: not a padapt command: $line"; fails=$((fails + 1)); continue ;;
  esac
  if [ $? -eq 0 ]; then echo "ok   $cmd"
  else echo "FAIL $cmd: $(grep -m 2 padapt: out.txt)"; fails=$((fails + 1)); fi
done < summary.sh
echo "$fails failed"
[ $fails -eq 0 ]
