#!/usr/bin/env python3
"""Copies a subset of the ICT face expressions into a folder, keeping only the vertex
records of the pose files (their faces are the neutral's), to vendor a small demo set.

Usage: make_face_subset.py SOURCE_DIR DEST_DIR NAME...
Copies SOURCE_DIR/poses/NAME.obj (and NAME.teeth.obj where it exists) to DEST_DIR/poses/.
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


def main():
    source, dest, names = sys.argv[1], sys.argv[2], sys.argv[3:]
    os.makedirs(os.path.join(dest, "poses"), exist_ok=True)
    for name in names:
        for suffix in (".obj", ".teeth.obj"):
            path = os.path.join(source, "poses", name + suffix)
            if os.path.exists(path):
                copy_vertices(path, os.path.join(dest, "poses", name + suffix))
            elif suffix == ".obj":
                sys.exit("missing " + path)


if __name__ == "__main__":
    main()
