#!/usr/bin/env bash
# The built-in example: the unit square meshed coarsely, the spherical-shell
# anisotropic metric, and a 2-process parallel adaptation (the seed paper's
# piece loop). Prints the input statistics, the progress lines and the final
# report, and leaves the meshes and a VTK file in demo-out/.
set -euo pipefail
build=${1:-build}
padapt="$build/bin/padapt"
out=demo-out
mkdir -p "$out"
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
export OMPI_MCA_rmaps_base_oversubscribe=1 SCOTCH_PTHREAD_NUMBER=1

echo "== padapt demo: unit square, 'shell' anisotropic metric, 2 processes =="
"$padapt" generate box2d 20 "$out/square.mesh"
"$padapt" metric shell:0.05 "$out/square.mesh" "$out/square.sol"
echo
echo "-- input mesh, lengths and qualities in the metric --"
"$padapt" stats "$out/square.mesh" -met "$out/square.sol" -json "$out/input.json"
echo
echo "-- mpiexec -n 2 padapt adapt --"
# the example is small: -serial-below 0 shares it out all the same, to show
# the piece loop (by default rank 0 would adapt it alone)
mpiexec -n 2 "$padapt" adapt "$out/square.mesh" -met "$out/square.sol" \
  -serial-below 0 -out "$out/adapted.mesh" -json "$out/report.json" -svg "$out/hist.svg"
"$padapt" convert "$out/adapted.mesh" "$out/adapted.vtu" -met "$out/adapted.sol"
echo
echo "Output in $out/: adapted.mesh + adapted.sol (mesh and metric), report.json,"
echo "adapted.vtu (ParaView: cell data 'quality', 'ref' and 'entity', point data 'metric'"
echo "and 'size' for the Tensor Glyph filter), hist.svg (the histograms before and after),"
echo "and the input square.mesh + square.sol."
