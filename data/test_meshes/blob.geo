SetFactory("OpenCASCADE");
Ellipsoid = 0;
Sphere(1) = {0, 0, 0, 1.0};
Box(2) = {-0.3, -0.3, 0.4, 0.6, 0.6, 1.2};
BooleanUnion{ Volume{1}; Delete; }{ Volume{2}; Delete; }
Mesh.CharacteristicLengthMax = 0.45;
Mesh.MshFileVersion = 2.2;
Mesh.Binary = 0;
