// A ventilated disc brake for a compact car's front axle, as squeal meshes it from CAD
// (mesh.cad): a disc of two friction rings (cheeks) joined by straight radial vanes, with a
// hat bolted to the hub, and two pads, each a lining on a steel backplate, centred on the
// x axis on both sides of the disc. The proportions are catalogue ones for that class of car
// (a 280 x 22 mm ventilated disc on a 5 x 112 mm bolt circle, 57 mm centre bore). Lengths in
// metres; every number below may be set by a study (mesh.cad's `set`), and `mesh_size` is.
//
// Each volume is meshed on its own: the linings meet the disc and their backplates on
// non-matching faces (contact.mortar pairs the first, assemble's ties join the second).
SetFactory("OpenCASCADE");
DefineConstant[
  r_out = 0.140,        // the disc's outer radius (280 mm disc)
  r_in = 0.090,         // the friction rings' inner radius
  cheek = 0.0065,       // each friction ring's thickness
  vane_height = 0.009,  // the vent's height: the disc is 2 cheek + vane_height thick (22 mm)
  vanes = 36,           // straight radial vanes
  vane_width = 0.005,
  vane_inset = 0.003,   // the vanes stop short of the rim
  hat_radius = 0.081,   // the hat's outer radius
  hat_wall = 0.006,
  hat_height = 0.040,   // from the disc's inboard face to the hat's top
  hat_top = 0.006,
  bore = 0.0285,        // the centre bore's radius (57 mm)
  bolt_circle = 0.056,  // 5 bolts on a 112 mm circle
  bolt_radius = 0.0075,
  pad_angle = 55,       // degrees: the linings' angular extent
  pad_r_in = 0.095,
  pad_r_out = 0.137,
  lining = 0.010,
  backplate = 0.005,
  backplate_margin = 0.002
];
thickness = 2 * cheek + vane_height;

// The disc: cheeks, vanes and the hat, fused into one volume.
Cylinder(1) = {0, 0, 0, 0, 0, cheek, r_out};
Cylinder(2) = {0, 0, 0, 0, 0, cheek, r_in};
BooleanDifference(3) = { Volume{1}; Delete; }{ Volume{2}; Delete; };
Cylinder(4) = {0, 0, cheek + vane_height, 0, 0, cheek, r_out};
Cylinder(5) = {0, 0, cheek + vane_height, 0, 0, cheek, hat_radius - hat_wall};
BooleanDifference(6) = { Volume{4}; Delete; }{ Volume{5}; Delete; };
vane_list[] = {};
For k In {0 : vanes - 1}
  Box(100 + k) = {r_in, -vane_width / 2, cheek, r_out - vane_inset - r_in, vane_width, vane_height};
  Rotate {{0, 0, 1}, {0, 0, 0}, 2 * Pi * k / vanes} { Volume{100 + k}; }
  vane_list[] += {100 + k};
EndFor
Cylinder(7) = {0, 0, cheek + vane_height, 0, 0, hat_height - cheek - vane_height, hat_radius};
Cylinder(8) = {0, 0, cheek + vane_height, 0, 0, hat_height - cheek - vane_height, hat_radius - hat_wall};
BooleanDifference(9) = { Volume{7}; Delete; }{ Volume{8}; Delete; };
Cylinder(10) = {0, 0, hat_height, 0, 0, hat_top, hat_radius};
Cylinder(11) = {0, 0, hat_height, 0, 0, hat_top, bore};
holes[] = {11};
For k In {0 : 4}
  Cylinder(20 + k) = {bolt_circle * Cos(2 * Pi * k / 5), bolt_circle * Sin(2 * Pi * k / 5), hat_height, 0, 0, hat_top, bolt_radius};
  holes[] += {20 + k};
EndFor
BooleanDifference(12) = { Volume{10}; Delete; }{ Volume{holes[]}; Delete; };
disc() = BooleanUnion{ Volume{3}; Delete; }{ Volume{6, 9, 12, vane_list[]}; Delete; };

