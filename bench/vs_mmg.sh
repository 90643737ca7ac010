#!/usr/bin/env bash
# vs_mmg.sh -- padapt side by side with Mmg on uniform refinements, and the
# small-job parallel efficiency.
#
#   bash bench/vs_mmg.sh BUILD_DIR WORK_DIR [CASE...]
#
# CASE: kuhn (box3d 10, the Kuhn-subdivided unit cube of 6 000 tets ->
# -hsiz 0.03), rod (tests/data/rod3d.mesh -> 0.03), plate
# (tests/data/plate2d.mesh -> 0.002, 2D), plateh (the plate -> 0.003 with
# -hausd 0.0005), small (no Mmg: box3d 10 -> 0.05, about a second
# sequential, at 1 and 2 processes). Default: all five.
#
# For each remeshing case, PAIRS (default 3) back-to-back runs of padapt and
# of mmg3d/mmg2d (when on PATH; skipped otherwise), both with -hsiz and
# their defaults; per run the wall time of the whole command and its peak
# RSS (/usr/bin/time), the output elements, and both outputs judged the
# same way: `padapt stats` in the uniform metric of the case (edges in
# [0.7071, 1.4142), worst and mean quality), the count beside the metric's
# ideal one (volume over the regular simplex of edge h). The lines give the
# medians, then padapt's time over Mmg's, its element count over Mmg's and
# its elements per second over Mmg's, side by side. For `small`, PAIRS pairs of
# `padapt adapt` at 1 then 2 processes, and the median efficiency
# T1 / (2 T2) twice: on the wall clock of the whole command, and on the
# command's own time (`padapt -v 1` prints it: from the end of MPI_Init to
# the outputs written, on rank 0), which leaves out the start and end of
# MPI -- about 0.4 s on one process (a singleton still starts Open MPI's
# runtime) and 0.5 s with mpiexec -n 2, as much as half of the small job's
# work, the same whatever padapt does. Then the speed of each core: the
# same sequential job pinned to core 0 and to core 1 (taskset), and the cap
# that puts on the efficiency (a virtual machine's cores can differ: on the
# 2-core VM of docs/BENCHMARKS.md by up to 1.5x, changing over minutes).
# Wall clock: meaningful on a quiet machine only (the load is printed first).
set -u
BUILD=${1:?BUILD_DIR}
WORK=${2:?WORK_DIR}
shift 2
CASES=${*:-kuhn rod plate plateh small}
PAIRS=${PAIRS:-3}
PADAPT=$(cd "$BUILD" && pwd)/bin/padapt
ROOT=$(cd "$(dirname "$0")/.." && pwd)
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
export OMPI_MCA_rmaps_base_oversubscribe=1 SCOTCH_PTHREAD_NUMBER=1
mkdir -p "$WORK"
cd "$WORK" || exit 1
echo "# vs_mmg: $(date -u +%Y-%m-%dT%H:%M:%SZ), repo $(git -C "$ROOT" rev-parse --short HEAD)"
echo "# host: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //'); load $(cut -d' ' -f1-3 /proc/loadavg)"

median() { sort -g | awk '{a[NR] = $1} END {print (NR % 2) ? a[(NR + 1) / 2] : (a[NR / 2] + a[NR / 2 + 1]) / 2}'; }
# "elements in-range% worstQ meanQ ideal" of mesh $1 in the uniform metric
# $2; ideal: the metric's ideal count, the volume over the regular
# simplex of edge $2 (sqrt(3)/4 h^2, sqrt(2)/12 h^3)
judge() {
  "$PADAPT" metric "uniform:$2" "$1" judge.sol > /dev/null 2>&1
  "$PADAPT" stats "$1" -met judge.sol -json judge.json > /dev/null 2>&1
  /usr/bin/python3 -c "import json, math; j = json.load(open('judge.json')); h = $2
unit = math.sqrt(3) / 4 * h * h if j['dim'] == 2 else math.sqrt(2) / 12 * h ** 3
print(j['elements'], round(100 * j['edge_in_range'], 2), round(j['quality_worst'], 3), round(j['quality_mean'], 3), round(j['volume'] / unit))"
}
# wall seconds and peak RSS (MB) of a command (its stderr in $LOG if set)
timed() {
  /usr/bin/time -f "%e %M" -o t.txt "$@" > /dev/null 2> "${LOG:-/dev/null}"
  awk '{printf "%s %.0f", $1, $2 / 1024}' t.txt
}
# the command's own seconds of a `padapt -v 1` run, from its stderr in $1
own() { sed -n 's/^padapt: MPI start .* s, command \([0-9.]*\) s,.*/\1/p' "$1"; }

