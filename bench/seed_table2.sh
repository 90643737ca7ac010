#!/usr/bin/env bash
# seed_table2.sh -- the second experiment of Lachat, Dobrzynski, Pellegrini,
# "Parallel mesh adaptation using parallel graph partitioning": an
# anisotropic mesh capturing the interface of an ellipsoid of semi-axes
# (0.5, 0.1, 0.2) centred in a ball of radius 10, the distance between the
# surface and the mesh bounded by EPS, the smallest size HMIN (the paper:
# EPS = HMIN = 0.0003, 29.4 M tetrahedra on 48 processes). Printed as the
# rows of the paper's Table 2, one column per process count, plus the
# measured distance of the discrete interface to the exact surface.
#
#   bash bench/seed_table2.sh [BUILD_DIR] [WORK_DIR]
#
# Environment: EPS (default "0.003 0.001": a 0.3 M-tetrahedron run, then
# about 1 M; EPS / 3 gave 3.1 times the count), HMAX (default 2),
# PASSES (default 3), PROCS (default "1 2"), LCIN / LCOUT (gmsh sizes of the
# initial mesh inside radius 0.7 / at the sphere, default 0.05 / 2: 69 k
# tetrahedra).
# Each pass, from the current mesh: `padapt levelset ellipsoid:0.5,0.1,0.2`
# (the exact signed distance at the vertices), `padapt metric levelset -eps
# EPS -hmin EPS -hmax HMAX` (under mpiexec -n P at P > 1: the distributed
# recovery), `padapt adapt` (idem: the parallel driver). Rows: from the last
# pass's JSON report (the edge lengths and qualities in that pass's level-set
# metric; the paper's quality bin [1, 2] of MMG3D 4 is Q >= 0.5); elapsed
# time = the sum over the passes of metric + adaptation (time_s, without
# start-up and I/O); then bench/levelset_judge.py measures, from the exact
# ellipsoid alone, how far the zero set of the distance interpolated on the
# final mesh lies from the surface. gmsh must be on PATH.
set -u
# the piece loop itself at every size (padapt adapt -serial-below)
export PADAPT_SERIAL_BELOW=${PADAPT_SERIAL_BELOW:-0}
BUILD=${1:-build}
WORK=${2:-/tmp/padapt-seed-table2}
PADAPT=${PADAPT:-$BUILD/bin/padapt}
EPS=${EPS:-"0.003 0.001"}
HMAX=${HMAX:-2}
PASSES=${PASSES:-3}
PROCS=${PROCS:-"1 2"}
LCIN=${LCIN:-0.05}
LCOUT=${LCOUT:-2}
SHAPE="ellipsoid:0.5,0.1,0.2"
PY=/usr/bin/python3
HERE=$(cd "$(dirname "$0")" && pwd)
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
export OMPI_MCA_rmaps_base_oversubscribe=1 SCOTCH_PTHREAD_NUMBER=1
MPIEXEC=${MPIEXEC:-mpiexec}

if [ ! -x "$PADAPT" ]; then
  echo "seed_table2: $PADAPT not found (build first: cmake --build $BUILD)" >&2
  exit 1
fi
PADAPT=$(cd "$(dirname "$PADAPT")" && pwd)/$(basename "$PADAPT")
mkdir -p "$WORK"
WORK=$(cd "$WORK" && pwd)
commit=$(git -C "$HERE/.." rev-parse --short HEAD 2>/dev/null || echo unknown)
if [ -n "$(git -C "$HERE/.." status --porcelain --untracked-files=no 2>/dev/null)" ]; then
  commit="$commit (with uncommitted changes)"
fi
echo "# Table 2 of Lachat, Dobrzynski, Pellegrini: level-set interface of an ellipsoid in a ball"
echo "# $(date -u +%Y-%m-%dT%H:%M:%SZ)"
echo "# host: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | sed 's/.*: //'), $(uname -srm), $(free -g | awk '/^Mem:/ {print $2}') GB; load: $(cut -d' ' -f1-3 /proc/loadavg)"
echo "# repo: $(cd "$HERE/.." && pwd) at $commit; binary: $PADAPT"
echo "# shape $SHAPE; EPS (= HMIN): $EPS; HMAX $HMAX; passes $PASSES; processes: $PROCS"
echo "# work: $WORK"
if ! command -v gmsh >/dev/null; then
  echo "# SKIPPED: gmsh not on PATH; it makes the initial mesh from $HERE/sphere.geo"
  exit 0
fi
IN="$WORK/sphere.mesh"
if ! gmsh -3 "$HERE/sphere.geo" -setnumber lcin "$LCIN" -setnumber lcout "$LCOUT" \
     -format mesh -o "$IN" >"$WORK/gmsh.log" 2>&1; then
  echo "# gmsh failed, see $WORK/gmsh.log"
  exit 1
fi
"$PADAPT" stats "$IN" -json "$WORK/in.json" >/dev/null 2>&1
"$PY" -c "import json,sys; d=json.load(open(sys.argv[1])); print('# initial mesh: %d vertices, %d tetrahedra, volume %.2f, %s' % (d['vertices'], d['elements'], d['volume'], 'valid' if d['valid'] else 'INVALID'))" "$WORK/in.json"

