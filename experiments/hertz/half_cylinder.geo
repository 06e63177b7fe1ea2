// Hertz verification of the Signorini solver [LTL87 sec. 7]: the lower quarter of a disc of
// radius Rc (x1 >= 0, x2 <= 0), plane strain, resting on the rigid plane x2 = -Rc and pressed
// down by a uniform traction on its flat top face x2 = 0. By symmetry only x1 >= 0 is meshed.
//
//            O --------- top --------- A        O = (0, 0), A = (Rc, 0)
//            |                      .'         top:        x2 = 0, loaded
//   symmetry_x                   .'  free      symmetry_x: x1 = 0, u1 = 0
//            |               . '               free:       arc from C to A, traction free
//            B  . contact .  C                 contact:    arc from B = (0, -Rc) to C
//   =============================== x2 = -Rc  (rigid plane)
//
// C is where the arc reaches x1 = xc * Rc (xc in (0, 1)): keep xc a few times a/Rc so that the
// contact zone [0, a] lies well inside Gamma_c.
//
// Mesh grading: a Distance field from B and a Threshold field give the size hc within the
// distance dc of B, growing linearly to hf at the distance df. Refinement level k divides both
// sizes by 2^k (so every level halves the mesh size everywhere: a uniform refinement of a graded
// mesh). Triangles are made P2 by the library (gmsh places the mid-edge nodes on the circle).
DefineConstant[ Rc = {1.0, Name "Parameters/Rc"} ];
DefineConstant[ xc = {0.4, Name "Parameters/xc"} ];
DefineConstant[ hc = {0.02, Name "Parameters/hc"} ];   // size near B, relative to Rc
DefineConstant[ hf = {0.2, Name "Parameters/hf"} ];    // size far from B, relative to Rc
DefineConstant[ dc = {0.15, Name "Parameters/dc"} ];   // radius of the fine zone, relative to Rc
DefineConstant[ df = {0.8, Name "Parameters/df"} ];    // where the size reaches hf, relative to Rc
DefineConstant[ k = {0, Name "Parameters/k"} ];        // refinement level

s = 2^(-k);
th = Asin(xc);
Point(1) = {0, 0, 0};
Point(2) = {0, -Rc, 0};
Point(3) = {Rc * Sin(th), -Rc * Cos(th), 0};
Point(4) = {Rc, 0, 0};
Line(1) = {1, 2};        // symmetry_x
Circle(2) = {2, 1, 3};   // contact
Circle(3) = {3, 1, 4};   // free
Line(4) = {4, 1};        // top
Curve Loop(1) = {1, 2, 3, 4};
Plane Surface(1) = {1};

Field[1] = Distance;
Field[1].PointsList = {2};
Field[2] = Threshold;
Field[2].InField = 1;
Field[2].SizeMin = hc * s * Rc;
Field[2].SizeMax = hf * s * Rc;
Field[2].DistMin = dc * Rc;
Field[2].DistMax = df * Rc;
Background Field = 2;
Mesh.MeshSizeExtendFromBoundary = 0;
Mesh.MeshSizeFromPoints = 0;
Mesh.MeshSizeFromCurvature = 0;

Physical Curve("symmetry_x") = {1};
Physical Curve("contact") = {2};
Physical Curve("free") = {3};
Physical Curve("top") = {4};
Physical Surface("body") = {1};