// The pads: a lining on a backplate on each side, as annular sectors about the x axis.
half = pad_angle * Pi / 360;
Cylinder(200) = {0, 0, thickness, 0, 0, lining, pad_r_out, 2 * half};
Cylinder(201) = {0, 0, thickness, 0, 0, lining, pad_r_in, 2 * half};
BooleanDifference(202) = { Volume{200}; Delete; }{ Volume{201}; Delete; };
Rotate {{0, 0, 1}, {0, 0, 0}, -half} { Volume{202}; }
Cylinder(210) = {0, 0, thickness + lining, 0, 0, backplate, pad_r_out + backplate_margin, 2 * half + 0.05};
Cylinder(211) = {0, 0, thickness + lining, 0, 0, backplate, pad_r_in - backplate_margin, 2 * half + 0.05};
BooleanDifference(212) = { Volume{210}; Delete; }{ Volume{211}; Delete; };
Rotate {{0, 0, 1}, {0, 0, 0}, -half - 0.025} { Volume{212}; }
// The inboard pad: the outboard one mirrored through the disc's mid-plane.
inboard[] = Symmetry {0, 0, 1, -thickness / 2} { Duplicata { Volume{202, 212}; } };

Physical Volume("disc") = {disc()};
Physical Volume("lining") = {202, inboard[0]};
Physical Volume("backplate") = {212, inboard[1]};

// The surfaces a study names, picked by the plane they lie in.
eps = 1e-6;
disc_friction[] = {};
boundary[] = Abs(Boundary{ Volume{disc()}; });
For i In {0 : #boundary[] - 1}
  bb[] = BoundingBox Surface{boundary[i]};
  If ((Fabs(bb[2] - (0)) < eps && Fabs(bb[5] - (0)) < eps) || (Fabs(bb[2] - (thickness)) < eps && Fabs(bb[5] - (thickness)) < eps))
    disc_friction[] += boundary[i];
  EndIf
EndFor
Physical Surface("disc_friction") = {disc_friction[]};
lining_friction[] = {};
boundary[] = Abs(Boundary{ Volume{202, inboard[0]}; });
For i In {0 : #boundary[] - 1}
  bb[] = BoundingBox Surface{boundary[i]};
  If ((Fabs(bb[2] - (thickness)) < eps && Fabs(bb[5] - (thickness)) < eps) || (Fabs(bb[2] - (0)) < eps && Fabs(bb[5] - (0)) < eps))
    lining_friction[] += boundary[i];
  EndIf
EndFor
Physical Surface("lining_friction") = {lining_friction[]};
lining_back[] = {};
boundary[] = Abs(Boundary{ Volume{202, inboard[0]}; });
For i In {0 : #boundary[] - 1}
  bb[] = BoundingBox Surface{boundary[i]};
  If ((Fabs(bb[2] - (thickness + lining)) < eps && Fabs(bb[5] - (thickness + lining)) < eps) || (Fabs(bb[2] - (-lining)) < eps && Fabs(bb[5] - (-lining)) < eps))
    lining_back[] += boundary[i];
  EndIf
EndFor
Physical Surface("lining_back") = {lining_back[]};
backplate_front[] = {};
boundary[] = Abs(Boundary{ Volume{212, inboard[1]}; });
For i In {0 : #boundary[] - 1}
  bb[] = BoundingBox Surface{boundary[i]};
  If ((Fabs(bb[2] - (thickness + lining)) < eps && Fabs(bb[5] - (thickness + lining)) < eps) || (Fabs(bb[2] - (-lining)) < eps && Fabs(bb[5] - (-lining)) < eps))
    backplate_front[] += boundary[i];
  EndIf
EndFor
Physical Surface("backplate_front") = {backplate_front[]};
pad_backs[] = {};
boundary[] = Abs(Boundary{ Volume{212, inboard[1]}; });
For i In {0 : #boundary[] - 1}
  bb[] = BoundingBox Surface{boundary[i]};
  If ((Fabs(bb[2] - (thickness + lining + backplate)) < eps && Fabs(bb[5] - (thickness + lining + backplate)) < eps) || (Fabs(bb[2] - (-lining - backplate)) < eps && Fabs(bb[5] - (-lining - backplate)) < eps))
    pad_backs[] += boundary[i];
  EndIf
EndFor
Physical Surface("pad_backs") = {pad_backs[]};

// The bolt holes' walls: the hub clamps the disc there.
bolts[] = {};
boundary[] = Abs(Boundary{ Volume{disc()}; });
For i In {0 : #boundary[] - 1}
  bb[] = BoundingBox Surface{boundary[i]};
  If (bb[2] > hat_height - eps && bb[5] < hat_height + hat_top + eps && bb[3] - bb[0] < 2 * bolt_radius + eps && bb[4] - bb[1] < 2 * bolt_radius + eps && bb[3] - bb[0] > eps && bb[4] - bb[1] > eps)
    bolts[] += boundary[i];
  EndIf
EndFor
Physical Surface("bolts") = {bolts[]};
Mesh.SecondOrderLinear = 1;  // straight-sided quadratic tetrahedra: none inverted on curved faces
Mesh.OptimizeNetgen = 1;
