# gmsh_box.sh -- sourced by the benchmarks: gmsh_box DIM LC GEO OUT writes
# GEO, the gmsh description of the unit square (DIM 2, characteristic length
# LC) or cube (DIM 3, largest length LC) with every boundary entity in
# physical group 1, and meshes it into OUT (Medit .mesh; gmsh's log in
# OUT.log). gmsh must be on PATH.
gmsh_box() {
  local dim=$1 lc=$2 geo=$3 out=$4
  if [ "$dim" = 2 ]; then
    cat >"$geo" <<GEO
lc = $lc;
Point(1) = {0, 0, 0, lc}; Point(2) = {1, 0, 0, lc};
Point(3) = {1, 1, 0, lc}; Point(4) = {0, 1, 0, lc};
Line(1) = {1, 2}; Line(2) = {2, 3}; Line(3) = {3, 4}; Line(4) = {4, 1};
Curve Loop(1) = {1, 2, 3, 4}; Plane Surface(1) = {1};
Physical Surface(1) = {1}; Physical Curve(1) = {1, 2, 3, 4};
GEO
  else
    cat >"$geo" <<GEO
SetFactory("OpenCASCADE");
Box(1) = {0, 0, 0, 1, 1, 1};
Mesh.CharacteristicLengthMax = $lc;
Physical Volume(1) = {1};
Physical Surface(1) = {1, 2, 3, 4, 5, 6};
GEO
  fi
  gmsh "-$dim" "$geo" -format mesh -o "$out" >"$out.log" 2>&1
}
