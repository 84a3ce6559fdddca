#!/usr/bin/env python3
"""Copies a subset of the ICT face expressions into a folder, keeping only the vertex
records of the pose files (their faces are the neutral's), to vendor a small demo set.

Usage: make_face_subset.py SOURCE_DIR DEST_DIR NAME...
Copies SOURCE_DIR/poses/NAME.obj (and NAME.teeth.obj where it exists) to DEST_DIR/poses/.
A NAME of the form A+B writes the blend of two expressions instead: vertex by vertex
A + B - neutral (the ICT expressions are blend shapes: e.g. jawOpen+mouthClose closes
the lips over an opened jaw), and for the teeth the same with teeth_neutral.obj (parts without
teeth files leave the teeth at rest).
A development-time tool; the project does not run it."""
import os
import sys


def copy_vertices(source, dest):
    with open(source) as src, open(dest, "w") as out:
        out.write("# vertices of %s (faces: see skin_neutral.obj / teeth_neutral.obj)\n"
                  % os.path.basename(source))
        for line in src:
            if line.startswith("v "):
                out.write(line)


def read_vertices(path):
    with open(path) as src:
        return [[float(x) for x in line.split()[1:4]] for line in src if line.startswith("v ")]


def write_blend(source, dest, name, suffix, neutral_name):
    parts = name.split("+")
    paths = [os.path.join(source, "poses", part + suffix) for part in parts]
    if suffix == ".teeth.obj":  # a part without teeth leaves them at rest
        paths = [path for path in paths if os.path.exists(path)]
    if not paths or not all(os.path.exists(path) for path in paths):
        return False
    neutral = read_vertices(os.path.join(source, neutral_name))
    blend = [list(v) for v in neutral]
    for path in paths:
        for i, v in enumerate(read_vertices(path)):
            for k in range(3):
                blend[i][k] += v[k] - neutral[i][k]
    with open(os.path.join(dest, "poses", name + suffix), "w") as out:
        out.write("# blend %s: sum of the expressions' offsets from %s\n"
                  % (" + ".join(parts), neutral_name))
        for v in blend:
            out.write("v %.6f %.6f %.6f\n" % tuple(v))
    return True


def main():
    if len(sys.argv) < 3:
        sys.exit("usage: make_face_subset.py ICT_FOLDER OUTPUT_FOLDER [POSE ...]")
    source, dest, names = sys.argv[1], sys.argv[2], sys.argv[3:]
    os.makedirs(os.path.join(dest, "poses"), exist_ok=True)
    for name in names:
        if "+" in name:
            if not write_blend(source, dest, name, ".obj", "skin_neutral.obj"):
                sys.exit("missing a part of " + name)
            write_blend(source, dest, name, ".teeth.obj", "teeth_neutral.obj")
            continue
        for suffix in (".obj", ".teeth.obj"):
            path = os.path.join(source, "poses", name + suffix)
            if os.path.exists(path):
                copy_vertices(path, os.path.join(dest, "poses", name + suffix))
            elif suffix == ".obj":
                sys.exit("missing " + path)


if __name__ == "__main__":
    main()
