// Block with a spherical cap: top face z = 1.2 (|x|, |y| <= 0.5), bottom face ("cap") on the
// sphere of radius 1 centred at (0, 0, 1), its lowest point at the origin; transfinite hexahedra
// (8 x 8 x 3). Gmsh places the cap's nodes on the sphere (to round-off), but the file carries no
// geometry: nurbs-contact enriches the cap by a smooth fit through its nodes.
// Regenerate (Gmsh 4.8.4, Debian 12 `apt-get install gmsh`):
//   gmsh -3 -format msh41 cap_block.geo -o cap_block.msh
n = 9;   // nodes per side of the cap (odd: a node at the lowest point)
m = 4;   // nodes through the height
R = 1; a = 0.5; zc = R - Sqrt(R * R - 2 * a * a);
Point(1) = {0, 0, R, 1};                // sphere centre
Point(2) = {-a, -a, zc, 1};
Point(3) = { a, -a, zc, 1};
Point(4) = { a,  a, zc, 1};
Point(5) = {-a,  a, zc, 1};
Point(6) = {-a, -a, 1.2, 1};
Point(7) = { a, -a, 1.2, 1};
Point(8) = { a,  a, 1.2, 1};
Point(9) = {-a,  a, 1.2, 1};
Circle(1) = {2, 1, 3};
Circle(2) = {3, 1, 4};
Circle(3) = {4, 1, 5};
Circle(4) = {5, 1, 2};
Line(5) = {6, 7}; Line(6) = {7, 8}; Line(7) = {8, 9}; Line(8) = {9, 6};
Line(9) = {2, 6}; Line(10) = {3, 7}; Line(11) = {4, 8}; Line(12) = {5, 9};
Curve Loop(1) = {1, 2, 3, 4};     Surface(1) = {1} In Sphere {1};   // the cap
Curve Loop(2) = {5, 6, 7, 8};     Plane Surface(2) = {2};           // top
Curve Loop(3) = {1, 10, -5, -9};  Surface(3) = {3};
Curve Loop(4) = {2, 11, -6, -10}; Surface(4) = {4};
Curve Loop(5) = {3, 12, -7, -11}; Surface(5) = {5};
Curve Loop(6) = {4, 9, -8, -12};  Surface(6) = {6};
Surface Loop(1) = {1, 2, 3, 4, 5, 6};
Volume(1) = {1};
Transfinite Curve{1, 2, 3, 4, 5, 6, 7, 8} = n;
Transfinite Curve{9, 10, 11, 12} = m;
Transfinite Surface{1, 2, 3, 4, 5, 6};
Recombine Surface{1, 2, 3, 4, 5, 6};
Transfinite Volume{1};
Physical Surface("cap") = {1};
Physical Surface("top") = {2};
Physical Surface("sides") = {3, 4, 5, 6};
Physical Volume("block") = {1};
