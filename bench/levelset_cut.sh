#!/usr/bin/env bash
# levelset_cut.sh -- padapt adapt -ls side by side with Mmg's -ls
# (mmg2d_O3 / mmg3d_O3) on the same inputs, judged by the same independent
# judge (bench/lscut_judge.py: numpy and meshio, the exact surface).
#
#   bash bench/levelset_cut.sh BUILD_DIR WORK_DIR [CASE...]
#
# CASE: disc (box2d 100, a circle of radius 0.3, -hsiz 0.002), sphere (box3d
# 16, a sphere of radius 0.3, -hsiz 0.04), torus (box3d 16, a torus of radii
# 0.28 and 0.12, -hsiz 0.05). Default: all three. The level set is the
# exact signed distance at the input's vertices (padapt levelset, or numpy
# for the torus); both tools get the same mesh, level set and options
# (-hsiz, their defaults otherwise: -hausd 0.01, -hgrad 1.3).
#
# For each case, PAIRS (default 3) back-to-back runs of padapt and of Mmg
# (when on PATH or in MMG_BIN; skipped otherwise): the wall time and the
# user CPU time of the whole command (/usr/bin/time), and the outputs
# judged: elements, the interface's entities (reference 10), the inside
# volume's error against the exact volume, the largest and mean distance
# from the interface to the exact surface (sampled at the interface's
# vertices, edge midpoints and centroids), the worst and mean quality in
# the uniform metric of -hsiz and the share of edges in range. A line per
# tool with the medians, then the ratios. The user CPU time is the figure
# to compare on a shared machine (the load is printed first); wall clock
# only on a quiet one.
set -u
BUILD=${1:?BUILD_DIR}
WORK=${2:?WORK_DIR}
shift 2
CASES=${*:-disc sphere torus}
PAIRS=${PAIRS:-3}
PADAPT=$(cd "$BUILD" && pwd)/bin/padapt
ROOT=$(cd "$(dirname "$0")/.." && pwd)
JUDGE=$ROOT/bench/lscut_judge.py
MMG_BIN=${MMG_BIN:-/work/scratch/mmg-build/bin}
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
export OMPI_MCA_rmaps_base_oversubscribe=1 SCOTCH_PTHREAD_NUMBER=1
mkdir -p "$WORK"
cd "$WORK" || exit 1
echo "# levelset_cut: $(date -u +%Y-%m-%dT%H:%M:%SZ), repo $(git -C "$ROOT" rev-parse --short HEAD)"
echo "# host: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //'); load $(cut -d' ' -f1-3 /proc/loadavg)"

mmg_of() { # the Mmg binary of dimension $1, or nothing
  local b=mmg${1}d_O3
  if command -v "$b" > /dev/null; then command -v "$b"
  elif [ -x "$MMG_BIN/$b" ]; then echo "$MMG_BIN/$b"; fi
}
median() { sort -g | awk '{a[NR] = $1} END {print (NR % 2) ? a[(NR + 1) / 2] : (a[NR / 2] + a[NR / 2 + 1]) / 2}'; }
# wall and user seconds of a command
timed() {
  /usr/bin/time -f "%e %U" -o t.txt "$@" > /dev/null 2>&1
  cat t.txt
}
# "elements volume_error dist_max dist_mean qworst qmean inrange interface"
# of mesh $1
judge() {
  /usr/bin/python3 "$JUDGE" "$1" "$2" "$3" "$4" | /usr/bin/python3 -c "
import json, sys
j = json.load(sys.stdin)
print(j['elements'], '%.3e' % j['volume_error'], '%.3e' % j['dist_max'], '%.3e' % j['dist_mean'],
      '%.3f' % j['quality_worst'], '%.3f' % j['quality_mean'], '%.4f' % j['edges_in_range'],
      j['interface'])"
}

write_torus_sol() { # mesh $1 -> level set $2 (the torus of the case)
  /usr/bin/python3 - "$1" "$2" <<'PY'
import sys, warnings, os
import numpy as np
import meshio
with warnings.catch_warnings():
    warnings.simplefilter("ignore")
    saved = os.dup(2); null = open(os.devnull, "w"); os.dup2(null.fileno(), 2)
    m = meshio.read(sys.argv[1]); os.dup2(saved, 2)
x = m.points
q = np.hypot(x[:, 0] - 0.5, x[:, 1] - 0.5) - 0.28
phi = np.hypot(q, x[:, 2] - 0.5) - 0.12
with open(sys.argv[2], "w") as f:
    f.write("MeshVersionFormatted 2\nDimension 3\nSolAtVertices\n%d\n1 1\n" % len(phi))
    f.write("".join("%.17g\n" % v for v in phi) + "End\n")
PY
}

side_by_side() {
  local name=$1 dim=$2 n=$3 shape=$4 h=$5
  "$PADAPT" generate "box${dim}d" "$n" in.mesh > /dev/null
  case $shape in
    torus*) write_torus_sol in.mesh phi.sol ;;
    *) "$PADAPT" levelset "$shape" in.mesh phi.sol > /dev/null ;;
  esac
  local jshape=$shape
  [ "$name" = torus ] && jshape=torus:0.28,0.12:0.5,0.5,0.5
  local mmg
  mmg=$(mmg_of "$dim")
  : > p.txt
  : > m.txt
  for i in $(seq "$PAIRS"); do
    rm -f p.mesh
    echo "$(timed "$PADAPT" -v -1 adapt in.mesh -ls phi.sol -hsiz "$h" -out p.mesh -nosol) $(judge p.mesh "$jshape" "$h" "$dim")" >> p.txt
    if [ -n "$mmg" ]; then
      rm -f m.mesh m.sol
      echo "$(timed "$mmg" -in in.mesh -sol phi.sol -ls -hsiz "$h" -out m.mesh -v -1) $(judge m.mesh "$jshape" "$h" "$dim")" >> m.txt
    fi
  done
  row() { # file -> "wall user elements volerr dmax dmean qworst qmean inrange iface"
    echo "$(cut -d' ' -f1 "$1" | median) $(cut -d' ' -f2 "$1" | median) $(tail -1 "$1" | cut -d' ' -f3-)"
  }
  local p m
  p=$(row p.txt)
  printf "%-6s padapt: wall %s s, user %s s, %s elements, volume error %s, distance max %s mean %s, quality worst %s mean %s, in range %s, %s interface entities\n" "$name" $p
  if [ -s m.txt ]; then
    m=$(row m.txt)
    printf "%-6s mmg:    wall %s s, user %s s, %s elements, volume error %s, distance max %s mean %s, quality worst %s mean %s, in range %s, %s interface entities\n" "$name" $m
    echo "$p $m" | awk -v n="$name" '{
      printf "%-6s Mmg / padapt: wall %.2f, user %.2f, elements %.2f, interface entities %.2f, volume error %.2f, distance max %.2f mean %.2f; quality worst %.3f vs %.3f, mean %.3f vs %.3f\n",
        n, $11 / $1, $12 / $2, $13 / $3, $20 / $10, $14 / $4, $15 / $5, $16 / $6, $7, $17, $8, $18 }'
  else
    echo "$name mmg${dim}d_O3 not found: padapt only"
  fi
}

for c in $CASES; do
  case $c in
    disc) side_by_side disc 2 100 sphere:0.3:0.5,0.5 0.002 ;;
    sphere) side_by_side sphere 3 16 sphere:0.3:0.5,0.5,0.5 0.04 ;;
    torus) side_by_side torus 3 16 torus 0.05 ;;
    *) echo "levelset_cut: unknown case $c" >&2; exit 1 ;;
  esac
done
