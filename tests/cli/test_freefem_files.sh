#!/usr/bin/env bash
# The files FreeFem++ and Gmsh write, written here by them, read by padapt:
# FreeFem++'s savemesh (2D: bamg's keywords, ASCII even as .meshb; 3D:
# libMeshb, ASCII and binary) and the medit plugin's savesol (.sol, .solb),
# Gmsh's -format mesh (2D, 3D, high order refused). Counts must match what
# the writer reports, the note at -v 1 must name the keywords skipped, a
# metric must build from FreeFem++'s mesh and solution, and padapt's output
# must read back in FreeFem++. Unit side: tests/unit/test_medit.c
# (test_freefem, test_mmg, test_unknown_binary...).
set -u
: "${PADAPT:?PADAPT must point to the padapt binary}"
fails=0
ok()  { echo "ok   $1"; }
bad() { echo "FAIL $1"; fails=$((fails + 1)); }
for tool in FreeFem++ gmsh; do
  command -v $tool > /dev/null || { echo "FAIL $tool not found (scripts/install-deps.sh installs it)"; exit 1; }
done
# Debian's FreeFem++ finds its plugins only there (examples/freefem/run.sh).
plugin=$(dpkg -L libfreefem++ 2> /dev/null | grep '/msh3\.so$' | head -1 || true)
[ -n "$plugin" ] && export FF_LOADPATH=$(dirname "$plugin")
ff() { FreeFem++ -nw -v 0 "$@"; }
# "vertices N" and the element line of padapt stats
counts() { "$PADAPT" stats "$1" 2> /dev/null | awk '$1 == "vertices" {v = $2} $1 == "triangles" || $1 == "tetrahedra" {if (!e) e = $2} END {print v, e}'; }

# ---- FreeFem++ 2D: an L-shaped mesh, savemesh and savesol
cat > ff2d.edp <<'EOF'
load "medit"
border a(t = 0, 1) { x = t; y = 0; label = 1; }
border b(t = 0, 1) { x = 1; y = t; label = 2; }
border c(t = 0, 2) { x = 1 - t; y = 1; label = 3; }
border d(t = 0, 2) { x = -1; y = 1 - t; label = 4; }
border e(t = 0, 1) { x = -1 + t; y = -1; label = 5; }
border f(t = 0, 1) { x = 0; y = -1 + t; label = 6; }
mesh Th = buildmesh(a(6) + b(6) + c(12) + d(12) + e(6) + f(6));
savemesh(Th, "ff2d.mesh");
savemesh(Th, "ff2d.meshb");
fespace Vh(Th, P1);
Vh u = sin(3 * x) * cos(2 * y);
savesol("ff2d.sol", Th, u);
savesol("ff2d.solb", Th, u);
cout << Th.nv << " " << Th.nt << endl;
EOF
want=$(ff ff2d.edp | tail -1)
for f in ff2d.mesh ff2d.meshb; do
  got=$(counts $f)
  [ "$got" = "$want" ] && ok "FreeFem++ 2D $f: $got" || bad "FreeFem++ 2D $f: padapt reads '$got', FreeFem++ wrote '$want'"
done
"$PADAPT" -v 1 convert ff2d.mesh back2d.mesh > /dev/null 2> note.txt
grep -q "ff2d.mesh: skipped the keywords padapt does not use: Identifier, Geometry, SubDomainFromMesh, SubDomainFromGeom, VertexOnGeometricVertex, VertexOnGeometricEdge, EdgeOnGeometricEdge$" note.txt &&
  [ "$(grep -c skipped note.txt)" -eq 1 ] && ok "one note names FreeFem++'s keywords" ||
  bad "note at -v 1: $(cat note.txt)"
"$PADAPT" convert ff2d.mesh quiet.mesh > /dev/null 2> quiet.txt
[ ! -s quiet.txt ] && ok "no note at -v 0" || bad "-v 0 printed: $(cat quiet.txt)"
grep -q "an ASCII Medit file under a binary name" <("$PADAPT" -v 1 stats ff2d.meshb 2>&1) &&
  ok "ff2d.meshb (ASCII) read as ASCII, with a note" || bad "no note for the ASCII ff2d.meshb"
for s in ff2d.sol ff2d.solb; do
  "$PADAPT" metric hessian ff2d.mesh -field $s -target 400 h.sol > out.txt 2>&1 &&
    grep -q "complexity 4" out.txt && ok "metric hessian on ff2d.mesh + $s" ||
    bad "metric hessian on ff2d.mesh + $s: $(cat out.txt)"
