#!/usr/bin/env bash
# seed_table1.sh -- the first experiment of Lachat, Dobrzynski, Pellegrini,
# "Parallel mesh adaptation using parallel graph partitioning": isotropic
# refinement of a connecting rod (bench/rod.geo, meshed by gmsh) to a
# constant size H at several process counts, printed as the rows of the
# paper's Table 1, one column per process count.
#
#   bash bench/seed_table1.sh [BUILD_DIR] [WORK_DIR]
#
# Environment: H (the sizes, default "0.05 0.016": a 0.2 M-tetrahedron check,
# then the main run, about 5.5 M tetrahedra), PROCS (default "1 2 4"),
# LC (gmsh's characteristic length for the initial mesh, default 0.2: about
# 3 k tetrahedra), EXTRA (more `padapt adapt` options).
# At 1 process `padapt adapt IN -hsiz H -out OUT.mesh` runs the sequential
# remesher; at P > 1 `mpiexec -n P padapt adapt IN -hsiz H -out OUT.meshb
# -distributed-output` runs the parallel driver. Runs go one after another
# (the machine may have fewer cores than the largest P: such times are
# oversubscribed and say little). gmsh must be on PATH; without it the
# script says so and stops.
#
# Rows, all from each run's JSON report (padapt adapt -json):
#   initial / final elements; elapsed time (time_s: the adaptation, without
#   reading and writing) and that time x processes; smallest and largest
#   edge length in the metric (1 = the prescribed size); worst quality, as
#   padapt's Q (Mmg's normalisation, 1 = regular tetrahedron) and as the
#   paper's MMG3D 4 printed it, 1/Q; the share of elements in the paper's
#   quality bin [1, 2] (1/Q <= 2, i.e. Q >= 0.5: quality_above_0.5); the
#   share of edges with length in [0.71, 1.41] (edge_in_range); then, not in
#   the paper: final tetrahedra per second of time_s, per second x process;
#   peak memory per rank (padapt's counting allocator and the RSS) and bytes
#   per final tetrahedron (the sum over the ranks of those peaks / final
#   elements); the command's wall time (start, I/O and mpiexec included);
#   the 1-minute load average just before the run (times mean little when
#   it is above 0 on a machine that other jobs share).
# Every file of a run stays in WORK_DIR/h<H>-np<P>/.
set -u
# the piece loop itself at every size (padapt adapt -serial-below)
export PADAPT_SERIAL_BELOW=${PADAPT_SERIAL_BELOW:-0}
BUILD=${1:-build}
WORK=${2:-/tmp/padapt-seed-table1}
PADAPT=${PADAPT:-$BUILD/bin/padapt}
H=${H:-"0.05 0.016"}
PROCS=${PROCS:-"1 2 4"}
LC=${LC:-0.2}
EXTRA=${EXTRA:-}
PY=/usr/bin/python3
HERE=$(cd "$(dirname "$0")" && pwd)
GEO="$HERE/rod.geo"
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
export OMPI_MCA_rmaps_base_oversubscribe=1 SCOTCH_PTHREAD_NUMBER=1
MPIEXEC=${MPIEXEC:-mpiexec}

if [ ! -x "$PADAPT" ]; then
  echo "seed_table1: $PADAPT not found (build first: cmake --build $BUILD)" >&2
  exit 1
fi
PADAPT=$(cd "$(dirname "$PADAPT")" && pwd)/$(basename "$PADAPT")
mkdir -p "$WORK"
WORK=$(cd "$WORK" && pwd)

commit=$(git -C "$HERE/.." rev-parse --short HEAD 2>/dev/null || echo unknown)
if [ -n "$(git -C "$HERE/.." status --porcelain --untracked-files=no 2>/dev/null)" ]; then
  commit="$commit (with uncommitted changes)"
fi
echo "# Table 1 of Lachat, Dobrzynski, Pellegrini: isotropic refinement of a connecting rod"
echo "# $(date -u +%Y-%m-%dT%H:%M:%SZ)"
echo "# host: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | sed 's/.*: //'), $(uname -srm), $(free -g | awk '/^Mem:/ {print $2}') GB; load: $(cut -d' ' -f1-3 /proc/loadavg)"
echo "# repo: $(cd "$HERE/.." && pwd) at $commit; binary: $PADAPT"
echo "# sizes H: $H; processes: $PROCS; initial mesh: $GEO, lc $LC; extra options: ${EXTRA:-none}"
echo "# work: $WORK"

if ! command -v gmsh >/dev/null; then
  echo "# SKIPPED: gmsh not on PATH; it makes the initial mesh from $GEO"
  echo "# (apt-get install gmsh, or put an unpacked gmsh >= 4 on PATH)"
  exit 0
fi
echo "# gmsh: $(command -v gmsh) ($(gmsh --version 2>&1 | tail -1))"

# The initial mesh. gmsh writes the boundary triangles (surfaces in a
# Physical Surface group) with their CAD face as reference, so padapt keeps
# the edges between faces (the ridges) as features.
IN="$WORK/rod.mesh"
if ! gmsh -3 "$GEO" -setnumber lc "$LC" -format mesh -o "$IN" >"$WORK/gmsh.log" 2>&1; then
  echo "# gmsh failed, see $WORK/gmsh.log"
  exit 1
fi
"$PADAPT" stats "$IN" -json "$WORK/rod_stats.json" >"$WORK/rod_stats.log" 2>&1
"$PY" - "$WORK/rod_stats.json" <<'PY'
import json, sys
d = json.load(open(sys.argv[1]))
print(f"# initial mesh: {d['vertices']} vertices, {d['elements']} tetrahedra, "
      f"{d['boundary']} boundary triangles, volume {d['volume']:.4f}, "
      f"worst quality {d['quality_worst']:.3f}, "
      f"{'valid' if d['valid'] else 'INVALID'}")
