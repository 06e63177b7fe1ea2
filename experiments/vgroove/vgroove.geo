// A square block of side a in a right-angled V-groove, plane strain: the block turned by 45
// degrees, its lower corner at the bottom of the groove (the origin), its two lower faces on the
// groove's faces, the planes x2 = -x1 (left) and x2 = x1 (right). Boundary groups: lower_left,
// lower_right (the faces on the groove; both hold the corner node), upper_left, upper_right (the
// faces the load presses), block (the body). n cells along a side; quadratic triangles.
DefineConstant[ a = {0.02, Name "Parameters/a"} ];
DefineConstant[ n = {8, Name "Parameters/n"} ];
h = a / n;
s = a / Sqrt(2);
Point(1) = {0, 0, 0, h};
Point(2) = {s, s, 0, h};
Point(3) = {0, 2 * s, 0, h};
Point(4) = {-s, s, 0, h};
Line(1) = {1, 2};
Line(2) = {2, 3};
Line(3) = {3, 4};
Line(4) = {4, 1};
Curve Loop(1) = {1, 2, 3, 4};
Plane Surface(1) = {1};
Physical Curve("lower_right") = {1};
Physical Curve("upper_right") = {2};
Physical Curve("upper_left") = {3};
Physical Curve("lower_left") = {4};
Physical Surface("block") = {1};
