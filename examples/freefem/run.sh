#!/usr/bin/env bash
# examples/freefem/run.sh OUTDIR CASE [small]
#
# A real solver in the adaptation loop: FreeFem++ solves, padapt builds the
# metric from the solution and adapts the mesh (under mpiexec, NP processes,
# the solution carried onto the new mesh), FreeFem++ solves again.
#
#   CASE steady2d    Poisson on an L-shaped domain (corner singularity)
#        steady3d    the same on the L-shaped prism (edge singularity)
#        unsteady2d  an advected hill, fixed-point method over time windows
#   small            the short version the tests run (a few seconds)
#
# Writes OUTDIR/CASE.json
#   {"case": CASE, "adapted": [{"vertices", "elements", "error", "seconds"}...],
#    "uniform": [{"vertices", "elements", "error"}...]}
# (error: the L2 norm of the error against the exact solution; unsteady:
# at the final time, vertices and elements the means over the time steps,
# so equal values cost the same space-time work) and OUTDIR/CASE.svg (error
# against vertices, adapted and uniform), the meshes and solutions in
# OUTDIR/CASE/, and the log of every step on stdout.
#
# Environment: PADAPT (default: padapt on PATH), MPIEXEC (mpiexec), NP (2).
set -euo pipefail

[ $# -ge 2 ] || { echo "usage: $0 OUTDIR steady2d|steady3d|unsteady2d [small]" >&2; exit 2; }
outdir=$1
case=$2
size=${3:-full}
here=$(cd "$(dirname "$0")" && pwd)
PADAPT=${PADAPT:-padapt}
MPIEXEC=${MPIEXEC:-mpiexec}
NP=${NP:-2}
command -v FreeFem++ > /dev/null || { echo "$0: FreeFem++ not found (scripts/install-deps.sh installs it)" >&2; exit 1; }

# Debian's freefem++ looks for its plugins (load "msh3", "medit") and its
# .idp files where its configuration file says, /usr/lib/ff++/VERSION/, but
# installs them where `dpkg -L libfreefem++` lists (/usr/lib/freefem++):
# FF_LOADPATH pointing there makes load work. include "getARGV.idp" fails
# for the same reason; the scripts read the built-in ARGV array instead.
if [ -z "${FF_LOADPATH:-}" ] && command -v dpkg > /dev/null; then
  plugin=$(dpkg -L libfreefem++ 2> /dev/null | grep '/msh3\.so$' | head -1 || true)
  [ -n "$plugin" ] && export FF_LOADPATH=$(dirname "$plugin")
fi

work=$outdir/$case
mkdir -p "$work"
work=$(cd "$work" && pwd)
json=$(cd "$outdir" && pwd)/$case.json
cd "$work"

ff() { FreeFem++ -nw -v 0 "$here/$1" "${@:2}"; }
adapt() { "$MPIEXEC" -n "$NP" "$PADAPT" -v -1 adapt "$@"; }
now() { date +%s.%N; }
calc() { awk "BEGIN {printf \"%.10g\", $*}"; }
field() { awk -v k="$1" -v w="$2" '$1 == k {print $w; exit}'; }   # word w of line "k ..."
adapted=()
uniform=()

# ---------------------------------------------------------------- steady
# solve on uniform meshes; then from the coarse one: Hessian metric at a
# growing complexity -> adapt with the solution carried -> solve, and
# compare the carried solution with FreeFem++'s own interpolation.
steady() {
  local edp=$1 start=$2 ns=$3 targets=$4 r
  for n in $ns; do
    r=$(ff "$edp" -n "$n" | field RESULT 0)
    echo "uniform n=$n: $r"
    uniform+=("$(echo "$r" | awk '{printf "{\"vertices\": %d, \"elements\": %d, \"error\": %s}", $2, $3, $4}')")
  done
  echo "start n=$start: $(ff "$edp" -n "$start" -savemesh m0.mesh -sol u0.sol | field RESULT 0)"
  local k=0 t0 out
  for c in $targets; do
    t0=$(now)
    "$PADAPT" metric hessian m$k.mesh -field u$k.sol -target "$c" met$k.sol
    adapt m$k.mesh -met met$k.sol -field u$k.sol -outfield carried$((k + 1)).sol \
      -out m$((k + 1)).mesh -nosol
    out=$(ff "$edp" -mesh m$((k + 1)).mesh -sol u$((k + 1)).sol -carried carried$((k + 1)).sol \
      -prevmesh m$k.mesh -prevsol u$k.sol)
    k=$((k + 1))
    r=$(echo "$out" | field RESULT 0)
    echo "adapted $k, complexity $c: $r; carried vs interpolated (L2, max): $(echo "$out" | field CARRIED 0 | cut -d' ' -f2-)"
    adapted+=("$(echo "$r" | awk -v s="$(calc "$(now) - $t0")" \
      '{printf "{\"vertices\": %d, \"elements\": %d, \"error\": %s, \"seconds\": %.2f}", $2, $3, $4, s}')")
  done
}

# -------------------------------------------------------------- unsteady
# The fixed-point method (Alauzet et al.): the time span cut into windows,
# each with its own mesh. A pass solves over all windows; for each window
# the Hessian metrics of its samples are intersected (the mesh must suit
# the solution all along the window), then every window's metric is scaled
# so that the space-time complexity (each window's complexity times its
# steps, summed) is the budget, in proportion to the complexity of the
# intersection at a common scale (each sample's metric at the same
# complexity): windows where the solution needs more get more. The next
# pass runs on the meshes adapted to them, each from the same window's
# mesh, carrying the window's first state (the next pass compares it with
# the state that arrives there: the fixed point's change).
unsteady() {
  local windows=$1 steps=$2 samples=$3 passes=$4 start=$5 ns=$6 budgets=$7 r
  local opts=(-windows "$windows" -steps "$steps" -samples "$samples")
  for n in $ns; do
    r=$(ff unsteady2d.edp "${opts[@]}" -n "$n" -meshes uni$n -out uni$n | field RESULT 0)
    echo "uniform n=$n: $r"
    uniform+=("$(echo "$r" | awk '{printf "{\"vertices\": %d, \"elements\": %d, \"error\": %s}", $2, $3, $4}')")
    rm -f uni$n.*
  done
  local c wsteps=$((steps / windows)) t0 out pass i k
  for c in $budgets; do
    t0=$(now)
    ff unsteady2d.edp "${opts[@]}" -n "$start" -meshes c$c.p0 -out c$c.p0.s > /dev/null
    for pass in $(seq 1 "$passes"); do
      local prev=c$c.p$((pass - 1)) next=c$c.p$pass total=0
      for i in $(seq 1 "$windows"); do
        "$PADAPT" metric hessian $prev.$i.mesh -field $prev.s.$i.0.sol -target "$c" $prev.met.$i.sol > /dev/null
        for k in $(seq 1 "$samples"); do
          "$PADAPT" metric hessian $prev.$i.mesh -field $prev.s.$i.$k.sol -target "$c" h.sol > /dev/null
          "$PADAPT" metric intersect $prev.$i.mesh $prev.met.$i.sol h.sol hi.sol
          mv hi.sol $prev.met.$i.sol
        done
        local ci
        ci=$("$PADAPT" metric complexity $prev.$i.mesh $prev.met.$i.sol | awk '{print $3; exit}')
        echo "$ci" > $prev.cplx.$i
        total=$(calc "$total + $wsteps * $ci")
      done
      for i in $(seq 1 "$windows"); do
        local ci target
        ci=$(cat $prev.cplx.$i)
        target=$(calc "$c * $steps * $ci / $total")
        "$PADAPT" metric scale $prev.$i.mesh $prev.met.$i.sol -target "$target" hs.sol
        mv hs.sol $prev.met.$i.sol
        adapt $prev.$i.mesh -met $prev.met.$i.sol -field $prev.s.$i.0.sol \
          -outfield $next.carried.$i.sol -out $next.$i.mesh -nosol
      done
      out=$(ff unsteady2d.edp "${opts[@]}" -meshes $next -out $next.s -carried $next.carried)
      r=$(echo "$out" | field RESULT 0)
      echo "budget $c, pass $pass: $r; fixed-point change per window:" \
        $(echo "$out" | awk '$1 == "CHANGE" {printf " %.3g", $3}')
    done
    adapted+=("$(echo "$r" | awk -v s="$(calc "$(now) - $t0")" \
      '{printf "{\"vertices\": %d, \"elements\": %d, \"error\": %s, \"seconds\": %.2f}", $2, $3, $4, s}')")
  done
}

case $case:$size in
  steady2d:full) steady steady2d.edp 8 "4 8 16 32 64 128" "500 1000 2000 4000 8000" ;;
  steady2d:small) steady steady2d.edp 8 "8 16 32" "300 600 1200" ;;
  steady3d:full) steady steady3d.edp 8 "4 8 12 16 24" "1000 2000 4000 8000 16000" ;;
  steady3d:small) steady steady3d.edp 4 "4 8" "300 600" ;;
  unsteady2d:full) unsteady 8 48 3 3 32 "16 32 64 128 256" "500 1000 2000 4000" ;;
  unsteady2d:small) unsteady 3 12 1 2 16 "16 32 64" "800" ;;
  *) echo "$0: unknown case '$case' or size '$size'" >&2; exit 2 ;;
esac

join() { local IFS=,; echo "$*"; }
{
  echo "{\"case\": \"$case\","
  echo " \"adapted\": [$(join "${adapted[@]}")],"
  echo " \"uniform\": [$(join "${uniform[@]}")]}"
} > "$json.tmp"
mv "$json.tmp" "$json"
python3 "$here/plot.py" "$json" "${json%.json}.svg"
echo "wrote $json and ${json%.json}.svg"
