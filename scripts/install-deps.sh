#!/usr/bin/env bash
# Install the Debian packages padapt needs, if any is missing. Works as root or
# through sudo; does nothing (and needs no privilege) when all are present.
set -euo pipefail
# The core needs the compilers, CMake, Open MPI and PT-Scotch; Gmsh's library
# is the optional geometry kernel (-geo); the tests use gmsh, FreeFem++,
# meshio and VTK's Python module as independent judges and real clients.
pkgs=(cmake gcc make pkg-config libptscotch-dev libscotch-dev openmpi-bin
      libopenmpi-dev python3 python3-meshio python3-numpy python3-mpi4py
      gmsh libgmsh-dev freefem++ libfreefem++ python3-vtk9)
missing=()
for p in "${pkgs[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
[ ${#missing[@]} -eq 0 ] && exit 0
echo "padapt: installing missing Debian packages: ${missing[*]}"
if [ "$(id -u)" -eq 0 ]; then SUDO=(); else SUDO=(sudo); fi
export DEBIAN_FRONTEND=noninteractive
"${SUDO[@]}" apt-get update -qq
"${SUDO[@]}" apt-get install -y -qq --no-install-recommends "${missing[@]}"
