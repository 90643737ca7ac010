// plate.geo -- a plate with a circular and an elliptic hole (issue #19):
// gmsh -2 bench/plate.geo -format mesh -o tests/data/plate2d.mesh
// (gmsh 4.8.4) made the input of tests/cli/test_parallel_quality.py.
SetFactory("OpenCASCADE");
Rectangle(1) = {0, 0, 0, 1, 0.6};
Disk(2) = {0.3, 0.3, 0, 0.1, 0.1};
Disk(3) = {0.7, 0.3, 0, 0.15, 0.07};
BooleanDifference{ Surface{1}; Delete; }{ Surface{2,3}; Delete; }
Mesh.CharacteristicLengthMax = 0.05;
