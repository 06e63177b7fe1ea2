// Box [0, a]^3 of n^3 hexahedra (tests distort the interior nodes themselves), with faces
// named x0, x1, y0, y1, z0, z1 and "boundary" for all six.
DefineConstant[ a = {1.0, Name "Parameters/a"} ];
DefineConstant[ n = {2, Name "Parameters/n"} ];
Point(1) = {0, 0, 0};
Point(2) = {a, 0, 0};
Point(3) = {a, a, 0};
Point(4) = {0, a, 0};
Line(1) = {1, 2};
Line(2) = {2, 3};
Line(3) = {3, 4};
Line(4) = {4, 1};
Curve Loop(1) = {1, 2, 3, 4};
Plane Surface(1) = {1};
Transfinite Curve{1, 2, 3, 4} = n + 1;
Transfinite Surface{1};
Recombine Surface{1};
out[] = Extrude {0, 0, a} { Surface{1}; Layers{n}; Recombine; };
Physical Surface("z0") = {1};
Physical Surface("z1") = {out[0]};
Physical Surface("y0") = {out[2]};
Physical Surface("x1") = {out[3]};
Physical Surface("y1") = {out[4]};
Physical Surface("x0") = {out[5]};
Physical Surface("boundary") = {1, out[0], out[2], out[3], out[4], out[5]};
Physical Volume("body") = {out[1]};
