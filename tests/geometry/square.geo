// Unit square [0, a] x [0, a] with sides named left, right, bottom, top, and "boundary" for all
// four; unstructured (distorted) triangles with n edges per side.
DefineConstant[ a = {1.0, Name "Parameters/a"} ];
DefineConstant[ n = {4, Name "Parameters/n"} ];
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
Physical Curve("bottom") = {1};
Physical Curve("right") = {2};
Physical Curve("top") = {3};
Physical Curve("left") = {4};
Physical Curve("boundary") = {1, 2, 3, 4};
Physical Surface("body") = {1};
