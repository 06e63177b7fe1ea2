// A ring (annulus) in plane strain between two plates, the half x1 >= 0 of it: inner radius ri,
// outer radius ro, centred at the origin; the plates are the planes x2 = ro and x2 = -ro, which
// it touches at its top and bottom. Boundary groups: outer (the outer half circle, the contact
// surface of both plates), inner (the inner half circle, where the pressure acts), cut (the two
// segments on x1 = 0, the symmetry plane), ring (the body). About n cells across the wall;
// quadratic triangles (the reader makes 3-node triangles 6-node P2).
DefineConstant[ ri = {0.008, Name "Parameters/ri"} ];
DefineConstant[ ro = {0.01, Name "Parameters/ro"} ];
DefineConstant[ n = {4, Name "Parameters/n"} ];
h = (ro - ri) / n;
Point(1) = {0, 0, 0, h};
Point(2) = {0, -ro, 0, h};
Point(3) = {ro, 0, 0, h};
Point(4) = {0, ro, 0, h};
Point(5) = {0, ri, 0, h};
Point(6) = {ri, 0, 0, h};
Point(7) = {0, -ri, 0, h};
Circle(1) = {2, 1, 3};
Circle(2) = {3, 1, 4};
Line(3) = {4, 5};
Circle(4) = {5, 1, 6};
Circle(5) = {6, 1, 7};
Line(6) = {7, 2};
Curve Loop(1) = {1, 2, 3, 4, 5, 6};
Plane Surface(1) = {1};
Physical Curve("outer") = {1, 2};
Physical Curve("inner") = {4, 5};
Physical Curve("cut") = {3, 6};
Physical Surface("ring") = {1};
