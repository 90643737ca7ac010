#!/usr/bin/env bash
# The built-in example: a unit square meshed coarsely, a spherical-shell
# anisotropic metric, statistics, and a VTK file to look at.
set -euo pipefail
build=${1:-build}
padapt="$build/bin/padapt"
out=demo-out
mkdir -p "$out"
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
export OMPI_MCA_rmaps_base_oversubscribe=1 SCOTCH_PTHREAD_NUMBER=1

echo "== padapt demo: unit square, 'shell' anisotropic metric =="
"$padapt" generate box2d 20 "$out/square.mesh"
"$padapt" metric shell "$out/square.mesh" "$out/square.sol"
echo
echo "-- input mesh in its metric --"
"$padapt" stats "$out/square.mesh" -met "$out/square.sol" -json "$out/input.json"
"$padapt" convert "$out/square.mesh" "$out/square.vtu" -met "$out/square.sol"
echo
echo "Output in $out/: square.mesh, square.sol (metric), input.json (report),"
echo "square.vtu (open it in ParaView: cell data 'quality', point data 'metric')."
