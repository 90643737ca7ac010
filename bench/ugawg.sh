#!/usr/bin/env bash
# ugawg.sh -- the UGAWG anisotropic benchmark (Ibanez, Barral, Krakos,
# Loseille, Michal, Park, "A benchmark case for unstructured mesh
# adaptation"): the fields linear, polar1 and polar2 on the unit square (2D)
# and cube (3D), each reached by PASSES adaptation passes from a start mesh,
# every pass re-evaluating the analytic field on the current vertices
# (`padapt metric ugawg-...`) and adapting with default options. The final
# mesh is judged against the analytic field twice: by `padapt stats` and by
# bench/ugawg_judge.py, which recomputes the edge lengths from the formulas
# alone, so a bug in padapt's metric or statistics cannot hide; the judge
# also gives the complexity C = integral of sqrt(det M) (1D Gauss-Legendre
# of the exact reduction; the per-element centroid rule on each final mesh
# is printed as a check). Mmg (mmg2d, mmg3d on PATH) runs the same protocol
# as the sequential reference.
#
#   bash bench/ugawg.sh [BUILD_DIR] [WORK_DIR]
#
# Environment: CASES (default "linear polar1 polar2"), DIMS ("2 3"),
# PROCS ("1 2": padapt's process counts; 1 runs `padapt adapt` directly, P > 1
# under `mpiexec -n P`), STARTS ("box gmsh": the built-in boxes box2d 20 and
# box3d 10, and unstructured gmsh meshes of similar size, characteristic
# length 0.05 / 0.1, when gmsh is on PATH), PASSES (5), TOOLS ("padapt mmg";
# Mmg runs once per case, sequentially, when mmg2d / mmg3d are on PATH).
#
# Columns: final elements; elements / C; edges in [0.7071, 1.4142) by
# padapt stats and by the Python judge (%); worst and mean quality (padapt
# stats, both tools); adapt time summed over the passes (padapt: the JSON's
# time_s; Mmg: the library time it prints, MMG2DLIB/MMG3DLIB ELAPSED TIME,
# or its wall time marked *); final elements / adapt time; the commands'
# summed wall time (process start, I/O and mpiexec included).
# Every file of a run stays in WORK_DIR/<tool>-<case>-<dim>d-<start>-np<P>/.
set -u
# the piece loop itself at every size (padapt adapt -serial-below)
export PADAPT_SERIAL_BELOW=${PADAPT_SERIAL_BELOW:-0}
BUILD=${1:-build}
WORK=${2:-/tmp/padapt-ugawg}
PADAPT=${PADAPT:-$BUILD/bin/padapt}
CASES=${CASES:-"linear polar1 polar2"}
DIMS=${DIMS:-"2 3"}
PROCS=${PROCS:-"1 2"}
STARTS=${STARTS:-"box gmsh"}
PASSES=${PASSES:-5}
TOOLS=${TOOLS:-"padapt mmg"}
PY=/usr/bin/python3
HERE=$(cd "$(dirname "$0")" && pwd)
JUDGE="$HERE/ugawg_judge.py"
# shellcheck source=bench/gmsh_box.sh
. "$HERE/gmsh_box.sh"
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
export OMPI_MCA_rmaps_base_oversubscribe=1 SCOTCH_PTHREAD_NUMBER=1
MPIEXEC=${MPIEXEC:-mpiexec}

if [ ! -x "$PADAPT" ]; then
  echo "ugawg: $PADAPT not found (build first: cmake --build $BUILD)" >&2
  exit 1
fi
PADAPT=$(cd "$(dirname "$PADAPT")" && pwd)/$(basename "$PADAPT")
mkdir -p "$WORK"
WORK=$(cd "$WORK" && pwd)
RECORDS="$WORK/records.jsonl"
: >"$RECORDS"

has() { case " $1 " in *" $2 "*) return 0 ;; esac; return 1; }

commit=$(git -C "$HERE/.." rev-parse --short HEAD 2>/dev/null || echo unknown)
if [ -n "$(git -C "$HERE/.." status --porcelain --untracked-files=no 2>/dev/null)" ]; then
  commit="$commit (with uncommitted changes)"
fi
echo "# UGAWG anisotropic benchmark, $(date -u +%Y-%m-%dT%H:%M:%SZ)"
echo "# host: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | sed 's/.*: //'), $(uname -srm); load: $(cut -d' ' -f1-3 /proc/loadavg)"
echo "# repo: $(cd "$HERE/.." && pwd) at $commit; binary: $PADAPT"
echo "# cases: $CASES; dims: $DIMS; starts: $STARTS; padapt processes: $PROCS; passes: $PASSES; tools: $TOOLS"
for t in mmg2d mmg3d gmsh; do
  if command -v "$t" >/dev/null; then
    case $t in
      gmsh) v=$(gmsh --version 2>&1 | tail -1) ;;
      *) v=$("$t" -h 2>&1 | grep -m1 -o 'Release [^ ]*') ;;
    esac
    echo "# $t: $(command -v "$t") ($v)"
  else
    echo "# $t: not on PATH"
  fi
done
echo "# work: $WORK"

# make_start DIM START OUT: the start mesh; returns 2 when it is skipped.
make_start() {
  local dim=$1 start=$2 out=$3
  if [ "$start" = box ]; then
    if [ "$dim" = 2 ]; then
      "$PADAPT" generate box2d 20 "$out" >/dev/null
    else
      "$PADAPT" generate box3d 10 "$out" >/dev/null
    fi
    return
  fi
  command -v gmsh >/dev/null || return 2
  local geo="$WORK/start/unit${dim}d.geo" raw="$WORK/start/gmsh${dim}d_raw.mesh"
  local lc=0.1
  [ "$dim" = 2 ] && lc=0.05
  gmsh_box "$dim" "$lc" "$geo" "$raw" ||
    { echo "# gmsh failed, see $raw.log" >&2; return 1; }
  # gmsh writes 2D meshes with z = 0 in Dimension 3: rewrite them as the
  # plain Medit file both tools read alike.
  "$PADAPT" convert "$raw" "$out" >/dev/null
}

