// Unit cube, 4 x 4 x 4 hexahedra by extrusion: the same mesh as the `box` generator with
// divisions = [4, 4, 4], so a case on this file must reproduce the generated one.
// Regenerate: gmsh -3 -format msh41 box_4x4x4.geo -o box_4x4x4.msh
p = newp; Point(p) = {0, 0, 0, 1};
l[] = Extrude {1, 0, 0} { Point{p}; Layers{4}; Recombine; };
s[] = Extrude {0, 1, 0} { Line{l[1]}; Layers{4}; Recombine; };
v[] = Extrude {0, 0, 1} { Surface{s[1]}; Layers{4}; Recombine; };
Physical Surface("zmin") = {s[1]};
Physical Surface("zmax") = {v[0]};
Physical Volume("block") = {v[1]};