for eps in $EPS; do
  dirs=""
  for np in $PROCS; do
    dir="$WORK/eps$eps-np$np"
    rm -rf "$dir"
    mkdir -p "$dir"
    run=()
    [ "$np" -gt 1 ] && run=("$MPIEXEC" -n "$np")
    mesh="$IN" rc=0 t0=$(date +%s.%N)
    for p in $(seq 1 "$PASSES"); do
      "$PADAPT" levelset "$SHAPE" "$mesh" "$dir/phi.sol" >"$dir/levelset$p.log" 2>&1 \
        && /usr/bin/time -f %e -o "$dir/metric$p.time" "${run[@]}" "$PADAPT" metric levelset \
             "$mesh" -ls "$dir/phi.sol" -eps "$eps" -hmin "$eps" -hmax "$HMAX" \
             "$dir/met.sol" >"$dir/metric$p.log" 2>&1 \
        && "${run[@]}" "$PADAPT" adapt "$mesh" -met "$dir/met.sol" -out "$dir/m$p.meshb" \
             -nosol -json "$dir/r$p.json" >"$dir/adapt$p.log" 2>&1 \
        || { rc=$?; break; }
      mesh="$dir/m$p.meshb"
    done
    t1=$(date +%s.%N)
    echo "$rc $t0 $t1" >"$dir/wall"
    if [ "$rc" = 0 ]; then
      "$PY" "$HERE/levelset_judge.py" "$mesh" "$SHAPE" "$eps" >"$dir/judge.json" 2>"$dir/judge.log"
    fi
    dirs="$dirs $np:$dir"
  done
  # shellcheck disable=SC2086
  "$PY" - "$eps" "$PASSES" "$(nproc)" $dirs <<'PY'
import json, os, sys
eps, passes, ncores = float(sys.argv[1]), int(sys.argv[2]), int(sys.argv[3])
runs = []
for a in sys.argv[4:]:
    np_, d = a.split(":", 1)
    rc, t0, t1 = open(os.path.join(d, "wall")).read().split()
    reps, jud, tmet = [], None, 0.0
    if rc == "0":
        reps = [json.load(open(os.path.join(d, "r%d.json" % p))) for p in range(1, passes + 1)]
        tmet = sum(float(open(os.path.join(d, "metric%d.time" % p)).read().split()[-1])
                   for p in range(1, passes + 1))
        try:
            jud = json.load(open(os.path.join(d, "judge.json")))
        except (OSError, ValueError):
            jud = None
    runs.append((int(np_), d, rc, float(t1) - float(t0), reps, tmet, jud))

def row(name, f):
    cells = []
    for np_, d, rc, wall, reps, tmet, jud in runs:
        if not reps:
            cells.append("FAILED (%s)" % rc)
            continue
        try:
            cells.append(f(reps[-1], reps, np_, tmet, jud, wall))
        except (KeyError, TypeError, ZeroDivisionError):
            cells.append("-")
    print("  %-40s" % name + "".join("%20s" % c for c in cells))

print()
print("## ellipsoid (0.5, 0.1, 0.2) in a ball of radius 10, eps = hmin = %g, %d passes" % (eps, passes))
print("  %-40s" % "processes" + "".join("%20s" % (str(r[0]) + ("*" if r[0] > ncores else "")) for r in runs))
row("initial elements", lambda r, R, p, tm, j, w: "{:,}".format(R[0]["elements_before"]))
row("final elements", lambda r, R, p, tm, j, w: "{:,}".format(r["elements"]))
row("elapsed time: adapt, all passes (s)", lambda r, R, p, tm, j, w: "%.2f" % sum(x["time_s"] for x in R))
row("elapsed time x processes (s)", lambda r, R, p, tm, j, w: "%.2f" % (p * sum(x["time_s"] for x in R)))
row("smallest edge length", lambda r, R, p, tm, j, w: "%.4f" % r["edge_min"])
row("largest edge length", lambda r, R, p, tm, j, w: "%.4f" % r["edge_max"])
row("worst quality, padapt Q (1 = best)", lambda r, R, p, tm, j, w: "%.4f" % r["quality_worst"])
row("worst quality, MMG3D 4: 1/Q", lambda r, R, p, tm, j, w: "%.3f" % (1 / r["quality_worst"]))
row("elements with 1/Q in [1, 2] (%)", lambda r, R, p, tm, j, w: "%.3f" % (100 * r["quality_above_0.5"]))
row("edges in [0.71, 1.41] (%)", lambda r, R, p, tm, j, w: "%.3f" % (100 * r["edge_in_range"]))
print("  -- the interface (bench/levelset_judge.py, exact ellipsoid)")
row("cut elements", lambda r, R, p, tm, j, w: "{:,}".format(j["cut_elements"]))
row("largest distance / eps", lambda r, R, p, tm, j, w: "%.3f" % (j["distance_max"] / eps))
row("99th percentile / eps", lambda r, R, p, tm, j, w: "%.3f" % (j["distance_p99"] / eps))
row("mean distance / eps", lambda r, R, p, tm, j, w: "%.3f" % (j["distance_mean"] / eps))
row("samples within eps (%)", lambda r, R, p, tm, j, w: "%.3f" % (100 * j["within_eps"]))
print("  -- not in the paper")
row("outcome (last pass)", lambda r, R, p, tm, j, w: r.get("outcome", "?"))
row("elements after each pass", lambda r, R, p, tm, j, w: "/".join("%.0fk" % (x["elements"] / 1e3) for x in R))
row("metric, all passes (s, with start-up)", lambda r, R, p, tm, j, w: "%.2f" % tm)
row("final tets / s of adapt (last pass)", lambda r, R, p, tm, j, w: "{:,.0f}".format(r["elements"] / r["time_s"]))
row("command wall time, all passes (s)", lambda r, R, p, tm, j, w: "%.1f" % w)
for np_, d, rc, wall, reps, tmet, jud in runs:
    if not reps:
        print("  np=%d failed (exit %s): see the logs in %s" % (np_, rc, d))
PY
done
echo
echo "# done $(date -u +%Y-%m-%dT%H:%M:%SZ); load: $(cut -d' ' -f1-3 /proc/loadavg)"
