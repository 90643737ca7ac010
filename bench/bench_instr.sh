#!/usr/bin/env bash
# bench_instr.sh -- parallel efficiency in instructions, not seconds: the
# machine-independent view of bench_adapt.sh. Runs `padapt adapt IN -hsiz H`
# under callgrind sequentially and at P processes, and prints the
# instructions of the sequential remesher (pa_remesh, what bench_adapt.sh
# times at P = 1) against those of the parallel driver on each rank
# (pa_dmesh_adapt), with its remeshing and reintegration parts:
#
#   efficiency in instructions = I_seq / (P x max over ranks of I_rank)
#
# Instruction counts are repeatable whatever else the machine does (this
# 2-core VM's speed drifts by 20 % over minutes and two busy cores slow each
# other by 5-25 %), so this separates what the parallel code adds from what
# the machine takes. It ignores memory stalls (a rank waiting on memory
# counts nothing) and counts the polling of a rank waiting for another in
# MPI; the slowest rank, which sets the max, waits least. About 50x slower
# than a native run: keep cases small (a few seconds natively).
#
#   bash bench/bench_instr.sh [BUILD_DIR] [WORK_DIR] [IN] [H] [P]
#
# Defaults: build, /tmp/padapt-bench-instr, box2d 100 (generated) and
# H = 0.0013 (1.28 M triangles), P = 2. Needs valgrind.
set -u
BUILD=${1:-build}
WORK=${2:-/tmp/padapt-bench-instr}
IN=${3:-}
H=${4:-0.0013}
P=${5:-2}
PADAPT=${PADAPT:-$BUILD/bin/padapt}
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
export OMPI_MCA_rmaps_base_oversubscribe=1 SCOTCH_PTHREAD_NUMBER=1
MPIEXEC=${MPIEXEC:-mpiexec}

command -v valgrind >/dev/null || { echo "bench_instr: valgrind not found" >&2; exit 1; }
[ -x "$PADAPT" ] || { echo "bench_instr: $PADAPT not found (make build)" >&2; exit 1; }
mkdir -p "$WORK"
if [ -z "$IN" ]; then
  IN="$WORK/box2d.meshb"
  "$PADAPT" generate box2d 100 "$IN" || exit 1
fi
WORK=$(cd "$WORK" && pwd)
echo "# padapt instruction-count efficiency, $(date -u +%Y-%m-%dT%H:%M:%SZ)"
echo "# input $IN, -hsiz $H, $P processes; binary $PADAPT"

rm -f "$WORK"/seq.out "$WORK"/par.*.out
valgrind --tool=callgrind --callgrind-out-file="$WORK/seq.out" \
  "$PADAPT" adapt "$IN" -hsiz "$H" -out "$WORK/seq.meshb" -nosol \
  >"$WORK/seq.log" 2>&1 || { echo "sequential run failed: $WORK/seq.log"; exit 1; }
# each rank writes its own profile (Open MPI sets OMPI_COMM_WORLD_RANK)
"$MPIEXEC" -n "$P" sh -c 'exec valgrind --tool=callgrind \
  --callgrind-out-file="$0/par.$OMPI_COMM_WORLD_RANK.out" "$@"' "$WORK" \
  "$PADAPT" adapt "$IN" -hsiz "$H" -out "$WORK/par.meshb" -nosol \
  >"$WORK/par.log" 2>&1 || { echo "parallel run failed: $WORK/par.log"; exit 1; }

# inclusive instructions of one function in a profile
incl() {
  callgrind_annotate --inclusive=yes "$1" 2>/dev/null |
    awk -v f="$2" '$0 ~ ":" f " \\[" { gsub(",", "", $1); print $1; exit }'
}
mi() { awk -v n="$1" 'BEGIN { printf "%.0f M", n / 1e6 }'; }
seq=$(incl "$WORK/seq.out" pa_remesh)
echo "sequential: pa_remesh $(mi "$seq") instructions"
max=0
for ((r = 0; r < P; r++)); do
  f="$WORK/par.$r.out"
  a=$(incl "$f" pa_dmesh_adapt)
  m=$(incl "$f" pa__adapt_remesh)
  g=$(incl "$f" pa__adapt_reintegrate)
  echo "rank $r: pa_dmesh_adapt $(mi "$a"): remesh $(mi "${m:-0}"), reintegrate $(mi "${g:-0}"), the rest $(mi $((a - ${m:-0} - ${g:-0})))"
  [ "$a" -gt "$max" ] && max=$a
done
awk -v s="$seq" -v m="$max" -v p="$P" 'BEGIN {
  printf "efficiency in instructions: %.0f M / (%d x %.0f M) = %.0f %%\n", s / 1e6, p, m / 1e6, 100 * s / (p * m)
}'
