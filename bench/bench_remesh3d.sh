#!/usr/bin/env bash
# bench_remesh3d.sh -- benchmark of padapt's sequential 3D remesher (#4),
# through the CLI (`padapt adapt`, which runs pa_remesh: metric preparation
# with the default gradation 1.3, then the tetrahedral remesher).
#
# usage: bench/bench_remesh3d.sh [PADAPT] [CASES...]
#   PADAPT  path of the CLI (default build/bin/padapt)
#   CASES   any of: cube aniso coarsen strong scale (default: cube aniso
#           coarsen strong);
#           scale is the optional sweep of uniform sizes from box3d 10,
#           about 1e5 to 1e7 output tets (the last one needs ~2 GB and
#           minutes).
#
# Each case prints one line: output tets, remesher time (report time_s),
# output tets per second, peak padapt memory per output tet
# (pa_memory_peak) and peak RSS per output tet, % of unique edges in
# [0.7071, 1.4142), worst and mean quality, validity and outcome, taken from
# the -json report (in-range: in the given metric, and in the metric used,
# after the gradation). The machine load is printed first: the figures are only
# comparable on a quiet machine (time is wall clock on one core).
#
# The issue #4 cases:
#   cube     padapt generate box3d 10 cube.mesh;
#            padapt adapt cube.mesh -hsiz 0.02 -out out.mesh -json r.json
#   aniso    padapt metric layer:0.1 (shell:0.1) cube.mesh m.sol;
#            padapt adapt cube.mesh -met m.sol -out out.mesh -json r.json
#   coarsen  box3d 40 adapted to -hsiz 0.1
#   strong   box3d 6 in the constant tensor of sizes 10, 10, 1e-4 (issue
#            #35: the metric asks for about 850 tets, the domain is 10
#            times narrower than the large sizes; it grew to 12 GB before)
set -euo pipefail

PADAPT=${1:-build/bin/padapt}
shift || true
CASES=${*:-cube aniso coarsen strong}
PADAPT=$(cd "$(dirname "$PADAPT")" && pwd)/$(basename "$PADAPT")
WORK=${WORK:-$(mktemp -d /tmp/bench_remesh3d.XXXXXX)}
cd "$WORK"

# Value of a number/boolean/string key in the flat JSON report.
jget() { grep -o "\"$1\": *[^,}]*" r.json | head -1 | sed 's/.*: *//; s/"//g'; }
# The same inside the "metric_used" object (the metric after the gradation).
jused() { grep -o '"metric_used": {[^}]*}' r.json | grep -o "\"$1\": *[^,}]*" |
          sed 's/.*: *//'; }

run() {
  local n=$1 spec=$2
  "$PADAPT" generate box3d "$n" in.mesh >/dev/null
  case $spec in
    uniform:*) "$PADAPT" adapt in.mesh -hsiz "${spec#uniform:}" -out out.mesh \
                 -json r.json >/dev/null ;;
    tensor:*) # tensor:HX,HY,HZ, a constant diagonal metric
       local h=${spec#tensor:}
       awk -v h="$h" 'BEGIN { split(h, s, ",") }
         /^ *Vertices/ { getline; nv = $1 }
         END { printf "MeshVersionFormatted 2\nDimension 3\nSolAtVertices\n%d\n1 3\n", nv
               for (i = 0; i < nv; i++)
                 printf "%.17g 0 %.17g 0 0 %.17g\n", 1 / s[1]^2, 1 / s[2]^2, 1 / s[3]^2
               print "End" }' in.mesh > in.sol
       "$PADAPT" adapt in.mesh -met in.sol -out out.mesh -json r.json >/dev/null ;;
    *) "$PADAPT" metric "$spec" in.mesh in.sol >/dev/null
       "$PADAPT" adapt in.mesh -met in.sol -out out.mesh -json r.json >/dev/null ;;
  esac
  awk -v spec="$spec" -v n="$n" -v ne="$(jget elements)" -v t="$(jget time_s)" \
      -v mem="$(jget peak_memory_bytes)" -v rss="$(jget peak_rss_bytes)" \
      -v inr="$(jget edge_in_range)" -v qw="$(jget quality_worst)" \
      -v qm="$(jget quality_mean)" -v valid="$(jget valid)" \
      -v outcome="$(jget outcome)" -v inu="$(jused edge_in_range)" 'BEGIN {
    printf "%-14s box%-3d %9d tets %7.2f s %8.0f tets/s %6.1f B/tet (rss %6.1f)" \
           " in-range %5.2f%% (metric used %5.2f%%) worst %.3f mean %.3f" \
           " valid %s %s\n",
           spec, n, ne, t, ne / t, mem / ne, rss / ne, 100 * inr, 100 * inu,
           qw, qm, valid, outcome }'
}

echo "# $(date -u +%F) $(uname -m) $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2)"
echo "# load: $(cut -d' ' -f1-3 /proc/loadavg)"
for c in $CASES; do
  case $c in
    cube)    run 10 uniform:0.02 ;;
    aniso)   run 10 layer:0.1; run 10 shell:0.1 ;;
    coarsen) run 40 uniform:0.1 ;;
    strong)  run 6 tensor:10,10,1e-4 ;;
    scale)   for h in 0.045 0.03 0.02 0.014 0.01; do run 10 uniform:$h; done ;;
    *) echo "unknown case $c" >&2; exit 2 ;;
  esac
done
echo "# load: $(cut -d' ' -f1-3 /proc/loadavg)"
