#!/usr/bin/env bash
# freefem.sh -- the full FreeFem++ loops of examples/freefem (issue #34):
# steady2d (Poisson on the L-shape), steady3d (the L-shaped prism) and
# unsteady2d (an advected hill, fixed-point method), each a real solver in
# the loop with padapt adapting under mpiexec -n NP. Writes
# WORKDIR/CASE.json and WORKDIR/CASE.svg per case (examples/freefem/run.sh)
# and prints, per case, the adapted and uniform series and what the last
# adapted mesh reaches: its error against the finest uniform mesh's, and the
# uniform error at its vertex count (log-log interpolation; unsteady: at
# the same space-time cost, vertices being the mean over the time steps).
#
#   bash bench/freefem.sh [BUILD] [WORKDIR]
#
# Environment: CASES ("steady2d steady3d unsteady2d"), NP (2).
set -u
BUILD=${1:-build}
WORK=${2:-/tmp/padapt-freefem}
HERE=$(cd "$(dirname "$0")" && pwd)
export PADAPT=$(cd "$BUILD/bin" 2> /dev/null && pwd)/padapt
export NP=${NP:-2}
CASES=${CASES:-"steady2d steady3d unsteady2d"}
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
export OMPI_MCA_rmaps_base_oversubscribe=1 SCOTCH_PTHREAD_NUMBER=1
[ -x "$PADAPT" ] || { echo "freefem: no $PADAPT (build first)" >&2; exit 1; }
mkdir -p "$WORK"
echo "freefem: $(git -C "$HERE" rev-parse --short HEAD 2> /dev/null), NP=$NP, load $(cut -d' ' -f1-3 /proc/loadavg)"
for c in $CASES; do
  t0=$(date +%s)
  bash "$HERE/../examples/freefem/run.sh" "$WORK" "$c" > "$WORK/$c.log" 2>&1 ||
    { echo "freefem: $c failed, see $WORK/$c.log" >&2; tail -5 "$WORK/$c.log" >&2; exit 1; }
  echo
  echo "== $c ($(($(date +%s) - t0)) s, load $(cut -d' ' -f1-3 /proc/loadavg)): $WORK/$c.json, $WORK/$c.svg"
  /usr/bin/python3 - "$WORK/$c.json" <<'EOF'
import json, math, sys
d = json.load(open(sys.argv[1]))
u = sorted(d["uniform"], key=lambda p: p["vertices"])
a = d["adapted"]
print("%-9s %10s %10s %12s %9s" % ("", "vertices", "elements", "L2 error", "seconds"))
for p in u:
    print("%-9s %10d %10d %12.4e" % ("uniform", p["vertices"], p["elements"], p["error"]))
for p in a:
    print("%-9s %10d %10d %12.4e %9.1f" % ("adapted", p["vertices"], p["elements"],
                                            p["error"], p["seconds"]))
def uni(v):
    for (va, ea), (vb, eb) in zip([(p["vertices"], p["error"]) for p in u],
                                  [(p["vertices"], p["error"]) for p in u[1:]]):
        if va <= v <= vb:
            t = math.log(v / va) / math.log(vb / va)
            return math.exp((1 - t) * math.log(ea) + t * math.log(eb))
    return None
last, fine = a[-1], u[-1]
print("last adapted: %d vertices, error %.3e; finest uniform: %d vertices, error %.3e"
      % (last["vertices"], last["error"], fine["vertices"], fine["error"]))
print("  error ratio finest uniform / last adapted %.2f with %.3f of its vertices "
      "(at most its error with at most a quarter of its vertices: %s)"
      % (fine["error"] / last["error"], last["vertices"] / fine["vertices"],
         "yes" if last["error"] <= fine["error"] and 4 * last["vertices"] <= fine["vertices"]
         else "no"))
# vertices at which the adapted series reaches the finest uniform error
pts = sorted((p["vertices"], p["error"]) for p in a)
reach = None
if pts[0][1] <= fine["error"]:
    reach = "at most %d (its first iteration is already below)" % pts[0][0]
for (va, ea), (vb, eb) in zip(pts, pts[1:]):
    if reach is None and ea >= fine["error"] >= eb:
        t = math.log(fine["error"] / ea) / math.log(eb / ea)
        reach = "about %d" % math.exp((1 - t) * math.log(va) + t * math.log(vb))
if reach:
    n = int(reach.split()[-1]) if reach.startswith("about") else pts[0][0]
    print("  the adapted series reaches the finest uniform error with %s vertices: "
          "1/%.0f of its %d" % (reach, fine["vertices"] / n, fine["vertices"]))
for p in a:
    e = uni(p["vertices"])
    if e:
        print("  at %d vertices: uniform %.3e / adapted %.3e = %.1f"
              % (p["vertices"], e, p["error"], e / p["error"]))
EOF
done
