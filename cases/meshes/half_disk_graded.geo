// Half disk of radius 1 centred at (0, 1): flat top edge on y = 1, lowest point at the origin,
// unstructured quadrilaterals (Frontal-Delaunay + recombination) graded towards the lowest point.
// Regenerate (Gmsh 4.8.4, Debian 12 `apt-get install gmsh`):
//   gmsh -2 -format msh41 half_disk_graded.geo -o half_disk_graded.msh
h0 = 0.015;  // at the lowest point (0, 0), where contact starts
h1 = 0.15;  // at the ends of the arc and on the top edge
Point(1) = {0, 1, 0, h1};    // centre
Point(2) = {-1, 1, 0, h1};
Point(3) = {0, 0, 0, h0};    // lowest point
Point(4) = {1, 1, 0, h1};
Circle(1) = {2, 1, 3};
Circle(2) = {3, 1, 4};
Line(3) = {4, 2};
Curve Loop(1) = {1, 2, 3};
Plane Surface(1) = {1};
Recombine Surface{1};
Mesh.Algorithm = 6;              // Frontal-Delaunay
Mesh.RecombinationAlgorithm = 1; // blossom
Mesh.RecombineAll = 1;
Physical Curve("arc") = {1, 2};
Physical Curve("top") = {3};
Physical Surface("disk") = {1};
