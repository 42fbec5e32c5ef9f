// Two blocks, one on the other: a slab (disc) and a pad, meshed each on its own (their faces
// at z = thickness do not match: pair them with contact.mortar). For the tests of mesh.cad.
SetFactory("OpenCASCADE");
DefineConstant[ thickness = 0.01, pad_size = 0.02 ];
Box(1) = {0, 0, 0, 0.05, 0.05, thickness};
Box(2) = {0.015, 0.015, thickness, pad_size, pad_size, 0.008};
Physical Volume("disc") = {1};
Physical Volume("pad") = {2};
Physical Surface("disc_top") = {6};
Physical Surface("pad_bottom") = {11};
Physical Surface("disc_bottom") = {5};
Physical Surface("pad_top") = {12};
