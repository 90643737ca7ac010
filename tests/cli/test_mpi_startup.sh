#!/usr/bin/env bash
# Open MPI's start-up defaults (tools/main.c, mpi_start_defaults): a
# process started without a launcher runs as an isolated singleton with
# the ob1 messaging layer, ranks on one node get ob1, and a setting in the
# environment wins over both (a component that does not exist makes
# MPI_Init fail, which shows the user's value reached Open MPI). Isolated
# singletons started together each get their own session directory, and
# leave none behind.
set -u
: "${PADAPT:?}" "${MPIEXEC:?}"
fails=0
ok()  { echo "ok   $1"; }
bad() { echo "FAIL $1"; fails=$((fails + 1)); }
unset OMPI_MCA_pml OMPI_MCA_ess_singleton_isolated

"$PADAPT" -v 2 generate box3d 2 a.mesh > log1.txt 2>&1 \
  && grep -q "MPI start-up: one process: isolated singleton, pml ob1" log1.txt \
  && ok "one process: isolated singleton with ob1" \
  || { bad "one process: defaults not set"; cat log1.txt; }

OMPI_MCA_pml=no_such_pml "$PADAPT" -v 2 generate box3d 2 b.mesh > log2.txt 2>&1 \
  && bad "one process: the user's pml was overridden" \
  || ok "one process: the user's pml reaches Open MPI"
[ ! -e b.mesh ] && ok "no output when MPI cannot start" || bad "b.mesh written"

"$MPIEXEC" -n 2 "$PADAPT" -v 2 adapt a.mesh -hsiz 0.3 -out c.mesh -nosol > log3.txt 2>&1 \
  && grep -q "MPI start-up: ranks on one node: pml ob1" log3.txt \
  && [ -s c.mesh ] \
  && ok "two ranks on one node: ob1, and the adaptation runs" \
  || { bad "two ranks: defaults or run failed"; tail -5 log3.txt; }

# 2 x 40 singletons at once: with a shared session directory 3-7 % failed
mkdir -p tmp
nfail=0
for round in 1 2; do
  for i in $(seq 40); do
    (TMPDIR=$PWD/tmp "$PADAPT" stats a.mesh > /dev/null 2> "s$i.err" || cat "s$i.err") &
  done > "round$round.txt"
  wait
  [ -s "round$round.txt" ] && nfail=$((nfail + 1)) && head -5 "round$round.txt"
done
[ "$nfail" -eq 0 ] && ok "80 concurrent singletons start" \
  || bad "concurrent singletons failed in $nfail of 2 rounds"
[ -z "$(ls -A tmp)" ] && ok "no session directory left" \
  || { bad "session directories left"; ls -A tmp | head -3; }

OMPI_MCA_pml=no_such_pml "$MPIEXEC" -n 2 "$PADAPT" generate box3d 2 d.mesh > log4.txt 2>&1 \
  && bad "two ranks: the user's pml was overridden" \
  || ok "two ranks: the user's pml reaches Open MPI"
echo "$fails failed"
[ "$fails" -eq 0 ]
