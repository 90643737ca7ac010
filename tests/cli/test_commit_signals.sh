#!/usr/bin/env bash
# The commit of a run's outputs is one agreed step, under mpiexec too. The
# test hook PADAPT_TEST_PAUSE (tools/cli.h) stops a rank at each step of its
# output transaction (pa_output_hook: written, voted, agreed, renamed,
# committed) while the test sends SIGTERM to mpiexec (which passes it to
# every process) or SIGKILL to one rank. Then:
#  - before the commit point (written, voted): the previous outputs are
#    left byte for byte, the run fails and a message says it was
#    interrupted, and after SIGTERM no temporary is left;
#  - from the commit point on (agreed, renamed, committed): a SIGTERM no
#    longer stops the commit: every output is the new one, no temporary is
#    left, a note says the outputs are complete (a run without mpiexec then
#    exits 0; Open MPI's mpiexec returns 1 whenever it was signalled);
#    SIGKILL of a rank that writes nothing leaves all outputs new or all
#    old; SIGKILL of the writer leaves its temporaries, and during its
#    renames the outputs renamed so far (the documented limit).
# Process counts 1 to 4; every step and action at 2; a distributed set at
# every step and action at 2.
set -u
: "${PADAPT:?PADAPT must point to the padapt binary}" "${MPIEXEC:?}"
# mpiexec passes SIGTERM on, then kills what is left with SIGKILL after
# odls_base_sigkill_timeout (1 s by default): on a loaded machine a process
# may not have run its handler by then, and a SIGKILL leaves temporaries.
# It also waits that long before passing SIGTERM on, and after a process
# died before it ends the others: the SIGTERM cases set 2 s, the SIGKILL
# cases keep 1 s and may leave the temporaries of the processes it kills.
fails=0
ok()  { echo "ok   $1"; }
bad() { echo "FAIL $1"; fails=$((fails + 1)); }
rm -rf ./*.tmp.* out.* set.* flag
"$PADAPT" generate box2d 8 sq.mesh > /dev/null || bad "generate"
sum() { cat "$@" 2> /dev/null | cksum; }
OUTS="out.mesh out.sol out.json"
# fresh previous outputs, whose checksums old holds
previous() {
  rm -f $OUTS
  "$PADAPT" adapt sq.mesh -hsiz 0.2 -out out.mesh -json out.json > /dev/null 2>&1 \
    || bad "previous outputs"
  old=$(sum $OUTS) old_mesh=$(sum out.mesh)
}
# run NP STEP RANK ACTION ARGS...: padapt ARGS under mpiexec -n NP (NP 0:
# without mpiexec), RANK paused at STEP, then ACTION: TERM (to mpiexec, or
# to padapt without it) or KILL (SIGKILL to the paused rank). Sets rc.
run() {
  local np=$1 step=$2 rank=$3 action=$4 pid
  shift 4
  rm -f flag err.txt
  local wait=1
  [ "$action" = TERM ] && wait=2
  if [ "$np" -gt 0 ]; then
    OMPI_MCA_odls_base_sigkill_timeout=$wait \
    PADAPT_TEST_PAUSE=$step PADAPT_TEST_PAUSE_RANK=$rank PADAPT_TEST_PAUSE_FLAG=flag \
      "$MPIEXEC" -n "$np" "$PADAPT" "$@" > /dev/null 2> err.txt &
  else
    PADAPT_TEST_PAUSE=$step PADAPT_TEST_PAUSE_FLAG=flag "$PADAPT" "$@" > /dev/null 2> err.txt &
  fi
  pid=$!
  for _ in $(seq 600); do [ -s flag ] && break; sleep 0.1; done
  if [ ! -s flag ]; then
    kill -KILL $pid 2> /dev/null; wait $pid; rc=-1; return
  fi
  if [ "$action" = TERM ]; then kill -TERM $pid; else kill -KILL "$(cat flag)"; fi
  wait $pid
  rc=$?
}
temps() { ls ./*.tmp.* 2> /dev/null | wc -l; }
interrupted() { grep -q "interrupted\|exited on signal\|Killed" err.txt; }

# case NP STEP RANK ACTION: the gathered outputs of `padapt adapt`
case_gathered() {
  local np=$1 step=$2 rank=$3 action=$4 d="np $1, $4 at $2 on rank $3"
  previous
  run "$np" "$step" "$rank" "$action" adapt sq.mesh -hsiz 0.1 -out out.mesh -json out.json
  local now nt
  now=$(sum $OUTS) nt=$(temps)
  if [ "$rc" = -1 ]; then bad "$d: the hook never paused"; return; fi
  if grep -q "AddressSanitizer\|runtime error" err.txt; then bad "$d: sanitizer report"; return; fi
  case "$step" in
    written|voted)
      if [ $rc -eq 0 ]; then bad "$d: exit status 0"
      elif [ "$now" != "$old" ]; then bad "$d: a previous output changed"
      elif [ "$action" = TERM ] && [ "$nt" -ne 0 ]; then bad "$d: $nt temporaries left"
      elif ! interrupted; then bad "$d: no message: $(head -c 300 err.txt)"
      else ok "$d: status $rc, previous outputs kept"; fi ;;
    *)
      if [ "$action" = TERM ]; then
        if [ "$now" = "$old" ]; then bad "$d: the outputs were not committed"
        elif [ "$nt" -ne 0 ]; then bad "$d: $nt temporaries left"
        elif ! grep -q "they are complete" err.txt; then bad "$d: no note: $(head -c 300 err.txt)"
        elif [ "$np" -eq 0 ] && [ $rc -ne 0 ]; then bad "$d: committed, exit status $rc"
        else ok "$d: committed (status $rc), the note printed"; fi
      elif [ "$rank" -ne 0 ]; then
        if [ "$nt" -ne 0 ]; then bad "$d: $nt temporaries left"
        elif [ "$(sum out.mesh)" = "$old_mesh" ] && [ "$now" != "$old" ]; then bad "$d: old and new outputs mixed"
        else ok "$d: status $rc, outputs all $([ "$now" = "$old" ] && echo old || echo new)"; fi
      else # the writer killed
        case "$step" in
          agreed) [ "$now" = "$old" ] && [ "$nt" -eq 3 ] \
                    && ok "$d: previous outputs kept, its 3 temporaries left" \
                    || bad "$d: outputs $([ "$now" = "$old" ] && echo kept || echo changed), $nt temporaries" ;;
          renamed) [ "$(sum out.mesh)" != "$old_mesh" ] && [ "$nt" -eq 2 ] \
                     && ok "$d: the mesh renamed, its other 2 temporaries left (the documented limit)" \
                     || bad "$d: $nt temporaries" ;;
          committed) [ "$now" != "$old" ] && [ "$nt" -eq 0 ] \
                       && ok "$d: committed" || bad "$d: not committed, $nt temporaries" ;;
        esac
      fi ;;
  esac
  rm -f ./*.tmp.*
}

for step in written voted agreed renamed committed; do
  case_gathered 0 "$step" 0 TERM
done
for step in written voted agreed renamed committed; do
  case_gathered 2 "$step" 0 TERM
  case_gathered 2 "$step" 0 KILL
  [ "$step" != renamed ] && case_gathered 2 "$step" 1 KILL # rank 1 renames nothing
done
case_gathered 1 agreed 0 TERM
for np in 1 3 4; do
  case_gathered "$np" voted 0 TERM
  case_gathered "$np" voted $((np - 1)) KILL
done

# A distributed set on 2 ranks, every rank renaming its own files (the
# rank files, rank 0 also the manifest and the ParaView files), at every
# step: SIGTERM before the commit point keeps the previous set byte for byte
# and readable, after it both ranks commit and the new set reads back;
# SIGKILL of rank 1 before the commit point keeps the previous set, after it
# (rank 0 commits, rank 1 may not) the set is readable as the new one or
# refused by its manifest, never read as a mix of two writes.
SET="set.manifest set.0.meshb set.1.meshb set.pvtu set.0.vtu set.1.vtu"
case_set() {
  local step=$1 action=$2 d="set, np 2, $2 at $1 on rank 1"
  rm -f $SET
  "$MPIEXEC" -n 2 "$PADAPT" adapt sq.mesh -hsiz 0.2 -distributed-output -out set.meshb \
    > /dev/null 2>&1 || bad "previous set"
  local prev prev0 prev1 prevm now nt reads
  prev=$(sum $SET) prev0=$(sum set.0.meshb) prev1=$(sum set.1.meshb) prevm=$(sum set.manifest)
  run 2 "$step" 1 "$action" adapt sq.mesh -hsiz 0.1 -distributed-output -out set.meshb
  now=$(sum $SET) nt=$(temps)
  "$PADAPT" stats set.meshb > stats.txt 2>&1 && reads=1 || reads=0
  if [ "$rc" = -1 ]; then bad "$d: the hook never paused"
  elif grep -q "AddressSanitizer\|runtime error" err.txt; then bad "$d: sanitizer report"
  else
    case "$step.$action" in
      written.*|voted.*)
        if [ $rc -eq 0 ]; then bad "$d: exit status 0"
        elif [ "$now" != "$prev" ]; then bad "$d: the previous set changed"
        elif [ $reads -ne 1 ]; then bad "$d: the previous set unreadable: $(head -c 300 stats.txt)"
        elif [ "$action" = TERM ] && [ "$nt" -ne 0 ]; then bad "$d: $nt temporaries left"
        elif ! interrupted; then bad "$d: no message: $(head -c 300 err.txt)"
        else ok "$d: status $rc, previous set kept and readable"; fi ;;
      *.TERM)
        if [ "$now" = "$prev" ]; then bad "$d: the set was not committed"
        elif [ "$nt" -ne 0 ]; then bad "$d: $nt temporaries left"
        elif [ $reads -ne 1 ]; then bad "$d: the new set unreadable: $(head -c 300 stats.txt)"
        elif ! grep -q "they are complete" err.txt; then bad "$d: no note: $(head -c 300 err.txt)"
        else ok "$d: new set committed and readable"; fi ;;
      *)
        local m0=0 m1=0 mm=0
        [ "$(sum set.0.meshb)" = "$prev0" ] || m0=1
        [ "$(sum set.1.meshb)" = "$prev1" ] || m1=1
        [ "$(sum set.manifest)" = "$prevm" ] || mm=1
        if [ $reads -eq 1 ] && { [ $m0 != $m1 ] || [ $m0 != $mm ]; }; then
          bad "$d: a mixed set was read (rank files changed: $m0 $m1, manifest $mm)"
        elif [ $reads -eq 1 ]; then ok "$d: status $rc, the set reads back"
        elif grep -q "manifest" stats.txt; then ok "$d: status $rc, the mixed set refused by its manifest"
        else bad "$d: unreadable set: $(head -c 300 stats.txt)"; fi ;;
    esac
  fi
  rm -f ./*.tmp.* stats.txt
}
for step in written voted agreed renamed committed; do
  case_set "$step" TERM
  case_set "$step" KILL
done
echo "$fails failed"
[ $fails -eq 0 ]