# side_by_side NAME IN H MMG [OPTION...]: padapt and MMG on IN with -hsiz H
# and the options (both tools take them; $MMG_ONLY: Mmg's alone)
side_by_side() {
  local name=$1 in=$2 h=$3 mmg=$4
  shift 4 # the rest: options of both tools
  local p m
  : > p.txt
  : > m.txt
  for i in $(seq "$PAIRS"); do
    echo "$(timed "$PADAPT" adapt "$in" -hsiz "$h" "$@" -out p.mesh -nosol -v -1) $(judge p.mesh "$h")" >> p.txt
    if command -v "$mmg" > /dev/null; then
      rm -f m.mesh m.sol
      # shellcheck disable=SC2086
      echo "$(timed "$mmg" "$in" -hsiz "$h" "$@" -out m.mesh -v -1 ${MMG_ONLY:-}) $(judge m.mesh "$h")" >> m.txt
    fi
  done
  row() { # file -> "median_time rss elements inrange worst mean ideal"
    echo "$(cut -d' ' -f1 "$1" | median) $(tail -1 "$1" | cut -d' ' -f2-)"
  }
  line() { # tool row -> the tool's line, its count beside the ideal one
    awk -v n="$name" -v t="$1" -v r="$2" 'BEGIN { split(r, a, " ");
      printf "%-6s %s: %s s, RSS %s MB, %s elements (%.3f x the ideal %s), %s %% in range, worst Q %s, mean Q %s\n",
        n, t, a[1], a[2], a[3], a[3] / a[7], a[7], a[4], a[5], a[6] }'
  }
  p=$(row p.txt)
  line padapt "$p"
  if [ -s m.txt ]; then
    m=$(row m.txt)
    line "$mmg" "$m"
    # the time ratio and the element-count ratio beside the speed ratio:
    # a speed figure never hides a density difference
    awk -v p="$p" -v m="$m" 'BEGIN { split(p, a, " "); split(m, b, " ");
      printf "%-6s padapt / %s: time %.3f (%s %.2f times longer), elements %.3f, elements per second %.2f (times %s)\n",
        "'"$name"'", "'"$mmg"'", a[1] / b[1], "'"$mmg"'", b[1] / a[1], a[3] / b[3],
        (a[3] / a[1]) / (b[3] / b[1]), "'"$(cut -d' ' -f1 p.txt | tr '\n' ' ')"'/ '"$(cut -d' ' -f1 m.txt | tr '\n' ' ')"'" }'
  else
    echo "$name   $mmg not on PATH: no side-by-side"
  fi
}

for c in $CASES; do
  case $c in
    kuhn) "$PADAPT" generate box3d 10 kuhn.mesh > /dev/null
          side_by_side kuhn kuhn.mesh 0.03 mmg3d ;;
    rod) side_by_side rod "$ROOT/tests/data/rod3d.mesh" 0.03 mmg3d ;;
    # the plate is written with Dimension 3 (gmsh): mmg2d reads it so with
    # -3dMedit 3 and writes a 2D mesh
    plate) MMG_ONLY="-3dMedit 3" side_by_side plate "$ROOT/tests/data/plate2d.mesh" 0.002 mmg2d ;;
    # the same plate at the size and Hausdorff distance of issue #39
    plateh) MMG_ONLY="-3dMedit 3" side_by_side plateh "$ROOT/tests/data/plate2d.mesh" 0.003 mmg2d -hausd 0.0005 ;;
    small)
      "$PADAPT" generate box3d 10 small.mesh > /dev/null
      : > e.txt; rm -f cpu0.txt cpu1.txt
      for i in $(seq "$PAIRS"); do
        t1=$(LOG=l1.txt timed "$PADAPT" -v 1 adapt small.mesh -hsiz 0.05 -out s1.mesh -nosol -v -1 | cut -d' ' -f1)
        t2=$(LOG=l2.txt timed mpiexec -n 2 "$PADAPT" -v 1 adapt small.mesh -hsiz 0.05 -out s2.mesh -nosol -v -1 | cut -d' ' -f1)
        echo "$t1 $t2 $(own l1.txt) $(own l2.txt)" |
          awk '{print $1 / (2 * $2), $1, $2, $3 / (2 * $4), $3, $4}' >> e.txt
        if command -v taskset > /dev/null; then
          for cpu in 0 1; do
            LOG=l1.txt timed taskset -c $cpu "$PADAPT" -v 1 adapt small.mesh -hsiz 0.05 -out s1.mesh -nosol -v -1 > /dev/null
            own l1.txt >> "cpu$cpu.txt"
          done
        fi
      done
      echo "small  box3d 10 -> 0.05, $(judge s1.mesh 0.05 | cut -d' ' -f1) / $(judge s2.mesh 0.05 | cut -d' ' -f1) elements:" \
           "median efficiency T1/(2 T2) $(cut -d' ' -f1 e.txt | median) wall," \
           "$(cut -d' ' -f4 e.txt | median) on the command's own time" \
           "(T1/T2 pairs, wall: $(awk '{printf "%s/%s ", $2, $3}' e.txt); own: $(awk '{printf "%s/%s ", $5, $6}' e.txt | sed 's/ $//'))"
      if [ -s cpu0.txt ] && [ -s cpu1.txt ]; then
        # mpiexec -n 2 binds rank r to core r: with the job cut in two
        # equal halves, T2 >= max(a, b) / 2, so T1 / (2 T2) <= T1 / max(a, b)
        a=$(median < cpu0.txt) b=$(median < cpu1.txt)
        t1=$(cut -d' ' -f5 e.txt | median)
        echo "small  the two cores: T1 pinned to core 0 / core 1 (own, median) $a / $b s;" \
             "equal halves cap the efficiency at T1 / max = $(awk -v t="$t1" -v a="$a" -v b="$b" 'BEGIN { printf "%.3f", t / (a > b ? a : b) }')"
      fi
      rm -f cpu0.txt cpu1.txt ;;
    *) echo "unknown case $c" ;;
  esac
done
