// Quarter of a 4 x 4 plate with a central hole of radius 0.5 (symmetry on x = 0 and y = 0),
// meshed with unstructured quadrilaterals. Regenerate:
//   gmsh -2 -format msh41 plate_hole.geo -o plate_hole.msh
h = 0.12;
Point(1) = {0.5, 0, 0, h};
Point(2) = {2, 0, 0, h};
Point(3) = {2, 2, 0, h};
Point(4) = {0, 2, 0, h};
Point(5) = {0, 0.5, 0, h};
Point(6) = {0, 0, 0, h};
Line(1) = {1, 2};
Line(2) = {2, 3};
Line(3) = {3, 4};
Line(4) = {4, 5};
Circle(5) = {5, 6, 1};
Curve Loop(1) = {1, 2, 3, 4, 5};
Plane Surface(1) = {1};
Recombine Surface{1};
Mesh.Algorithm = 6;
Mesh.RecombinationAlgorithm = 0;
Mesh.SubdivisionAlgorithm = 1; // all quadrilaterals (splits any leftover triangle)
Physical Curve("bottom") = {1};
Physical Curve("right") = {2};
Physical Curve("top") = {3};
Physical Curve("left") = {4};
Physical Curve("hole") = {5};
Physical Surface("plate") = {1};