# run TOOL CASE DIM START NP STARTMESH: PASSES passes, judge, print a row.
run() {
  local tool=$1 case=$2 dim=$3 start=$4 np=$5 mesh0=$6
  local dir="$WORK/$tool-$case-${dim}d-$start-np$np" failed="" i
  rm -rf "$dir"
  mkdir -p "$dir"
  cp "$mesh0" "$dir/p0.mesh"
  : >"$dir/passes.tsv"
  for i in $(seq "$PASSES"); do
    local in="$dir/p$((i - 1)).mesh" sol="$dir/p$((i - 1)).sol" out="$dir/p$i.mesh"
    local log="$dir/pass$i.log" json="$dir/r$i.json" rc t0 t1
    if ! "$PADAPT" metric "ugawg-$case" "$in" "$sol" >"$dir/metric$i.log" 2>&1; then
      failed="pass $i: padapt metric failed, see $dir/metric$i.log"
      break
    fi
    t0=$(date +%s.%N)
    if [ "$tool" = mmg ]; then
      "mmg${dim}d" "$in" -met "$sol" -out "$out" >"$log" 2>&1
    elif [ "$np" = 1 ]; then
      "$PADAPT" adapt "$in" -met "$sol" -out "$out" -nosol -json "$json" >"$log" 2>&1
    else
      "$MPIEXEC" -n "$np" "$PADAPT" adapt "$in" -met "$sol" -out "$out" -nosol \
        -json "$json" >"$log" 2>&1
    fi
    rc=$?
    t1=$(date +%s.%N)
    if [ "$rc" != 0 ] || [ ! -s "$out" ]; then
      failed="pass $i: exit $rc, see $log"
      break
    fi
    if [ "$tool" = mmg ]; then
      rm -f "$dir/p$i.sol"
      local lib nel wall kw=TETRAHEDRA
      [ "$dim" = 2 ] && kw=TRIANGLES
      lib=$(sed -n 's/.*MMG[23]DLIB: ELAPSED TIME *\([0-9.]*\)s.*/\1/p' "$log" | tail -1)
      nel=$(grep "NUMBER OF $kw" "$log" | tail -1 | awk '{print $4}')
      wall=$(awk -v a="$t0" -v b="$t1" 'BEGIN { printf "%.6f", b - a }')
      if [ -n "$lib" ]; then
        echo "$i ${nel:-0} $lib $wall lib -" >>"$dir/passes.tsv"
      else
        echo "$i ${nel:-0} $wall $wall wall -" >>"$dir/passes.tsv"
      fi
    else
      "$PY" - "$json" "$i" "$t0" "$t1" >>"$dir/passes.tsv" <<'PY'
import json, sys
d = json.load(open(sys.argv[1]))
wall = float(sys.argv[4]) - float(sys.argv[3])
print(sys.argv[2], d["elements"], d.get("time_s", 0.0), f"{wall:.6f}", "json",
      d.get("outcome", "-"))
PY
    fi
  done
  local final="$dir/p$PASSES.mesh"
  if [ -z "$failed" ]; then
    "$PADAPT" metric "ugawg-$case" "$final" "$dir/final.sol" >/dev/null 2>&1 ||
      failed="final: padapt metric failed"
    # padapt stats exits 1 on an invalid mesh; its JSON says so.
    "$PADAPT" stats "$final" -met "$dir/final.sol" -json "$dir/s.json" \
      >"$dir/stats.log" 2>&1
  fi
  "$PY" "$JUDGE" record "tool=$tool" "case=$case" "dim=$dim" "start=$start" \
    "np=$np" "field=$case" "mesh=$final" "sol=$dir/final.sol" \
    "stats=$dir/s.json" "passes=$dir/passes.tsv" "records=$RECORDS" \
    "failed=$failed"
}

echo
"$PY" "$JUDGE" header
mkdir -p "$WORK/start"
for dim in $DIMS; do
  for start in $STARTS; do
    mesh0="$WORK/start/$start${dim}d.mesh"
    make_start "$dim" "$start" "$mesh0"
    rc=$?
    if [ "$rc" = 2 ]; then
      echo "# ${dim}D unstructured start skipped: gmsh not on PATH"
      continue
    elif [ "$rc" != 0 ]; then
      echo "# ${dim}D $start start could not be made"
      continue
    fi
    for case in $CASES; do
      if has "$TOOLS" padapt; then
        for np in $PROCS; do
          run padapt "$case" "$dim" "$start" "$np" "$mesh0"
        done
      fi
      if has "$TOOLS" mmg; then
        if command -v "mmg${dim}d" >/dev/null; then
          run mmg "$case" "$dim" "$start" 1 "$mesh0"
        fi
      fi
    done
  done
done
for dim in $DIMS; do
  if has "$TOOLS" mmg && ! command -v "mmg${dim}d" >/dev/null; then
    echo "# Mmg ${dim}D skipped: mmg${dim}d not on PATH"
  fi
done
"$PY" "$JUDGE" summary "$RECORDS"
echo
echo "# done $(date -u +%Y-%m-%dT%H:%M:%SZ); load: $(cut -d' ' -f1-3 /proc/loadavg)"
