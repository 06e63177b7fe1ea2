// One quarter of the gutter of Fig 6 [LTL87 sec. 8]: half of a circular tube (axis x1, inner
// radius Ri, thickness t) hanging below its axis; the quarter x1 in [0, L/2], x3 >= 0.
// Cross-section in the (x2, x3) plane: the quarter annulus from the bottom (x2 = -r, x3 = 0) to
// the rim (x2 = 0, x3 = r). nt cells through the thickness, na around the quarter arc, nl along
// the half length: 8-node hexahedra (transfinite + recombined).
// Boundary parts: inner (loaded), outer (contact), symmetry_x (x1 = 0), symmetry_z (x3 = 0),
// clamped (x1 = L/2), rim (x2 = 0).
DefineConstant[ Ri = {1.0, Name "Parameters/Ri"} ];
DefineConstant[ t = {0.2, Name "Parameters/t"} ];
DefineConstant[ L = {20.0, Name "Parameters/L"} ];
DefineConstant[ nt = {2, Name "Parameters/nt"} ];
DefineConstant[ na = {9, Name "Parameters/na"} ];
DefineConstant[ nl = {15, Name "Parameters/nl"} ];

Ro = Ri + t;
Point(1) = {0, 0, 0};
Point(2) = {0, -Ri, 0};
Point(3) = {0, -Ro, 0};
Point(4) = {0, 0, Ro};
Point(5) = {0, 0, Ri};
Line(1) = {2, 3};
Circle(2) = {3, 1, 4};
Line(3) = {4, 5};
Circle(4) = {5, 1, 2};
Curve Loop(1) = {1, 2, 3, 4};
Plane Surface(1) = {1};
Transfinite Curve{1, 3} = nt + 1;
Transfinite Curve{2, 4} = na + 1;
Transfinite Surface{1};
Recombine Surface{1};

out[] = Extrude {L / 2, 0, 0} { Surface{1}; Layers{nl}; Recombine; };
// out[0]: the end x1 = L/2, out[1]: the volume, out[2..5]: the sides swept by curves 1..4.
Physical Surface("symmetry_x") = {1};
Physical Surface("clamped") = {out[0]};
Physical Surface("symmetry_z") = {out[2]};
Physical Surface("outer") = {out[3]};
Physical Surface("rim") = {out[4]};
Physical Surface("inner") = {out[5]};
Physical Volume("body") = {out[1]};
