#!/usr/bin/env bash
# python_overhead.sh -- what calling padapt through Python costs on ~1 M
# element sequential adaptations.
#
#   bash bench/python_overhead.sh [BUILD [WORKDIR [PAIRS]]]   (default build /tmp/pyovh 3)
#
# Cases: 2d and 3d refine a coarse box with a constant size (-hsiz) to about
# 1 M elements; 2d-aniso adapts the 0.8 M-triangle result of 2d to the
# anisotropic "layer" metric (about 1 M triangles), given to the CLI as a
# .sol file and to Python as a numpy array of tensors (so the Python layer
# checks and copies a 0.8 M-element mesh and its 0.4 M tensors).
# Per case, PAIRS interleaved pairs of the same adaptation:
#   cli     `padapt adapt IN (-hsiz H | -met M.sol) -out OUT.meshb -nosol`
#   python  python3: padapt.read(IN), padapt.adapt(mesh, ...), new.write(OUT)
# both wall-clock, process start included. The CLI starts MPI (MPI_Init,
# about 0.5 s here) and the sequential Python path does not, so the
# end-to-end figures differ by more than the binding. The binding's own
# cost is measured inside the Python process: the wall time of the
# padapt.adapt() call against the wall time of the pa_remesh call it makes
# (timed around the ctypes call); the difference is what the Python layer
# adds (argument checks, copy of the input mesh, metric and fields, the
# report); pa_remesh is the same C call the CLI makes. Also: building a
# Mesh of the result from numpy arrays (what a solver's arrays cost to come
# in) and reading its arrays (views). Medians of the pairs are printed.
set -euo pipefail
BUILD=${1:-build}
W=${2:-/tmp/pyovh}
PAIRS=${3:-3}
SRC=$(cd "$(dirname "$0")/.." && pwd)
PADAPT=$(cd "$BUILD" && pwd)/bin/padapt
export PADAPT_LIB=$(cd "$BUILD" && pwd)/lib/libpadapt.so PYTHONPATH=$SRC/python
mkdir -p "$W"
cd "$W"
"$PADAPT" generate box2d 20 in2d.meshb > /dev/null
"$PADAPT" generate box3d 6 in3d.meshb > /dev/null

now() { date +%s.%N; }

python_run() { # IN KWARGS OUT -> "adapt_call pa_remesh_call nelem build_s views_s"
  /usr/bin/python3 - "$1" "$2" "$3" <<'PY'
import sys, time
import numpy as np
import padapt
from padapt import _lib
src, kwargs, out = sys.argv[1], sys.argv[2], sys.argv[3]
c_remesh, timed = _lib.lib.pa_remesh, []
def remesh(*args):
    t = time.perf_counter()
    st = c_remesh(*args)
    timed.append(time.perf_counter() - t)
    return st
_lib.lib.pa_remesh = remesh
mesh = padapt.read(src)
kw = eval("dict(%s)" % kwargs, {"padapt": padapt, "mesh": mesh})
t = time.perf_counter()
new, fields, rep = padapt.adapt(mesh, **kw)
call = time.perf_counter() - t
new.write(out)
t = time.perf_counter()
arrays = (new.points, new.cells, new.boundary, new.boundary_refs)
views = time.perf_counter() - t
t = time.perf_counter()
again = padapt.Mesh(*arrays[:3], boundary_refs=arrays[3], cell_refs=new.cell_refs)
build = time.perf_counter() - t
print(call, timed[0], new.nelem, build, views)
PY
}

median() { sort -g | awk '{a[NR]=$1} END {print (NR%2) ? a[(NR+1)/2] : (a[NR/2]+a[NR/2+1])/2}'; }

run_case() { # NAME IN "CLI ARGS" "PYTHON KWARGS"
  local d=$1 in=$2 cargs=$3 pargs=$4
  : > cli.$d; : > py.$d; : > call.$d
  for p in $(seq "$PAIRS"); do
    t0=$(now); "$PADAPT" adapt "$in" $cargs -out out_cli$d.meshb -nosol > /dev/null; t1=$(now)
    echo "$t1 - $t0" | bc -l >> cli.$d
    t0=$(now); r=$(python_run "$in" "$pargs" out_py$d.meshb); t1=$(now)
    echo "$t1 - $t0" | bc -l >> py.$d
    echo "$r" >> call.$d
  done
  local ne cli py callw rem ovh build views
  ne=$(awk '{print $3}' call.$d | head -1)
  cli=$(median < cli.$d) py=$(median < py.$d)
  callw=$(awk '{print $1}' call.$d | median) rem=$(awk '{print $2}' call.$d | median)
  ovh=$(awk '{print $1 - $2}' call.$d | median)
  build=$(awk '{print $4}' call.$d | median) views=$(awk '{print $5}' call.$d | median)
  printf '%s: %s -> %s elements, %s pairs (medians):\n' "$d" "$cargs" "$ne" "$PAIRS"
  printf '  end to end: cli %.2f s, python %.2f s (%+.1f %%)\n' "$cli" "$py" \
    "$(echo "100 * ($py - $cli) / $cli" | bc -l)"
  printf '  padapt.adapt() call %.3f s, of which the pa_remesh call %.3f s: Python layer %.3f s (%.2f %%)\n' \
    "$callw" "$rem" "$ovh" "$(echo "100 * $ovh / $rem" | bc -l)"
  printf '  Mesh from numpy arrays of the result %.3f s; arrays out (views) %.6f s\n' "$build" "$views"
}

echo "machine: $(nproc) cores, $(awk '/MemTotal/ {printf "%.0f GiB", $2/1048576}' /proc/meminfo), load $(cut -d' ' -f1-3 /proc/loadavg)"
run_case 2d in2d.meshb "-hsiz 0.0017" "hsiz=0.0017"
"$PADAPT" adapt in2d.meshb -hsiz 0.0017 -out aniso_in.meshb -nosol > /dev/null
"$PADAPT" metric layer:0.0025 aniso_in.meshb layer.sol > /dev/null
run_case 2d-aniso aniso_in.meshb "-met layer.sol" "metric=padapt.metric.analytic(mesh, 'layer:0.0025')"
run_case 3d in3d.meshb "-hsiz 0.0235" "hsiz=0.0235"
