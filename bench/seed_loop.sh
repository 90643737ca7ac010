#!/usr/bin/env bash
# seed_loop.sh -- the adaptation loop of the seed paper's third experiment
# (Lachat, Dobrzynski, Pellegrini, section 5.3: a metric from a solution,
# adapt, evaluate again), on an analytic shock-like layer
# u = tanh(50 (x - 0.5 - 0.1 sin(3 pi y) [cos(2 pi z)])) (bench/seed_field.py)
# standing in for a solver. For each target complexity N of a doubling
# sequence: from the built-in box, ITERS times evaluate u on the mesh, build
# its L2 Hessian metric (`padapt metric hessian -target N`, default -hmin
# and gradation) and adapt to it; then measure the L2 and L-infinity norms
# of u - P1(u) on the adapted mesh (7/14-point quadrature per element). The
# same for uniform meshes (`padapt generate boxNd n`, n giving the vertex
# count nearest the adapted mesh's). Prints the table, the observed orders (error against
# vertices: second order is -2/d) and the gain of the adapted meshes at
# equal vertex count; writes WORKDIR/loop-<dim>d.svg (log-log L2 error).
#
#   bash bench/seed_loop.sh [BUILD] [WORKDIR]
#
# Environment: DIMS ("2 3"), N2D ("250 500 1000 2000 4000 8000"), N3D ("1000
# 2000 4000 8000 16000 32000 64000"), ITERS (4), NP (1; > 1 runs the metric and the
# adaptation under mpiexec -n NP).
set -u
# the piece loop itself at every size (padapt adapt -serial-below)
export PADAPT_SERIAL_BELOW=${PADAPT_SERIAL_BELOW:-0}
BUILD=${1:-build}
WORK=${2:-/tmp/padapt-seed-loop}
PADAPT=$(cd "$BUILD/bin" 2>/dev/null && pwd)/padapt
HERE=$(cd "$(dirname "$0")" && pwd)
PY=/usr/bin/python3
FIELD="$HERE/seed_field.py"
DIMS=${DIMS:-"2 3"}
N2D=${N2D:-"250 500 1000 2000 4000 8000"}
N3D=${N3D:-"1000 2000 4000 8000 16000 32000 64000"}
ITERS=${ITERS:-4}
NP=${NP:-1}
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
export OMPI_MCA_rmaps_base_oversubscribe=1 SCOTCH_PTHREAD_NUMBER=1
[ -x "$PADAPT" ] || { echo "seed_loop: no $PADAPT (build first)" >&2; exit 1; }
mkdir -p "$WORK"
run() { if [ "$NP" -gt 1 ]; then mpiexec -n "$NP" "$PADAPT" "$@"; else "$PADAPT" "$@"; fi; }

echo "# seed_loop: adaptation loop on a tanh layer, $(date -u +%Y-%m-%dT%H:%M:%SZ)"
echo "# host: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //'); load $(cut -d' ' -f1-3 /proc/loadavg)"
echo "# repo $(git -C "$HERE" rev-parse --short HEAD 2>/dev/null); binary $PADAPT; processes $NP; iterations $ITERS"
for dim in $DIMS; do
  table="$WORK/loop-${dim}d.txt"
  : >"$table"
  if [ "$dim" = 2 ]; then list=$N2D; box=20; else list=$N3D; box=8; fi
  printf "\n## %dD   %-8s %8s %9s %9s %12s %12s %8s\n" "$dim" kind N vertices elements L2 Linf time_s
  for n in $list; do
    d="$WORK/${dim}d-$n"
    mkdir -p "$d"
    "$PADAPT" generate "box${dim}d" "$box" "$d/m.mesh" >/dev/null
    t0=$(date +%s.%N)
    for i in $(seq "$ITERS"); do
      $PY "$FIELD" sol "$dim" "$d/m.mesh" "$d/u.sol"
      run metric hessian "$d/m.mesh" -field "$d/u.sol" -target "$n" "$d/h.sol" >/dev/null ||
        { echo "metric hessian failed ($dim D, N $n)"; break; }
      run adapt "$d/m.mesh" -met "$d/h.sol" -out "$d/m2.mesh" -nosol >/dev/null 2>&1 ||
        { echo "adapt failed ($dim D, N $n)"; break; }
      mv "$d/m2.mesh" "$d/m.mesh"
    done
    t1=$(date +%s.%N)
    read -r l2 linf nv ne < <($PY "$FIELD" err "$dim" "$d/m.mesh")
    printf "         %-8s %8d %9d %9d %12.4e %12.4e %8.2f\n" adapted "$n" "$nv" "$ne" "$l2" "$linf" \
      "$(echo "$t1 - $t0" | bc)"
    echo "adapted $n $nv $ne $l2 $linf" >>"$table"
    # uniform: the built-in box with the vertex count nearest the adapted
    # mesh's, (n + 1)^d vertices
    n1=$($PY -c "print(max(1, round($nv ** (1.0 / $dim)) - 1))")
    "$PADAPT" generate "box${dim}d" "$n1" "$d/u.mesh" >/dev/null
    read -r l2 linf nv ne < <($PY "$FIELD" err "$dim" "$d/u.mesh")
    printf "         %-8s %8s %9d %9d %12.4e %12.4e\n" uniform "" "$nv" "$ne" "$l2" "$linf"
    echo "uniform $n $nv $ne $l2 $linf" >>"$table"
  done
  $PY - "$table" "$dim" <<'PYEOF'
import math, sys
rows = [l.split() for l in open(sys.argv[1])]
dim = int(sys.argv[2])
for kind in ("adapted", "uniform"):
    r = [(float(x[2]), float(x[4]), float(x[5])) for x in rows if x[0] == kind]
    if len(r) < 2:
        continue
    def slope(i):
        xs = [math.log(a[0]) for a in r]; ys = [math.log(a[i]) for a in r]
        n = len(xs); mx = sum(xs) / n; my = sum(ys) / n
        return sum((a - mx) * (b - my) for a, b in zip(xs, ys)) / sum((a - mx) ** 2 for a in xs)
    print("   order (log-log slope against vertices) %-8s L2 %6.2f  Linf %6.2f   (second order: %.2f)"
          % (kind, slope(1), slope(2), -2.0 / dim))
    print("     from one N to the next, L2: " + " ".join(
        "%.2f" % (math.log(b[1] / a[1]) / math.log(b[0] / a[0])) for a, b in zip(r, r[1:])))
ad = [x for x in rows if x[0] == "adapted"]; un = [x for x in rows if x[0] == "uniform"]
for a, u in zip(ad, un):
    print("   N %6s: at %s / %s vertices, uniform L2 error / adapted = %.1f, Linf %.1f"
          % (a[1], a[2], u[2], float(u[4]) / float(a[4]), float(u[5]) / float(a[5])))
PYEOF
  $PY "$FIELD" svg "$table" "$WORK/loop-${dim}d.svg" && echo "   plot: $WORK/loop-${dim}d.svg"
done
