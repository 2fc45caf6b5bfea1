// A plate with a central hole, 100 x 40 x 5 mm (lengths in mm), hole radius 8 mm, with 10 mm
// grips at both ends; meshed by gmsh when peridyn reads examples/meshed_plate_hole.yaml.
// Physical groups: volumes Plate, GripLeft, GripRight (blocks and node sets), surface Hole.
SetFactory("OpenCASCADE");
Box(1) = {0, 0, 0, 100, 40, 5};
Cylinder(2) = {50, 20, 0, 0, 0, 5, 8};
BooleanDifference(3) = { Volume{1}; Delete; }{ Volume{2}; Delete; };
Box(4) = {0, 0, 0, 10, 40, 5};
Box(5) = {90, 0, 0, 10, 40, 5};
BooleanFragments{ Volume{3}; Delete; }{ Volume{4, 5}; Delete; }
Physical Volume("Plate") = Volume In BoundingBox{9.9, -1, -1, 90.1, 41, 6};
Physical Volume("GripLeft") = Volume In BoundingBox{-1, -1, -1, 10.1, 41, 6};
Physical Volume("GripRight") = Volume In BoundingBox{89.9, -1, -1, 101, 41, 6};
Physical Surface("Hole") = Surface In BoundingBox{41.9, 11.9, -1, 58.1, 28.1, 6};
Mesh.MeshSizeMax = 2.5;
