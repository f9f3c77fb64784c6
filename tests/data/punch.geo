// A rigid flat circular punch of radius a on a cylinder of tissue 80 a wide and 80 a deep [m], for
// the half-space check of the contact force (tests/fem/test_indentation.cpp). The punch's rim is a
// curve of the top face, so nodes lie on it; the elements grow from a / fine at the rim by `growth`
// times the distance to it, so the far field costs little and the block is nearly a half-space.
// Meshed at build time by tests/CMakeLists.txt (gmsh -3 -nt 1 -format msh22), fine and coarse.
SetFactory("OpenCASCADE");
DefineConstant[ fine = 16, growth = 0.15, extent = 80 ];
a = 0.005;
R = extent * a;
H = extent * a;
Cylinder(1) = {0, 0, -H, 0, 0, H, R};
Disk(10) = {0, 0, 0, a};
BooleanFragments{ Volume{1}; Delete; }{ Surface{10}; Delete; }
rim() = Curve In BoundingBox{-1.01 * a, -1.01 * a, -1e-6, 1.01 * a, 1.01 * a, 1e-6};
Field[1] = Distance;
Field[1].CurvesList = {rim()};
Field[1].NumPointsPerCurve = 200;
Field[2] = MathEval;
Field[2].F = Sprintf("%g + %g * F1", a / fine, growth);
Background Field = 2;
Mesh.MeshSizeExtendFromBoundary = 0;
Mesh.MeshSizeFromPoints = 0;
Mesh.MeshSizeFromCurvature = 0;
Physical Volume("tissue", 10) = Volume{:};
Mesh.Binary = 0;
