// O-ring cross-section squeezed between a rigid plane (below) and a plate (above), plane strain:
// the half disc x1 >= 0 of radius Rc centred at the origin, its top flattened to the chord
// x2 = yt = sqrt(Rc^2 - b^2) of half-width b, where the plate holds it. Boundary groups: contact
// (the lower quarter circle, facing the plane x2 = -Rc), free (the upper arc up to the flat), top
// (the flat, x2 = yt), symmetry_x (the axis x1 = 0). Mesh size about (pi / 2) Rc / n; quadratic
// triangles (the reader makes 3-node triangles 6-node P2).
DefineConstant[ Rc = {0.01, Name "Parameters/Rc"} ];
DefineConstant[ b = {0.003, Name "Parameters/b"} ];
DefineConstant[ n = {6, Name "Parameters/n"} ];
h = (Pi / 2) * Rc / n;
yt = Sqrt(Rc * Rc - b * b);
Point(1) = {0, 0, 0, h};
Point(2) = {0, -Rc, 0, h};
Point(3) = {Rc, 0, 0, h};
Point(4) = {b, yt, 0, h};
Point(5) = {0, yt, 0, h};
Circle(1) = {2, 1, 3};
Circle(2) = {3, 1, 4};
Line(3) = {4, 5};
Line(4) = {5, 1};
Line(5) = {1, 2};
Curve Loop(1) = {1, 2, 3, 4, 5};
Plane Surface(1) = {1};
Physical Curve("contact") = {1};
Physical Curve("free") = {2};
Physical Curve("top") = {3};
Physical Curve("symmetry_x") = {4, 5};
Physical Surface("body") = {1};
