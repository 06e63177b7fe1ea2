// A half disc (plane strain, symmetry at x1 = 0) pressed onto the plane x2 = -Rc by a traction on
// the part of its top within 30 degrees of the axis ("top"); the rest of the upper quarter free.
DefineConstant[ Rc = {1.0, Name "Parameters/Rc"} ];
DefineConstant[ n = {8, Name "Parameters/n"} ];
h = (Pi / 2) * Rc / n;
Point(1) = {0, 0, 0, h};
Point(2) = {0, -Rc, 0, h};
Point(3) = {Rc, 0, 0, h};
Point(4) = {0, Rc, 0, h};
Point(5) = {Rc * Sin(Pi / 6), Rc * Cos(Pi / 6), 0, h};
Circle(1) = {2, 1, 3};
Circle(2) = {3, 1, 5};
Circle(5) = {5, 1, 4};
Line(3) = {4, 1};
Line(4) = {1, 2};
Curve Loop(1) = {1, 2, 5, 3, 4};
Plane Surface(1) = {1};
Transfinite Curve{1} = n + 1;
Transfinite Curve{2} = 2 * n / 3 + 1;
Transfinite Curve{5} = n / 3 + 1;
Transfinite Curve{3, 4} = n + 1;
Physical Curve("contact") = {1};
Physical Curve("free") = {2};
Physical Curve("top") = {5};
Physical Curve("symmetry_x") = {3, 4};
Physical Surface("body") = {1};
