#!/usr/bin/env bash
# efficiency.sh -- the parallel loop's efficiency and work (issue: the seed
# paper's open problem, "a better distribution of the remeshing workload").
#
#   bash bench/efficiency.sh BUILD_DIR WORK_DIR [PART...]
#
# PART (default: time work weak); TIME_JOBS (default "rod plate plate1s
# cube") picks the jobs of the time part.
#   time  PAIRS (default 3) interleaved pairs of `padapt adapt` at 1 then 2
#         processes on four jobs: the gmsh rod (tests/data/rod3d.mesh ->
#         -hsiz 0.03, ~0.8 M tets, ~7 s), the gmsh plate of similar duration
#         (2D, tests/data/plate2d.mesh -> -hsiz 0.0005, ~6 M triangles), the
#         1-second plate (-hsiz 0.0012, ~1.2 M triangles) and the 1-second
#         Kuhn cube (box3d 10 -> 0.05). Per job the medians at np=1 and
#         np=2 of the whole command's wall time and of the adaptation's own
#         time ("time_s" of the -json report, without Open MPI's start and
#         end, ~0.45 s, and without the measurement of the result: a
#         sequential time_s leaves it out, a parallel one holds it as
#         steps_s.measure, subtracted here), and the median efficiencies
#         T1 / (2 T2) of both over the pairs. Wall clock: meaningful on a quiet machine only (the
#         load is printed first).
#   work  the remeshing work -- the remesher's CPU time summed over the
#         ranks, "remesh_cpu_s" of the -json report -- on the rod and on the
#         6 M-triangle plate at np 1, 2, 4 and 8 (oversubscribed), its ratio
#         to the sequential work, the iterations and the work of each,
#         elements and worst quality; then what sharing the cores adds to
#         the CPU time of a rank (np ranks on 2 cores switch in turn and
#         refill each other's caches): np copies of the sequential job of
#         a rank's size (N / np elements: -hsiz x np^(1/dim)) run at once,
#         their CPU per element over that of one such run alone, and the
#         work ratio over that factor; and the remesher's operation counts
#         (splits, collapses, swaps, moves) over np=1's, which the machine
#         does not change.
#   weak  the rod refined to N = np x 2 M tets at np 1 and WEAK_NPS
#         (default 2 4 8; -distributed-output, deleted after each run):
#         remeshing work per output tet (microseconds), its ratio to np=1's
#         and to the sequential run of the same N (the sequential cost per
#         tet moves with N), and what sharing the cores adds: np copies of
#         the np=1 job run at once, their CPU per tet over that of one run
#         alone (the np ranks of an oversubscribed run share the cores and
#         caches the same way), and the ratio to the same-size sequential
#         run divided by that factor; the operation counts over the
#         same-size sequential run's; the iterations.
# Every -json report is kept in WORK_DIR (time-*, work-np*, weak-np*.json):
# bench/time_model.py reads them.
set -u
BUILD=${1:?BUILD_DIR}
WORK=${2:?WORK_DIR}
shift 2
PARTS=${*:-time work weak}
PAIRS=${PAIRS:-3}
PADAPT=$(cd "$BUILD" && pwd)/bin/padapt
ROOT=$(cd "$(dirname "$0")/.." && pwd)
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
export OMPI_MCA_rmaps_base_oversubscribe=1 SCOTCH_PTHREAD_NUMBER=1
mkdir -p "$WORK"
cd "$WORK" || exit 1
echo "# efficiency: $(date -u +%Y-%m-%dT%H:%M:%SZ), repo $(git -C "$ROOT" rev-parse --short HEAD)"
echo "# host: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //'); load $(cut -d' ' -f1-3 /proc/loadavg)"

median() { sort -g | awk '{a[NR] = $1} END {print (NR % 2) ? a[(NR + 1) / 2] : (a[NR / 2] + a[NR / 2 + 1]) / 2}'; }
# wall seconds of a command (stdout and stderr dropped)
wall() {
  /usr/bin/time -f "%e" -o t.txt "$@" > /dev/null 2>&1
  cat t.txt
}
# the value of key $2 in the JSON report $1
jget() { /usr/bin/python3 -c "import json, sys; print(json.load(open(sys.argv[1])).get(sys.argv[2], '-'))" "$1" "$2"; }

