#!/usr/bin/env bash
# cad.sh -- `padapt adapt -geo MODEL` against h: the largest distance of a
# boundary vertex to the CAD model and the volume (area) error, with and
# without -geo, and what the projections cost (their count, the seconds in
# the kernel, the remesher's and the process's CPU time). The models of
# bench/cad_judge.py (a cylinder with a transverse hole, 3D; a plate with a
# disk and an ellipse cut out, 2D), written as .geo, exported as STEP and
# meshed coarsely (-clmax 0.3) by the gmsh command line, then adapted to
# -hsiz h from that coarse mesh; judged from the shapes' closed forms.
# Prints one line per run and the observed orders of the volume error;
# writes WORKDIR/cad.svg (log-log, both against h).
#
#   bash bench/cad.sh [BUILD] [WORKDIR]
#
# Environment: HS3 ("0.1 0.07 0.05 0.035 0.025"), HS2 ("0.04 0.02 0.01
# 0.005 0.0025"), NP (1: sequential; > 1 under mpiexec -n NP).
set -eu
BUILD=${1:-build}
WORK=${2:-/tmp/padapt-cad}
PADAPT=$(cd "$BUILD/bin" 2>/dev/null && pwd)/padapt
HERE=$(cd "$(dirname "$0")" && pwd)
[ -x "$PADAPT" ] || { echo "cad.sh: no $PADAPT (build first)" >&2; exit 1; }
command -v gmsh > /dev/null || { echo "cad.sh: needs the gmsh command line" >&2; exit 1; }
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
export OMPI_MCA_rmaps_base_oversubscribe=1 SCOTCH_PTHREAD_NUMBER=1
mkdir -p "$WORK"
echo "cad.sh: $(date '+%F %T'), $(nproc) cores, load $(cut -d' ' -f1-3 /proc/loadavg)"
/usr/bin/python3 "$HERE/cad_judge.py" bench "$PADAPT" "$WORK"