PY

for h in $H; do
  jsons=""
  for np in $PROCS; do
    dir="$WORK/h$h-np$np"
    rm -rf "$dir"
    mkdir -p "$dir"
    json="$dir/r.json" log="$dir/adapt.log"
    load=$(cut -d' ' -f1 /proc/loadavg)
    t0=$(date +%s.%N)
    if [ "$np" = 1 ]; then
      # shellcheck disable=SC2086
      "$PADAPT" adapt "$IN" -hsiz "$h" -out "$dir/out.mesh" -json "$json" $EXTRA \
        >"$log" 2>&1
    else
      # shellcheck disable=SC2086
      "$MPIEXEC" -n "$np" "$PADAPT" adapt "$IN" -hsiz "$h" -out "$dir/out.meshb" \
        -distributed-output -json "$json" $EXTRA >"$log" 2>&1
    fi
    rc=$?
    t1=$(date +%s.%N)
    echo "$rc $t0 $t1 $load" >"$dir/wall"
    jsons="$jsons $np:$dir"
  done
  # shellcheck disable=SC2086
  "$PY" - "$h" "$(nproc)" $jsons <<'PY'
import json, os, sys
h, ncores = sys.argv[1], int(sys.argv[2])
runs = []
for a in sys.argv[3:]:
    np, d = a.split(":", 1)
    rc, t0, t1, load = open(os.path.join(d, "wall")).read().split()
    path = os.path.join(d, "r.json")
    r = json.load(open(path)) if rc == "0" and os.path.exists(path) else None
    runs.append((int(np), d, rc, float(t1) - float(t0), r, load))

def per_rank(r, key):
    if key + "_per_rank" in r:
        return r[key + "_per_rank"]
    return [r[key]] if key in r else []

def row(name, f):
    cells = []
    for np, d, rc, wall, r, load in runs:
        if r is None:
            cells.append(f"FAILED ({rc})")
            continue
        try:
            cells.append(f(r, np, wall))
        except (KeyError, ZeroDivisionError, ValueError):
            cells.append("-")
    print(f"  {name:<38}" + "".join(f"{c:>20}" for c in cells))

print()
print(f"## connecting rod, hsiz {h}")
print(f"  {'processes':<38}" + "".join(
    f"{(str(np) + ('*' if np > ncores else '')):>20}" for np, *_ in runs))
row("initial elements", lambda r, p, w: f"{r['elements_before']:,}")
row("final elements", lambda r, p, w: f"{r['elements']:,}")
row("elapsed time (s)", lambda r, p, w: f"{r['time_s']:.2f}")
row("elapsed time x processes (s)", lambda r, p, w: f"{r['time_s'] * p:.2f}")
row("smallest edge length", lambda r, p, w: f"{r['edge_min']:.4g}")
row("largest edge length", lambda r, p, w: f"{r['edge_max']:.4g}")
row("worst quality, padapt Q (1 = best)", lambda r, p, w: f"{r['quality_worst']:.4g}")
row("worst quality, MMG3D 4: 1/Q", lambda r, p, w: f"{1 / r['quality_worst']:.4g}")
row("elements with 1/Q in [1, 2] (%)", lambda r, p, w: f"{100 * r['quality_above_0.5']:.3f}")
row("edges in [0.71, 1.41] (%)", lambda r, p, w: f"{100 * r['edge_in_range']:.3f}")
print("  -- not in the paper")
row("outcome, valid", lambda r, p, w: f"{r.get('outcome', '?')}, {'yes' if r['valid'] else 'NO'}")
row("mean quality Q", lambda r, p, w: f"{r['quality_mean']:.4f}")
row("volume", lambda r, p, w: f"{r['volume']:.6f}")
row("final tets / s", lambda r, p, w: f"{r['elements'] / r['time_s']:,.0f}")
row("final tets / (s x processes)", lambda r, p, w: f"{r['elements'] / (r['time_s'] * p):,.0f}")
row("iterations (parallel driver)", lambda r, p, w: str(r['iterations']) if 'iterations' in r else "-")
row("peak padapt memory/rank (MB)", lambda r, p, w: "/".join(
    f"{m / 1e6:.0f}" for m in per_rank(r, "peak_memory_bytes")))
row("peak RSS/rank (MB)", lambda r, p, w: "/".join(
    f"{m / 1e6:.0f}" for m in per_rank(r, "peak_rss_bytes")))
row("padapt memory / final tet (B)", lambda r, p, w:
    f"{sum(per_rank(r, 'peak_memory_bytes')) / r['elements']:.0f}")
row("RSS / final tet (B)", lambda r, p, w:
    f"{sum(per_rank(r, 'peak_rss_bytes')) / r['elements']:.0f}")
row("command wall time (s)", lambda r, p, w: f"{w:.2f}")
print(f"  {'load average before the run':<38}" + "".join(f"{x[5]:>20}" for x in runs))
if any(np > ncores for np, *_ in runs):
    print(f"  * {ncores} cores: more processes than cores, the times are oversubscribed")
for np, d, rc, wall, r, load in runs:
    if r is None:
        print(f"  np={np} failed (exit {rc}): see {d}/adapt.log")
PY
done
echo
echo "# done $(date -u +%Y-%m-%dT%H:%M:%SZ); load: $(cut -d' ' -f1-3 /proc/loadavg)"
