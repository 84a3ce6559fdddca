SetFactory("OpenCASCADE");
Cone(1) = {0, 0, 0, 0, 0, 6, 1.0, 0.55};
Sphere(2) = {0, 0, 6, 0.55};
BooleanUnion{ Volume{1}; Delete; }{ Volume{2}; Delete; }
Mesh.CharacteristicLengthMax = 0.2;
Mesh.CharacteristicLengthMin = 0.12;
Mesh.MshFileVersion = 4.1;
Mesh.Binary = 0;
Mesh.Optimize = 1;
