// A ball of tissue [m], a curved mesh for the cutting fuzzer (tests/cutting/test_cut_fuzzer.cpp).
// Meshed at build time by tests/CMakeLists.txt (gmsh -3 -nt 1 -format msh22).
SetFactory("OpenCASCADE");
Sphere(1) = {0, 0, 0, 0.01};
Physical Volume("tissue", 10) = {1};
Mesh.CharacteristicLengthMax = 0.004;
Mesh.Binary = 0;
