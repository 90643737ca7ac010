#!/usr/bin/env bash
# scale.sh -- the scaling ladder of the parallel adaptation: the gmsh
# connecting rod (tests/data/rod3d.mesh, 2 899 tets) refined uniformly to
# about 1 M, 5 M, 20 M and 100 M tetrahedra by `mpiexec -n NP padapt adapt
# -distributed-output`, one rung after the other.
#
#   bash bench/scale.sh BUILD_DIR WORK_DIR [RUNG...]
#
# RUNG: 1M 5M 20M 100M (default "1M 5M"; each is an -hsiz on the rod, from
# N ~ 0.81 M x (0.03 / hsiz)^3) or any -hsiz value. Environment: NP (default
# 2), ARGS (more adapt options, e.g. "-mem 6000"), KEEP=1 keeps each rung's
# output set (deleted by default: the 100 M set takes ~10 GB).
#
# Per rung it prints: output elements, wall time of the whole command (read,
# adapt, statistics, write) and of the adaptation loop (report time_s),
# elements per second of the loop, the peak of padapt's counted memory and
# of the RSS per rank, and bytes per output element (sum over the ranks of
# each peak / elements); then per iteration the time of each step and the
# peak counted memory of each step (max over the ranks) with the bytes held
# after it, from the -json report. Figures are wall clock: they are only
# comparable on a quiet machine, and the load is printed first.
set -u
BUILD=${1:?BUILD_DIR}
WORK=${2:?WORK_DIR}
shift 2
RUNGS=${*:-1M 5M}
NP=${NP:-2}
ARGS=${ARGS:-}
PADAPT=$(cd "$BUILD" && pwd)/bin/padapt
ROOT=$(cd "$(dirname "$0")/.." && pwd)
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
export OMPI_MCA_rmaps_base_oversubscribe=1 SCOTCH_PTHREAD_NUMBER=1
mkdir -p "$WORK"
echo "# scale: rod3d, np=$NP $ARGS, $(date -u +%Y-%m-%dT%H:%M:%SZ)"
echo "# host: $(nproc) cores, $(awk '/MemTotal/ {printf "%.1f GiB", $2 / 1048576}' /proc/meminfo)," \
     "$(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //'); load $(cut -d' ' -f1-3 /proc/loadavg)"
echo "# repo $(git -C "$ROOT" rev-parse --short HEAD 2>/dev/null); binary $PADAPT"
for rung in $RUNGS; do
  case $rung in
    1M) h=0.028 ;;
    5M) h=0.0164 ;;
    20M) h=0.0103 ;;
    100M) h=0.0060 ;;
    *) h=$rung ;;
  esac
  d="$WORK/h$h"
  rm -rf "$d"
  mkdir -p "$d"
  t0=$(date +%s.%N)
  # shellcheck disable=SC2086
  mpiexec -n "$NP" "$PADAPT" adapt "$ROOT/tests/data/rod3d.mesh" -hsiz "$h" $ARGS \
    -out "$d/out.meshb" -distributed-output -json "$d/r.json" -v 3 \
    >"$d/log" 2>&1
  rc=$?
  t1=$(date +%s.%N)
  if [ $rc -ne 0 ] || [ ! -s "$d/r.json" ]; then
    echo "rung $rung (hsiz $h): FAILED (exit $rc), see $d/log"
    tail -5 "$d/log"
    continue
  fi
  /usr/bin/python3 - "$d/r.json" "$rung" "$h" "$t0" "$t1" <<'EOF'
import json, sys
r = json.load(open(sys.argv[1]))
rung, h, wall = sys.argv[2], sys.argv[3], float(sys.argv[5]) - float(sys.argv[4])
ne, t = r["elements"], r["time_s"]
mem, rss = r["peak_memory_bytes_per_rank"], r["peak_rss_bytes_per_rank"]
print(f"rung {rung:>5} hsiz {h}: {ne:,} tets, wall {wall:.1f} s (loop {t:.1f} s), "
      f"{ne / t:,.0f} tets/s, {r['iterations']} iterations, in range "
      f"{100 * r['edge_in_range']:.2f} %, worst Q {r['quality_worst']:.3f}")
print(f"  peak per rank: counted {' '.join(f'{m / 2**20:.0f}' for m in mem)} MiB, "
      f"RSS {' '.join(f'{m / 2**20:.0f}' for m in rss)} MiB; "
      f"{sum(mem) / ne:.1f} B/tet counted, {sum(rss) / ne:.1f} B/tet RSS")
s = r["steps_s"]
print("  steps (s): " + ", ".join(f"{k} {v:.2f}" for k, v in s.items()))
for it in r["iteration_detail"]:
    pb = it["peak_bytes"]
    print(f"  iter {it['iter']}: {it['elements']:,} tets, {it['pieces']} pieces, "
          f"imbalance {it['imbalance']:.2f}; s: " +
          " ".join(f"{k} {it[k + '_s']:.2f}" for k in
                   ("tag", "pieces", "gather", "remesh", "reintegrate")) +
          "; peak MiB: " + " ".join(f"{k} {v / 2**20:.0f}" for k, v in pb.items()) +
          f"; held after {it['bytes_after'] / 2**20:.0f} MiB "
          f"({it['bytes_after'] * len(mem) / max(it['elements'], 1):.0f} B/tet x ranks)")
EOF
  [ "${KEEP:-0}" = 1 ] || rm -f "$d"/out.*
done
