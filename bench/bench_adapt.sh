#!/usr/bin/env bash
# bench_adapt.sh -- parallel adaptation benchmark (issue #6): 2D and 3D
# uniform refinement to >= 1 M elements at 1 and 2 processes (timed), and at
# 4 and 8 processes oversubscribed (correctness only: the machine has fewer
# cores, so those times mean nothing). Prints, from each run's JSON report:
# wall time, parallel efficiency T1 / (P x TP), the per-step breakdown,
# bytes moved, peak memory per rank, the output size and quality.
#
#   bash bench/bench_adapt.sh [BUILD_DIR] [WORK_DIR]
#
# Environment: PROCS (default "1 2 4 8"), TIMED (default "1 2"),
# H2D / H3D (target sizes, default 0.0013 and 0.012: 1.28 M triangles and
# 5.8 M tetrahedra), N2D / N3D (initial boxes, default 100 and 20; box3d 10
# -> 0.019, 0.84 M tetrahedra, is the quick 3D case),
# EXTRA (more `padapt adapt` options, e.g. "-nomove"), DIMS (default "2 3").
# At 1 process `padapt adapt` runs the sequential remesher (the baseline);
# at P > 1 the parallel driver (pa_dmesh_adapt). 3D is skipped with a message
# when the built-in remesher does not handle tetrahedra yet.
set -u
BUILD=${1:-build}
WORK=${2:-/tmp/padapt-bench-adapt}
PADAPT=${PADAPT:-$BUILD/bin/padapt}
PROCS=${PROCS:-"1 2 4 8"}
TIMED=${TIMED:-"1 2"}
H2D=${H2D:-0.0013}
H3D=${H3D:-0.012}
N2D=${N2D:-100}
N3D=${N3D:-20}
EXTRA=${EXTRA:-}
DIMS=${DIMS:-"2 3"}
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
export OMPI_MCA_rmaps_base_oversubscribe=1 SCOTCH_PTHREAD_NUMBER=1
MPIEXEC=${MPIEXEC:-mpiexec}

if [ ! -x "$PADAPT" ]; then
  echo "bench_adapt: $PADAPT not found (build first: make build)" >&2
  exit 1
fi
mkdir -p "$WORK"
echo "# padapt parallel adaptation benchmark, $(date -u +%Y-%m-%dT%H:%M:%SZ)"
echo "# host: $(nproc) cores, $(uname -srm); load: $(cut -d' ' -f1-3 /proc/loadavg)"
echo "# binary: $PADAPT; extra options: ${EXTRA:-none}"

run_case() { # dim n h
  local dim=$1 n=$2 h=$3 tag="box${1}d"
  local in="$WORK/$tag.meshb"
  "$PADAPT" generate "$tag" "$n" "$in" || return 1
  if [ "$dim" = 3 ]; then
    # probe: does the built-in remesher handle tetrahedra?
    "$PADAPT" generate box3d 2 "$WORK/probe.mesh" >/dev/null 2>&1
    if ! "$PADAPT" adapt "$WORK/probe.mesh" -hsiz 0.3 -out "$WORK/probe_out.mesh" \
         >"$WORK/probe.log" 2>&1; then
      echo "## 3D skipped: the built-in remesher cannot adapt tetrahedra yet:"
      grep -m1 padapt "$WORK/probe.log" | sed 's/^/##   /'
      return 0
    fi
  fi
  echo
  echo "## ${dim}D uniform refinement: box${dim}d $n -> hsiz $h"
  for np in $PROCS; do
    local json="$WORK/${tag}_np$np.json" log="$WORK/${tag}_np$np.log"
    rm -f "$json"
    local t0 t1
    t0=$(date +%s.%N)
    # shellcheck disable=SC2086
    "$MPIEXEC" -n "$np" "$PADAPT" adapt "$in" -hsiz "$h" \
      -out "$WORK/${tag}_np$np.meshb" -nosol -json "$json" $EXTRA >"$log" 2>&1
    local rc=$?
    t1=$(date +%s.%N)
    local timed=no
    for t in $TIMED; do [ "$t" = "$np" ] && timed=yes; done
    python3 - "$json" "$np" "$rc" "$t0" "$t1" "$timed" "$WORK/${tag}_np1.json" <<'PY'
import json, sys, os
path, np, rc, t0, t1, timed, base = sys.argv[1:8]
np = int(np); wall = float(t1) - float(t0)
if rc != "0" or not os.path.exists(path):
    print(f"  P={np}: FAILED (exit {rc}), see {path[:-5]}.log")
    sys.exit(0)
d = json.load(open(path))
t = d.get("time_s", 0.0)
line = (f"  P={np}: {d.get('elements_before', '?')} -> {d['elements']} elements, "
        f"adapt {t:.2f} s (command wall {wall:.2f} s), "
        f"edges in range {100*d.get('edge_in_range', 0):.2f} %, "
        f"worst Q {d.get('quality_worst', 0):.3f}, valid {d.get('valid')}")
print(line)
if np > 1 and "steps_s" not in d:
    print("    (sequential report: `padapt adapt` is not wired to the parallel "
          "driver at P > 1)")
    sys.exit(0)
if os.path.exists(base) and np > 1:
    b = json.load(open(base))
    t1s = b.get("time_s", 0.0)
    if timed == "yes" and t > 0:
        print(f"    parallel efficiency T1/(P TP) = {t1s:.2f}/({np} x {t:.2f}) "
              f"= {100*t1s/(np*t):.0f} %")
    elif t > 0:
        print(f"    (oversubscribed: {np} processes on {os.cpu_count()} cores, "
              f"time not meaningful)")
if "steps_s" in d:
    s = d["steps_s"]
    tot = sum(s.values())
    parts = ", ".join(f"{k} {v:.2f}" for k, v in s.items())
    print(f"    steps (s): {parts}; remeshing {100*s['remesh']/t if t else 0:.0f} % "
          f"of the adapt time")
    print(f"    iterations {d['iterations']} ({'converged' if d['converged'] else 'stalled'}), "
          f"pieces {d['pieces']}, rolled back {d['pieces_rolled_back']}, "
          f"bytes moved {d['bytes_moved']/1e6:.1f} MB")
    mem = ", ".join(f"{m/1e6:.0f}" for m in d["peak_memory_bytes_per_rank"])
    rss = ", ".join(f"{m/1e6:.0f}" for m in d["peak_rss_bytes_per_rank"])
    print(f"    peak padapt memory per rank (MB): {mem}; peak RSS (MB): {rss}")
    for it in d.get("iteration_detail", []):
        print(f"      iter {it['iter']}: {it['tagged']} tagged, {it['pieces']} pieces, "
              f"imbalance {it['imbalance']:.2f}, remesh {it['remesh_s']:.2f} s, "
              f"reintegrate {it['reintegrate_s']:.2f} s")
else:
    print(f"    sequential: peak RSS {d.get('peak_rss_bytes', 0)/1e6:.0f} MB")
PY
  done
}

for dim in $DIMS; do
  if [ "$dim" = 2 ]; then run_case 2 "$N2D" "$H2D"; else run_case 3 "$N3D" "$H3D"; fi
done
