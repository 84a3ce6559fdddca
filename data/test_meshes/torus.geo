SetFactory("OpenCASCADE");
Torus(1) = {0, 0, 0, 1.0, 0.35};
Mesh.CharacteristicLengthMax = 0.3;
