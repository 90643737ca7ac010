// rod.geo -- a connecting rod for bench/seed_table1.sh (the first experiment
// of Lachat, Dobrzynski, Pellegrini, "Parallel mesh adaptation using parallel
// graph partitioning"): a big end (boss radius 1.0, thickness 0.6, bore
// radius 0.55) at the origin and a small end (boss radius 0.55, thickness
// 0.5, bore radius 0.3) at x = 4, bore axes along z, joined by a tapered
// I-section shank: a trapezoidal beam 0.4 thick with a pocket 0.1 deep in its
// top and bottom faces, leaving a web 0.2 thick. The shank's flat sides meet
// the bosses' cylinders along curved ridges; the pocket edges are rounded.
//
//   gmsh -3 rod.geo -format mesh -o rod.mesh        (gmsh >= 4, OpenCASCADE)
//
// Override the characteristic length with -setnumber lc 0.1 (default 0.2).
// Physical Volume 1 is the rod; Physical Surface 2 the big bore, 3 the small
// bore, 1 every other face (so gmsh writes all the boundary triangles).
SetFactory("OpenCASCADE");
If (!Exists(lc))
  lc = 0.2;
EndIf

L = 4.0;                          // distance between the bore centres
Rb = 1.0;  tb = 0.6;  rb = 0.55;  // big end: boss radius, thickness, bore
Rs = 0.55; ts = 0.5;  rs = 0.3;   // small end
ws0 = 0.9; ws1 = 0.5;             // shank width at the big and small ends
t = 0.4;  d = 0.1;                // shank thickness, pocket depth
x0 = 0.6; x1 = 3.8;               // shank ends (inside the bosses)
p0 = 1.15; p1 = 3.35;             // pocket ends (clear of the bosses)
m = 0.1;                          // rim left beside a pocket
rf = 0.06;                        // fillet radius of the pocket's corners

Cylinder(1) = {0, 0, -tb/2, 0, 0, tb, Rb};
Cylinder(2) = {L, 0, -ts/2, 0, 0, ts, Rs};

// The shank: a trapezoid in the plane z = -t/2, extruded by t.
Point(101) = {x0, -ws0/2, -t/2};
Point(102) = {x1, -ws1/2, -t/2};
Point(103) = {x1,  ws1/2, -t/2};
Point(104) = {x0,  ws0/2, -t/2};
Line(101) = {101, 102}; Line(102) = {102, 103};
Line(103) = {103, 104}; Line(104) = {104, 101};
Curve Loop(101) = {101, 102, 103, 104};
Plane Surface(101) = {101};
shank[] = Extrude {0, 0, t} { Surface{101}; };

// The pockets: the trapezoid shrunk by the rim m, cut d deep from each face.
// The half width of the shank at x is ws0/2 + (ws1 - ws0)/2 (x - x0)/(x1 - x0).
hw0 = ws0/2 + (ws1 - ws0)/2*(p0 - x0)/(x1 - x0) - m;
hw1 = ws0/2 + (ws1 - ws0)/2*(p1 - x0)/(x1 - x0) - m;
Point(201) = {p0, -hw0, t/2 - d};
Point(202) = {p1, -hw1, t/2 - d};
Point(203) = {p1,  hw1, t/2 - d};
Point(204) = {p0,  hw0, t/2 - d};
Line(201) = {201, 202}; Line(202) = {202, 203};
Line(203) = {203, 204}; Line(204) = {204, 201};
Curve Loop(201) = {201, 202, 203, 204};
Plane Surface(201) = {201};
top[] = Extrude {0, 0, 2*d} { Surface{201}; };
bot[] = Translate {0, 0, -t} { Duplicata { Volume{top[1]}; } };

rod[] = BooleanUnion{ Volume{1}; Delete; }{ Volume{2, shank[1]}; Delete; };
rod[] = BooleanDifference{ Volume{rod[]}; Delete; }{ Volume{top[1], bot[]}; Delete; };

Cylinder(11) = {0, 0, -1, 0, 0, 2, rb};
Cylinder(12) = {L, 0, -1, 0, 0, 2, rs};
rod[] = BooleanDifference{ Volume{rod[]}; Delete; }{ Volume{11, 12}; Delete; };

// Round the pockets' vertical edges (the corners of the trapezoids): the
// edges lying wholly inside the pockets' boxes, parallel to z.
e[] = Curve In BoundingBox{p0 - 1e-3, -hw0 - 1e-3, -t/2 - 1e-3,
                           p1 + 1e-3,  hw0 + 1e-3,  t/2 + 1e-3};
vert[] = {};
For i In {0 : #e[] - 1}
  bb[] = BoundingBox Curve{e[i]};
  If (Fabs(bb[3] - bb[0]) < 1e-6 && Fabs(bb[4] - bb[1]) < 1e-6)
    vert[] += e[i];
  EndIf
EndFor
If (#vert[] > 0 && rf > 0)
  rod[] = Fillet{rod[0]}{vert[]}{rf};
EndIf

Mesh.CharacteristicLengthMax = lc;
Mesh.CharacteristicLengthFromCurvature = 0;

bigbore[] = Surface In BoundingBox{-rb - 1e-3, -rb - 1e-3, -1, rb + 1e-3, rb + 1e-3, 1};
smallbore[] = Surface In BoundingBox{L - rs - 1e-3, -rs - 1e-3, -1,
                                     L + rs + 1e-3,  rs + 1e-3,  1};
all[] = Boundary{ Volume{rod[]}; };
Physical Volume(1) = {rod[]};
Physical Surface(2) = {bigbore[]};
Physical Surface(3) = {smallbore[]};
all[] -= {bigbore[], smallbore[]};
Physical Surface(1) = {all[]};
