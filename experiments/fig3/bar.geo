// The bar of Figs 3 and 4 [LTL87 sec. 8]: [0, L] x [0, H], plane strain, nx x ny rectangles
// each split into two triangles (P2 after setOrder(2) in the solver).
// Boundary parts: contact (x2 = 0, glued), top (x2 = H, loaded), left (x1 = 0, free end),
// right (x1 = L, fixed).
DefineConstant[ L = {1.0, Name "Parameters/L"} ];
DefineConstant[ H = {0.2, Name "Parameters/H"} ];
DefineConstant[ nx = {28, Name "Parameters/nx"} ];
DefineConstant[ ny = {3, Name "Parameters/ny"} ];

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

Physical Curve("contact") = {1};
Physical Curve("right") = {2};
Physical Curve("top") = {3};
Physical Curve("left") = {4};
Physical Surface("body") = {1};
