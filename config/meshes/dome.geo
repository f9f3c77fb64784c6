// A dome of skin over fat [m]: the cap of a sphere of radius 30 mm over a 40 x 30 mm base (z = 0),
// 8 mm high at its top, the outer 4 mm skin. Two physical volumes. The scenario
// config/scenarios/dome_incision.yaml cuts across its top, where the surface curves along the cut.
// Regenerate dome.msh with: gmsh -3 -nt 1 -v 0 -format msh22 config/meshes/dome.geo -o config/meshes/dome.msh
SetFactory("OpenCASCADE");
Sphere(1) = {0, 0, -0.022, 0.030};
Sphere(2) = {0, 0, -0.022, 0.026};
Box(3) = {-0.020, -0.015, 0, 0.040, 0.030, 0.010};
outer() = BooleanIntersection{ Volume{1}; Delete; }{ Volume{3}; };
inner() = BooleanIntersection{ Volume{2}; Delete; }{ Volume{3}; Delete; };
v() = BooleanFragments{ Volume{outer()}; Delete; }{ Volume{inner()}; Delete; };
Physical Volume("fat", 2) = {v(0)};
Physical Volume("skin", 1) = {v(1)};
Mesh.CharacteristicLengthMax = 0.0028;
Mesh.Binary = 0;
