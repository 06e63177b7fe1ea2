// Box [0, a]^3 meshed with gmsh's default unstructured tetrahedra (4-node, made 10-node P2 by
// the reader), mesh size about a/n; faces named x0, x1, y0, y1, z0, z1 and "boundary" for all
// six, as in box.geo (its hexahedral counterpart).
DefineConstant[ a = {1.0, Name "Parameters/a"} ];
DefineConstant[ n = {2, Name "Parameters/n"} ];
h = a / n;
Point(1) = {0, 0, 0, h};
Point(2) = {a, 0, 0, h};
Point(3) = {a, a, 0, h};
Point(4) = {0, a, 0, h};
Line(1) = {1, 2};
Line(2) = {2, 3};
Line(3) = {3, 4};
Line(4) = {4, 1};
Curve Loop(1) = {1, 2, 3, 4};
Plane Surface(1) = {1};
out[] = Extrude {0, 0, a} { Surface{1}; };
Physical Surface("z0") = {1};
Physical Surface("z1") = {out[0]};
Physical Surface("y0") = {out[2]};
Physical Surface("x1") = {out[3]};
Physical Surface("y1") = {out[4]};
Physical Surface("x0") = {out[5]};
Physical Surface("boundary") = {1, out[0], out[2], out[3], out[4], out[5]};
Physical Volume("body") = {out[1]};
