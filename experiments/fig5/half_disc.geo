// The half cylinder of Fig 5 [LTL87 sec. 8]: the half disc x1 >= 0 of radius Rc centred at the
// origin, plane strain. Boundary parts: symmetry_x (x1 = 0), contact (the lower quarter of the
// circle, facing the plane x2 = -Rc), free (the upper quarter).
// n = number of edges along each quarter circle, nd along each half of the symmetry axis; the
// interior is meshed unstructured (gmsh's default). The default n = nd = 7 gives 122 triangles
// (the paper used 120 Ruas elements; gmsh cannot be made to give exactly 120 here).
DefineConstant[ Rc = {1.0, Name "Parameters/Rc"} ];
DefineConstant[ n = {7, Name "Parameters/n"} ];
DefineConstant[ nd = {7, Name "Parameters/nd"} ];

h = (Pi / 2) * Rc / n;
Point(1) = {0, 0, 0, h};
Point(2) = {0, -Rc, 0, h};
Point(3) = {Rc, 0, 0, h};
Point(4) = {0, Rc, 0, h};
Circle(1) = {2, 1, 3};
Circle(2) = {3, 1, 4};
Line(3) = {4, 1};
Line(4) = {1, 2};
Curve Loop(1) = {1, 2, 3, 4};
Plane Surface(1) = {1};
Transfinite Curve{1, 2} = n + 1;
Transfinite Curve{3, 4} = nd + 1;

Physical Curve("contact") = {1};
Physical Curve("free") = {2};
Physical Curve("symmetry_x") = {3, 4};
Physical Surface("body") = {1};
