#!/usr/bin/env bash
# lattice3d.sh -- the 3D remesher on cube lattices against Mmg (issues #36,
# #39): box3d N adapted to a uniform size H, where bisection by whole
# levels makes lattices that a size in the wrong band leaves too dense or
# of poor shapes (docs/design/REMESHER3D.md, "Schedule").
#
#   bash bench/lattice3d.sh BUILD_DIR WORK_DIR [N:H ...]
#
# Default sizes: box3d 16 at H = 0.03 ... 0.06 by 0.0025 and box3d 10 at
# 0.06 ... 0.09 by 0.005. For each: `padapt adapt box3d.mesh -hsiz H -out
# p.mesh -nosol` and, when mmg3d_O3 is on PATH or in MMG_BIN, `mmg3d_O3 -in
# box3d.mesh -hsiz H -out m.mesh`, both judged by bench/lscut_judge.py
# (numpy and meshio on the files; its sphere argument is unused here):
# one line per size with the tet counts (padapt's also as a multiple of
# the ideal count, volume / regular tet of edge H, and of Mmg's), worst and
# mean quality and edges in range of both, the user CPU seconds of both,
# and a flag per figure where padapt falls behind (C: count above 1.05 x
# Mmg's, W / M: worst / mean quality below Mmg's, R: under 99 % in range).
set -u
BUILD=${1:?BUILD_DIR}
WORK=${2:?WORK_DIR}
shift 2
SIZES=${*:-$(for h in 0.03 0.0325 0.035 0.0375 0.04 0.0425 0.045 0.0475 0.05 \
  0.0525 0.055 0.0575 0.06; do echo "16:$h"; done; for h in 0.06 0.065 0.07 \
  0.075 0.08 0.085 0.09; do echo "10:$h"; done)}
PADAPT=$(cd "$BUILD" && pwd)/bin/padapt
ROOT=$(cd "$(dirname "$0")/.." && pwd)
JUDGE=$ROOT/bench/lscut_judge.py
MMG_BIN=${MMG_BIN:-/work/scratch/mmg-build/bin}
MMG=$(command -v mmg3d_O3 || { [ -x "$MMG_BIN/mmg3d_O3" ] && echo "$MMG_BIN/mmg3d_O3"; })
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
export OMPI_MCA_rmaps_base_oversubscribe=1 SCOTCH_PTHREAD_NUMBER=1
mkdir -p "$WORK"
cd "$WORK" || exit 1
echo "# lattice3d: $(date -u +%Y-%m-%dT%H:%M:%SZ), repo $(git -C "$ROOT" rev-parse --short HEAD)"
echo "# host: $(nproc) cores; load $(cut -d' ' -f1-3 /proc/loadavg); Mmg: ${MMG:-not found}"

# "elements qworst qmean inrange" of mesh $1 at size $2
judge() {
  /usr/bin/python3 "$JUDGE" "$1" sphere:0.3:0.5,0.5,0.5 "$2" 3 2> /dev/null |
    /usr/bin/python3 -c "import json, sys; j = json.load(sys.stdin)
print(j['elements'], '%.3f %.3f %.4f' % (j['quality_worst'], j['quality_mean'], j['edges_in_range']))"
}
user() { # user CPU seconds of a command
  /usr/bin/time -f "%U" -o t.txt "$@" > /dev/null 2>&1
  cat t.txt
}

printf "%-10s %-34s %-26s %s\n" "N:H" "padapt tets (x ideal, x Mmg) Qw/Qm" "Mmg tets Qw/Qm" "in range, user s, flags"
for s in $SIZES; do
  n=${s%%:*} h=${s#*:}
  [ -f "box$n.mesh" ] || "$PADAPT" generate box3d "$n" "box$n.mesh" > /dev/null
  rm -f p.mesh m.mesh m.sol
  tp=$(user "$PADAPT" -v -1 adapt "box$n.mesh" -hsiz "$h" -out p.mesh -nosol)
  read -r pe pw pm pr <<< "$(judge p.mesh "$h")"
  me=0 mw=0 mm=0 mr=0 tm=-
  if [ -n "$MMG" ]; then
    tm=$(user "$MMG" -in "box$n.mesh" -hsiz "$h" -out m.mesh -v -1)
    read -r me mw mm mr <<< "$(judge m.mesh "$h")"
  fi
  awk -v s="$s" -v h="$h" -v pe="$pe" -v pw="$pw" -v pm="$pm" -v pr="$pr" \
      -v me="$me" -v mw="$mw" -v mm="$mm" -v mr="$mr" -v tp="$tp" -v tm="$tm" 'BEGIN {
    ideal = h * h * h / (6 * sqrt(2)); ideal = 1 / ideal
    f = ""
    if (me > 0) {
      f = (pe > 1.05 * me ? "C" : ".") (pw < mw ? "W" : ".") (pm < mm ? "M" : ".")
      rx = sprintf("%.3f", pe / me)
    } else rx = "-"
    f = f (pr < 0.99 ? "R" : ".")
    printf "%-10s %7d (%.2f, %s) %s/%s   %7d %s/%s   %.2f%% / %.2f%%, %s / %s s, %s\n",
      s, pe, pe / ideal, rx, pw, pm, me, mw, mm, 100 * pr, 100 * mr, tp, tm, f }'
done
