// A block of tissue with an embedded cylindrical inclusion [m]: two physical volumes.
// Meshed at build time by tests/CMakeLists.txt (gmsh -3 -nt 1 -format msh22 / msh41).
SetFactory("OpenCASCADE");
Box(1) = {0, 0, 0, 0.04, 0.03, 0.02};
Cylinder(2) = {0.02, 0.015, 0.005, 0, 0, 0.01, 0.006};
// The fragments are the inclusion (the cylinder) and the block minus the inclusion.
v() = BooleanFragments{ Volume{1}; Delete; }{ Volume{2}; Delete; };
Physical Volume("inclusion", 20) = {v(0)};
Physical Volume("tissue", 10) = {v(1)};
Mesh.CharacteristicLengthMax = 0.005;
Mesh.Binary = 0;