time_pairs() { # name mesh hsiz
  local name=$1 in=$2 h=$3
  : > "e-$name.txt"
  for i in $(seq "$PAIRS"); do
    t1=$(wall "$PADAPT" adapt "$in" -hsiz "$h" -out o1.meshb -nosol -json "time-$name-np1.json")
    t2=$(wall mpiexec -n 2 "$PADAPT" adapt "$in" -hsiz "$h" -out o2.meshb -nosol -json "time-$name-np2.json")
    s1=$(jget "time-$name-np1.json" time_s)
    s2=$(/usr/bin/python3 -c "import json, sys; r = json.load(open(sys.argv[1]))
print(r['time_s'] - r['steps_s']['measure'])" "time-$name-np2.json")
    echo "$t1 $t2 $s1 $s2" | awk '{print $1 / (2 * $2), $1, $2, $3 / (2 * $4), $3, $4}' >> "e-$name.txt"
  done
  printf "time  %-7s %s elements: whole command T1 %s s, T2 %s s, efficiency %s; own time T1 %s s, T2 %s s, efficiency %s (medians; pairs T1/T2: %s)\n" \
    "$name" "$(jget "time-$name-np1.json" elements)" \
    "$(cut -d' ' -f2 "e-$name.txt" | median)" "$(cut -d' ' -f3 "e-$name.txt" | median)" \
    "$(cut -d' ' -f1 "e-$name.txt" | median)" \
    "$(cut -d' ' -f5 "e-$name.txt" | median)" "$(cut -d' ' -f6 "e-$name.txt" | median)" \
    "$(cut -d' ' -f4 "e-$name.txt" | median)" \
    "$(awk '{printf "%s/%s ", $2, $3}' "e-$name.txt" | sed 's/ $//')"
}

# remesher CPU microseconds per output element of the -json report $1
us_per_elem() { /usr/bin/python3 -c "import json, sys; r = json.load(open(sys.argv[1]))
print('%.3f' % (1e6 * r['remesh_cpu_s'] / r['elements']))" "$1"; }

# one line per iteration of a parallel report: tagged, pieces, work
iters() {
  /usr/bin/python3 -c "import json, sys
r = json.load(open(sys.argv[1]))
print(', '.join('%d: %d tagged, %d pieces, %.2f s' % (i['iter'], i['tagged'], i['pieces'], i['remesh_cpu_s'])
                for i in r['iteration_detail']))" "$1"
}

# the remesher's operation counts of the -json report $1 over those of $2
ops_ratio() { /usr/bin/python3 -c "import json, sys
a, b = (json.load(open(f)) for f in sys.argv[1:3])
print(', '.join('%s %.3f' % (k[1:], a[k] / max(b[k], 1)) for k in ('nsplit', 'ncollapse', 'nswap', 'nmove')))" "$1" "$2"; }

# what np copies at once add to the CPU per element of one run alone:
# mesh hsiz np prefix of the reports (PREFIX-alone.json, PREFIX-I.json)
copies_factor() {
  local in=$1 h=$2 np=$3 pre=$4
  "$PADAPT" adapt "$in" -hsiz "$h" -out c0.meshb -nosol -json "$pre-alone.json" > /dev/null 2>&1
  for i in $(seq "$np"); do
    "$PADAPT" adapt "$in" -hsiz "$h" -out "c$i.meshb" -nosol -json "$pre-$i.json" > /dev/null 2>&1 &
  done
  wait
  rm -f c*.meshb
  local a
  a=$(us_per_elem "$pre-alone.json")
  for i in $(seq "$np"); do us_per_elem "$pre-$i.json"; done |
    awk -v a="$a" '{s += $1} END {printf "%.3f", s / NR / a}'
}

# the work at np 1, 2, 4, 8 of one job: name mesh hsiz dimension prefix of
# the reports (PREFIX-npN.json, PREFIX-copyN-*.json)
work_nps() {
  local name=$1 in=$2 h=$3 dim=$4 pre=$5
  "$PADAPT" adapt "$in" -hsiz "$h" -out o1.meshb -nosol -json "$pre-np1.json" > /dev/null 2>&1
  w1=$(jget "$pre-np1.json" remesh_cpu_s)
  printf "work  %-5s np=1: %s elements, worst quality %.3f, remesher CPU %.2f s\n" "$name" \
    "$(jget "$pre-np1.json" elements)" "$(jget "$pre-np1.json" quality_worst)" "$w1"
  for np in 2 4 8; do
    mpiexec -n "$np" "$PADAPT" adapt "$in" -hsiz "$h" -out o2.meshb -nosol \
      -json "$pre-np$np.json" > /dev/null 2>&1
    w=$(jget "$pre-np$np.json" remesh_cpu_s)
    hq=$(awk -v h="$h" -v n="$np" -v d="$dim" 'BEGIN { printf "%.6f", h * n ^ (1 / d) }')
    cf=$(copies_factor "$in" "$hq" "$np" "$pre-copy$np")
    printf "work  %-5s np=%d: %s elements, worst quality %.3f, remesher CPU %.2f s, %.3f x np=1; %d copies of -hsiz %s at once: %.3f x its CPU per element, so %.3f x np=1 over that; operations x np=1: %s; %s iterations (%s)\n" \
      "$name" "$np" "$(jget "$pre-np$np.json" elements)" "$(jget "$pre-np$np.json" quality_worst)" "$w" \
      "$(echo "$w $w1" | awk '{print $1 / $2}')" "$np" "$hq" "$cf" \
      "$(echo "$w $w1 $cf" | awk '{print $1 / ($2 * $3)}')" \
      "$(ops_ratio "$pre-np$np.json" "$pre-np1.json")" \
      "$(jget "$pre-np$np.json" iterations)" "$(iters "$pre-np$np.json")"
  done
}

for part in $PARTS; do
  case $part in
    time)
      "$PADAPT" generate box3d 10 kuhn.mesh > /dev/null
      for job in ${TIME_JOBS:-rod plate plate1s cube}; do
        case $job in
          rod) time_pairs rod "$ROOT/tests/data/rod3d.mesh" 0.03 ;;
          plate) time_pairs plate "$ROOT/tests/data/plate2d.mesh" 0.0005 ;;
          plate1s) time_pairs plate1s "$ROOT/tests/data/plate2d.mesh" 0.0012 ;;
          cube) time_pairs cube kuhn.mesh 0.05 ;;
        esac
      done ;;
    work)
      work_nps rod "$ROOT/tests/data/rod3d.mesh" 0.03 3 work
      work_nps plate "$ROOT/tests/data/plate2d.mesh" 0.0005 2 work-plate ;;
    weak)
      # N ~ 0.817 M x (0.03 / h)^3 on the rod
      h1=$(awk 'BEGIN { printf "%.5f", 0.03 * (0.817 / 2) ^ (1 / 3) }')
      "$PADAPT" adapt "$ROOT/tests/data/rod3d.mesh" -hsiz "$h1" -out o1.meshb -nosol \
        -json weak-np1.json > /dev/null 2>&1
      us1=$(us_per_elem weak-np1.json)
      printf "weak  np=1 -hsiz %s: %s elements, remesher CPU %.2f s, %s us per tet\n" \
        "$h1" "$(jget weak-np1.json elements)" "$(jget weak-np1.json remesh_cpu_s)" "$us1"
      for np in ${WEAK_NPS:-2 4 8}; do
        h=$(awk -v n="$np" 'BEGIN { printf "%.5f", 0.03 * (0.817 / (2 * n)) ^ (1 / 3) }')
        rm -rf weak && mkdir weak
        mpiexec -n "$np" "$PADAPT" adapt "$ROOT/tests/data/rod3d.mesh" -hsiz "$h" -out weak/o.meshb \
          -distributed-output -nosol -json "weak-np$np.json" > /dev/null 2>&1
        rm -rf weak
        "$PADAPT" adapt "$ROOT/tests/data/rod3d.mesh" -hsiz "$h" -out o1.meshb -nosol \
          -json "weak-seq$np.json" > /dev/null 2>&1
        # np copies of the np=1 job at once: what sharing the cores and
        # caches alone adds to the CPU time of a rank
        for i in $(seq "$np"); do
          "$PADAPT" adapt "$ROOT/tests/data/rod3d.mesh" -hsiz "$h1" -out "c$i.meshb" -nosol \
            -json "weak-copy$np-$i.json" > /dev/null 2>&1 &
        done
        wait
        rm -f c*.meshb
        us=$(us_per_elem "weak-np$np.json")
        usq=$(us_per_elem "weak-seq$np.json")
        cf=$(for i in $(seq "$np"); do us_per_elem "weak-copy$np-$i.json"; done |
             awk -v a="$us1" '{s += $1} END {printf "%.3f", s / NR / a}')
        printf "weak  np=%d -hsiz %s: %s elements, remesher CPU %.2f s, %s us per tet, %.3f x np=1, %.3f x the sequential run of the same size (%s us per tet); %d copies of np=1 at once: %.3f x its CPU per tet, so %.3f x the sequential run over that; operations x the sequential run: %s; %s iterations\n" \
          "$np" "$h" "$(jget "weak-np$np.json" elements)" "$(jget "weak-np$np.json" remesh_cpu_s)" "$us" \
          "$(echo "$us $us1" | awk '{print $1 / $2}')" "$(echo "$us $usq" | awk '{print $1 / $2}')" "$usq" \
          "$np" "$cf" "$(echo "$us $usq $cf" | awk '{print $1 / ($2 * $3)}')" \
          "$(ops_ratio "weak-np$np.json" "weak-seq$np.json")" "$(jget "weak-np$np.json" iterations)"
      done ;;
    *) echo "unknown part $part" ;;
  esac
done
