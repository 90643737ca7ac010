#!/usr/bin/env bash
# bench_remesh2d.sh -- throughput, memory and quality of the sequential 2D
# remesher (`padapt adapt`). Builds nothing.
#
#   bench/bench_remesh2d.sh [PADAPT] [WORKDIR]
#
# PADAPT defaults to build/bin/padapt, WORKDIR to a fresh temporary directory.
# Cases:
#   uniform   unit square (box2d 9, 162 triangles) -> -hsiz 0.00096
#             (about 2.5 M output triangles): the speed figure;
#   layer     anisotropic boundary layer, metric sampled on box2d 200;
#   shell     anisotropic circular shell, metric sampled on box2d 200;
#   coarsen   box2d 600 (720 000 triangles) -> -hsiz 0.01.
# For each: output triangles, time, triangles/s, peak padapt memory and peak
# RSS per output triangle, edges in [0.7071, 1.4142), worst/mean quality.
# Environment: BENCH_UNIFORM_N (default 9), BENCH_HSIZ (0.00096),
# BENCH_FIELD_N (200), BENCH_FIELD_H (0.01).
set -eu
PADAPT=${1:-build/bin/padapt}
WORK=${2:-$(mktemp -d)}
N=${BENCH_UNIFORM_N:-9}
HSIZ=${BENCH_HSIZ:-0.00096}
FN=${BENCH_FIELD_N:-200}
FH=${BENCH_FIELD_H:-0.01}
[ -x "$PADAPT" ] || { echo "bench: no padapt binary at $PADAPT" >&2; exit 1; }
mkdir -p "$WORK"
cd "$WORK"

# a top-level key of a report (nested objects hold keys of the same names)
num() { /usr/bin/python3 -c 'import json, sys; print(json.load(open(sys.argv[1]))[sys.argv[2]])' "$1" "$2"; }
str() { num "$1" "$2"; }

row() { # row NAME JSON
  local ne t mem rss inr qw qm oc
  ne=$(num "$2" elements); t=$(num "$2" time_s)
  mem=$(num "$2" peak_memory_bytes); rss=$(num "$2" peak_rss_bytes)
  inr=$(num "$2" edge_in_range); qw=$(num "$2" quality_worst)
  qm=$(num "$2" quality_mean); oc=$(str "$2" outcome)
  awk -v n="$1" -v ne="$ne" -v t="$t" -v mem="$mem" -v rss="$rss" -v inr="$inr" \
      -v qw="$qw" -v qm="$qm" -v oc="$oc" 'BEGIN {
    printf "%-8s %10d %8.2f %12.0f %9.1f %9.1f %8.2f %7.3f %7.3f  %s\n",
           n, ne, t, ne / t, mem / ne, rss / ne, 100 * inr, qw, qm, oc }'
}

echo "padapt: $PADAPT"
echo "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //')"
printf "%-8s %10s %8s %12s %9s %9s %8s %7s %7s  %s\n" case triangles time_s \
       tri/s B/tri B/tri-rss "in%" Qworst Qmean outcome

"$PADAPT" generate box2d "$N" sq.mesh > /dev/null
"$PADAPT" adapt sq.mesh -hsiz "$HSIZ" -out uniform.meshb -nosol -json uniform.json > uniform.log
row uniform uniform.json

"$PADAPT" generate box2d "$FN" fine.mesh > /dev/null
for f in layer shell; do
  "$PADAPT" metric "$f:$FH" fine.mesh "$f.sol" > /dev/null
  "$PADAPT" adapt fine.mesh -met "$f.sol" -out "$f.meshb" -nosol -json "$f.json" > "$f.log"
  row "$f" "$f.json"
done

"$PADAPT" generate box2d 600 big.meshb > /dev/null
"$PADAPT" adapt big.meshb -hsiz 0.01 -out coarse.meshb -nosol -json coarsen.json > coarsen.log
row coarsen coarsen.json
echo "(B/tri: peak padapt memory per output triangle; B/tri-rss: peak RSS of the"
echo " process, MPI and the input mesh included. Logs and reports in $WORK.)"
