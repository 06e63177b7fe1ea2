// A cube [0, a]^3 of n^3 hexahedra (H8): a compact body for the partition of the cells over MPI
// ranks (bench_mpi --body cube; paper_notes/mpi.md, "The ranks' cells: a graph partition").
// Faces: bottom (z = 0), top (z = a), sides (the other four).
DefineConstant[ a = {0.1, Name "Parameters/a"} ];  // edge (m)
DefineConstant[ n = {10, Name "Parameters/n"} ];   // cells along an edge
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
Transfinite Surface{1};
Recombine Surface{1};
side[] = Extrude {0, 0, a} { Surface{1}; Layers{n}; Recombine; };
Physical Surface("bottom") = {1};
Physical Surface("top") = {side[0]};
Physical Surface("sides") = {side[2], side[3], side[4], side[5]};
Physical Volume("body") = {side[1]};
