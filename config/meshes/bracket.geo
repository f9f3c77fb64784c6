// A machined bracket [m], the irregular model of the sculpting scenario (paper section 7.3): an L of
// a 50 x 24 x 10 mm base and a 10 x 24 x 26 mm upright, a 6 mm fillet inside the corner, a bolt
// hole of 8 mm through the base and a slot of 6 x 12 mm through the upright. One physical volume.
// The scenario config/scenarios/bracket_sculpt.yaml cuts notches off it.
// Regenerate bracket.msh with:
//   gmsh -3 -nt 1 -v 0 -format msh22 config/meshes/bracket.geo -o config/meshes/bracket.msh
SetFactory("OpenCASCADE");
Box(1) = {0, 0, 0, 0.050, 0.024, 0.010};
Box(2) = {0, 0, 0.010, 0.010, 0.024, 0.026};
Box(3) = {0.010, 0, 0.010, 0.006, 0.024, 0.006};
Cylinder(4) = {0.016, -0.001, 0.016, 0, 0.026, 0, 0.006};
fillet() = BooleanDifference{ Volume{3}; Delete; }{ Volume{4}; Delete; };
Cylinder(5) = {0.033, 0.012, -0.001, 0, 0, 0.012, 0.004};
Box(6) = {-0.001, 0.009, 0.017, 0.012, 0.006, 0.012};
l() = BooleanUnion{ Volume{1}; Delete; }{ Volume{2}; Volume{fillet()}; Delete; };
part() = BooleanDifference{ Volume{l()}; Delete; }{ Volume{5}; Volume{6}; Delete; };
Physical Volume("steel", 1) = {part()};
Mesh.CharacteristicLengthMax = 0.0032;
Mesh.CharacteristicLengthMin = 0.0015;
Mesh.Binary = 0;
