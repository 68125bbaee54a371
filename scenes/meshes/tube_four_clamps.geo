// A tube clamped on part of its outside: the cross-section of scenes/tube_four_clamps.toml.
// Tube R = 1 m (the contact circle, N = 72 nodes) to 1.25 m, clamped on four arcs of its
// outside, each 70 degrees wide, centred at 45, 135, 225 and 315 degrees; the four
// 20-degree windows between them are free (with 30-degree windows the steady sliding
// pressure turns negative in them: no steady sliding to start from). 4-fold symmetry:
// it splits the +-k doublets
// whose 2k is a multiple of 4 (k = 2, 4, 6, ...) and leaves the odd k degenerate.
R = 1.0; Ro = 1.25; N = 72; W = 20;  // W: the free windows' width (degrees)
h = 2 * Pi * R / N;
Point(1) = {0, 0, 0, h};
// contact circle: four quarter arcs, N / 4 edges each
For j In {0:3}
  Point(10 + j) = {R * Cos(j * Pi / 2), R * Sin(j * Pi / 2), 0, h};
EndFor
For j In {0:3}
  Circle(10 + j) = {10 + j, 1, 10 + (j + 1) % 4};
  Transfinite Curve{10 + j} = N / 4 + 1;
EndFor
// outside: arc ends at 10, 80, 100, 170, ... degrees (clamped [10, 80], free [80, 100], ...)
For j In {0:7}
  a = (W / 2 + (90 - W) * Ceil(j / 2) + W * Floor(j / 2)) * Pi / 180;
  Point(20 + j) = {Ro * Cos(a), Ro * Sin(a), 0, h};
EndFor
For j In {0:7}
  Circle(20 + j) = {20 + j, 1, 20 + (j + 1) % 8};
EndFor
Curve Loop(1) = {20:27};
Curve Loop(2) = {10:13};
Plane Surface(1) = {1, 2};
Physical Curve("contact") = {10:13};
Physical Curve("clamped") = {20, 22, 24, 26};
Physical Surface("tube") = {1};