done
cat > back2d.edp <<'EOF'
mesh Th = readmesh("back2d.mesh");
cout << Th.nv << " " << Th.nt << endl;
EOF
got=$(ff back2d.edp | tail -1)
[ "$got" = "$want" ] && ok "FreeFem++ reads padapt's 2D mesh back: $got" || bad "FreeFem++ reads back '$got', want '$want'"

# ---- FreeFem++ 3D: libMeshb's ASCII and binary files
cat > ff3d.edp <<'EOF'
load "msh3"
load "medit"
mesh3 Th = cube(4, 5, 3);
savemesh(Th, "ff3d.mesh");
savemesh(Th, "ff3d.meshb");
fespace Vh(Th, P1);
Vh u = x * x + y * z;
savesol("ff3d.sol", Th, u);
savesol("ff3d.solb", Th, u);
cout << Th.nv << " " << Th.nt << endl;
EOF
want=$(ff ff3d.edp | tail -1)
for f in ff3d.mesh ff3d.meshb; do
  got=$(counts $f)
  [ "$got" = "$want" ] && ok "FreeFem++ 3D $f: $got" || bad "FreeFem++ 3D $f: padapt reads '$got', FreeFem++ wrote '$want'"
done
[ "$(head -c 4 ff3d.meshb | od -An -tu4 | tr -d ' ')" = 1 ] && ok "ff3d.meshb is binary" || bad "ff3d.meshb is not binary"
"$PADAPT" metric hessian ff3d.meshb -field ff3d.solb -target 300 h3.sol > out.txt 2>&1 &&
  ok "metric hessian on ff3d.meshb + ff3d.solb" || bad "metric hessian 3D: $(cat out.txt)"
"$PADAPT" convert ff3d.meshb back3d.mesh > /dev/null
cat > back3d.edp <<'EOF'
load "msh3"
mesh3 Th = readmesh3("back3d.mesh");
cout << Th.nv << " " << Th.nt << endl;
EOF
got=$(ff back3d.edp | tail -1)
[ "$got" = "$want" ] && ok "FreeFem++ reads padapt's 3D mesh back: $got" || bad "FreeFem++ reads back '$got', want '$want'"

# ---- Gmsh: -format mesh, compared with the same mesh in MSH 4.1
cat > sq.geo <<'EOF'
Point(1) = {0, 0, 0, 0.2}; Point(2) = {1, 0, 0, 0.2};
Point(3) = {1, 1, 0, 0.2}; Point(4) = {0, 1, 0, 0.2};
Line(1) = {1, 2}; Line(2) = {2, 3}; Line(3) = {3, 4}; Line(4) = {4, 1};
Curve Loop(1) = {1, 2, 3, 4}; Plane Surface(1) = {1};
Physical Curve("wall") = {1, 2, 3, 4}; Physical Surface("dom") = {1};
EOF
gmsh -2 sq.geo -format mesh -o g2.mesh > /dev/null && gmsh -2 sq.geo -o g2.msh > /dev/null
gmsh -2 sq.geo -format mesh -bin -o g2.meshb > /dev/null 2>&1
a=$(counts g2.mesh); b=$(counts g2.msh); c=$(counts g2.meshb)
[ -n "$a" ] && [ "$a" = "$b" ] && [ "$a" = "$c" ] && ok "gmsh 2D .mesh/.meshb = .msh: $a" || bad "gmsh 2D: .mesh '$a', .meshb '$c', .msh '$b'"
cat > box.geo <<'EOF'
SetFactory("OpenCASCADE");
Box(1) = {0, 0, 0, 1, 1, 1};
Mesh.CharacteristicLengthMax = 0.25;
EOF
gmsh -3 box.geo -format mesh -o g3.mesh > /dev/null && gmsh -3 box.geo -o g3.msh > /dev/null
a=$(counts g3.mesh); b=$(counts g3.msh)
[ -n "$a" ] && [ "$a" = "$b" ] && ok "gmsh 3D .mesh = .msh: $a" || bad "gmsh 3D: .mesh '$a', .msh '$b'"
gmsh -2 -order 2 sq.geo -format mesh -o p2.mesh > /dev/null
"$PADAPT" convert p2.mesh out.mesh > /dev/null 2> err.txt; rc=$?
[ $rc -ne 0 ] && grep -q "p2.mesh:[0-9]*: EdgesP2 are not supported" err.txt && [ ! -e out.mesh ] &&
  ok "gmsh -order 2 refused: $(cat err.txt)" || bad "gmsh -order 2 (exit $rc): $(cat err.txt)"

[ $fails -eq 0 ] || { echo "$fails failure(s)"; exit 1; }
