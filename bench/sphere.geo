// sphere.geo -- the domain of bench/seed_table2.sh (the second experiment of
// Lachat, Dobrzynski, Pellegrini): a ball of radius 10 centred at the origin,
// meshed finer (size lcin) within radius rin of the centre, where the
// ellipsoid of semi-axes (0.5, 0.1, 0.2) lies, growing to lcout at the
// sphere.
//
//   gmsh -3 sphere.geo -format mesh -o sphere.mesh   (gmsh >= 4, OpenCASCADE)
//
// Override with -setnumber lcin 0.05 -setnumber lcout 2 -setnumber rin 0.7.
// Physical Volume 1 is the ball, Physical Surface 1 its sphere.
SetFactory("OpenCASCADE");
If (!Exists(lcin))
  lcin = 0.05;
EndIf
If (!Exists(lcout))
  lcout = 2.0;
EndIf
If (!Exists(rin))
  rin = 0.7;
EndIf
Sphere(1) = {0, 0, 0, 10};
Physical Volume(1) = {1};
Physical Surface(1) = {1};

Field[1] = Ball;
Field[1].Radius = rin;
Field[1].Thickness = 3;
Field[1].VIn = lcin;
Field[1].VOut = lcout;
Background Field = 1;
Mesh.MeshSizeExtendFromBoundary = 0;
Mesh.MeshSizeFromPoints = 0;
Mesh.MeshSizeFromCurvature = 0;
