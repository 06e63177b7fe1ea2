// A strip [0, L] x [0, H] (plane strain) glued along its bottom to the plane x2 = 0, meshed with
// nx x ny structured cells split into triangles. Boundary groups: bottom (the glued contact
// surface), top, left, right (the end lifted by the prescribed displacement).
DefineConstant[ L = {0.1, Name "Parameters/L"} ];
DefineConstant[ H = {0.01, Name "Parameters/H"} ];
DefineConstant[ nx = {20, Name "Parameters/nx"} ];
DefineConstant[ ny = {2, Name "Parameters/ny"} ];
Point(1) = {0, 0, 0};
Point(2) = {L, 0, 0};
Point(3) = {L, H, 0};
Point(4) = {0, H, 0};
Line(1) = {1, 2};
Line(2) = {2, 3};
Line(3) = {3, 4};
Line(4) = {4, 1};
Curve Loop(1) = {1, 2, 3, 4};
Plane Surface(1) = {1};
Transfinite Curve{1, 3} = nx + 1;
Transfinite Curve{2, 4} = ny + 1;
Transfinite Surface{1};
Physical Curve("bottom") = {1};
Physical Curve("right") = {2};
Physical Curve("top") = {3};
Physical Curve("left") = {4};
Physical Surface("body") = {1};
