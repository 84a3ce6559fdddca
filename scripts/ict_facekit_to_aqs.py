#!/usr/bin/env python3
"""Converts the ICT-FaceKit light face model into the folder the face configs read
(configs/face_full.flags, face_250k.flags, face_full_fit.flags; make_fit_tests.py --ict):
the skin, the teeth and every expression as separate OBJ files.

Usage: ict_facekit_to_aqs.py FACEKIT OUT [--expressions NAME,...] [--teeth_tolerance CM]
       [--min_skin_motion CM] [--max_motion CM]

FACEKIT is a checkout of https://github.com/ICT-VGL/ICT-FaceKit (MIT license; the USC
Institute for Creative Technologies' Vision and Graphics Lab): its folder FaceXModel holds
generic_neutral_mesh.obj and one OBJ per expression blendshape, each with the whole
model's 26,719 vertices. FACEKIT may also be the FaceXModel folder itself. Written into
OUT (made if absent; these files are replaced, others left alone):

  skin_neutral.obj         ICT vertices [0, 13294) (face [0, 9409), head and neck
                           [9409, 11248), mouth socket [11248, 13294)) and the faces that
                           use only those: 13,226 in ICT-FaceKit
  teeth_neutral.obj        the teeth, ICT vertices [17039, 21451) numbered from 0, and
                           the faces that use only those: 4,490 in ICT-FaceKit
  poses/NAME.obj           the skin in expression NAME (same vertex order and faces)
  poses/NAME.teeth.obj     the teeth in NAME, for the expressions whose teeth move more
                           than --teeth_tolerance cm (default 1e-3) from the neutral's in
                           some coordinate (ICT-FaceKit at da5f95a: jawForward, jawLeft,
                           jawOpen, jawRight, 0.73 to 3.5 cm; the others 2e-4 at most,
                           rounding); a stale one from an earlier run is removed
  LICENSE                  copied from FACEKIT/LICENSE (or FaceXModel's folder or its
                           parent's): it must travel with the data

Only `v` and `f` records are kept (faces as vertex indices: `/vt/vn` stripped; quads stay
quads); coordinates are written with 6 decimals, as the inputs' (about 6 significant
digits). Units are the model's: centimetres (the head is about 25 cm wide), +y up, +z out
of the face. On ICT-FaceKit at commit da5f95a (2020-12-01) this writes, byte for byte,
the development data set ../shared/data/ict-face (55 expressions; all of it but its
README.md, checked 2026-12-07).

Where the numbers come from: the table "Face Model Topology" of ICT-FaceKit's README.md
gives inclusive ranges, per part, of vertex and polygon indices: All [0:26718] (26,719
vertices, 26,384 faces); Face [0:9408]; Head and Neck [9409:11247]; Mouth socket
[11248:13293] (polygons [11144:13225]); Eye sockets [13294:14061]; Gums and tongue
[14062:17038]; Teeth [17039:21450] (polygons [17006:21495]: 4,412 vertices, 4,490
faces); eyeballs, lacrimal fluid, eye blend and occlusion, eyelashes up to 26718. Faces
are chosen here by their vertices, which gives those polygon ranges.

The expressions are whole meshes in absolute positions, not offsets: ICT-FaceKit's
Scripts/face_model_io.py (_compute_shape_mode_deltas) makes each shape mode as
`mesh.points() - generic_neutral_mesh.points()`. So the positions are copied as they
are; a skin vertex that moves more than --max_motion cm in a coordinate (default 10; the
largest ICT motion is 3.8 cm) stops the script, as a file of offsets would. Expressions
are every OBJ of FaceXModel but generic_neutral_mesh.obj and identityNNN.obj (the identity
modes), or the --expressions list (a comma list of names). Without --expressions, an OBJ
whose skin moves no more than --min_skin_motion cm (default 0.01) is skipped with a
message: at da5f95a PupilDilate_L and PupilDilate_R (they move the irises; the skin
0.0045 cm at most).

Exit status: 0 done; 1 bad input (a missing folder or file, a file without 26,719
vertices, an unreadable record, an implausible motion: the message names the file) or an
output that cannot be written; 2 bad arguments (argparse).
A development-time tool; the project does not run it (tests/scripts runs it on a
synthetic model)."""
import argparse
import os
import re
import sys

PROGRAM = "ict_facekit_to_aqs.py"
ICT_VERTICES = 26719           # All [0:26718]
SKIN = (0, 13294)              # Face, Head and Neck, Mouth socket: [0:13293]
TEETH = (17039, 21451)         # Teeth [17039:21450]
NEUTRAL_FILE = "generic_neutral_mesh.obj"
IDENTITY_FILE = re.compile(r"identity\d+\.obj$")
HEADER = ("# ICT-FaceKit, Copyright (c) 2020 USC Institute for Creative Technologies, MIT"
          " License\n# (full text in LICENSE beside this folder). Extracted: v and f"
          " records only.\n")


def fail(message):
    sys.exit("%s: error: %s" % (PROGRAM, message))


def read_obj(path, with_faces):
    """The vertices ([x, y, z] floats) and, with with_faces, the faces (lists of 0-based
    vertex indices) of an OBJ file; every other record is passed over."""
    vertices, faces = [], []
    try:
        with open(path) as src:
            for number, line in enumerate(src, 1):
                if line.startswith("v "):
                    try:
                        xyz = [float(x) for x in line.split()[1:4]]
                    except ValueError:
                        xyz = []
                    if len(xyz) != 3:
                        fail("%s:%d: a vertex record without 3 numbers" % (path, number))
                    vertices.append(xyz)
                elif with_faces and line.startswith("f "):
                    face = []
                    for token in line.split()[1:]:
                        try:
                            k = int(token.split("/")[0])
                        except ValueError:
                            fail("%s:%d: a face corner that is not a vertex index: '%s'"
                                 % (path, number, token))
                        k = k - 1 if k > 0 else len(vertices) + k  # OBJ: -1 the last so far
                        face.append(k)
                    if len(face) < 3:
                        fail("%s:%d: a face of fewer than 3 corners" % (path, number))
                    faces.append((number, face))
    except OSError as e:
        fail("%s: %s" % (path, e.strerror))
    except UnicodeDecodeError:
        fail("%s: not a text file" % path)
    if len(vertices) != ICT_VERTICES:
        fail("%s: %d vertices, not the ICT face model's %d (is it a FaceXModel file?)"
             % (path, len(vertices), ICT_VERTICES))
    for number, face in faces:
        for k in face:
            if not 0 <= k < len(vertices):
                fail("%s:%d: face corner %d is not one of the %d vertices"
                     % (path, number, k + 1, len(vertices)))
    return vertices, [face for _, face in faces]


def part_faces(faces, part):
    """The faces whose corners all lie in part = (begin, end), renumbered from begin."""
    begin, end = part
    return [[k - begin for k in face] for face in faces
            if all(begin <= k < end for k in face)]


def max_motion(vertices, neutral, part):
    """The largest coordinate difference over the vertices of part, and its vertex."""
    largest, where = 0.0, part[0]
    for i in range(*part):
        d = max(abs(a - b) for a, b in zip(vertices[i], neutral[i]))
        if d > largest:
            largest, where = d, i
    return largest, where


def obj_text(vertices, part, faces):
    lines = [HEADER]
    lines += ["v %.6f %.6f %.6f\n" % tuple(vertices[i]) for i in range(*part)]
    lines += ["f %s\n" % " ".join(str(k + 1) for k in face) for face in faces]
    return "".join(lines)


def write_atomically(path, text):
    """The file whole or not at all: a temporary file beside it, then os.replace."""
    temp = path + ".tmp%d" % os.getpid()
    try:
        with open(temp, "w") as out:
            out.write(text)
        os.replace(temp, path)
    except OSError as e:
        if os.path.exists(temp):
            os.remove(temp)
        fail("%s: cannot write: %s" % (path, e.strerror))


def find_inputs(facekit):
    """The FaceXModel folder and the LICENSE file of a checkout (or of FaceXModel)."""
    if not os.path.isdir(facekit):
        fail("%s: no such folder (give an ICT-FaceKit checkout or its FaceXModel folder)"
             % facekit)
    model = os.path.join(facekit, "FaceXModel")
    if not os.path.isdir(model) and os.path.exists(os.path.join(facekit, NEUTRAL_FILE)):
        model = facekit
    neutral = os.path.join(model, NEUTRAL_FILE)
    if not os.path.isfile(neutral):
        fail("%s: no such file (is %s an ICT-FaceKit checkout?)" % (neutral, facekit))
    candidates = [os.path.join(facekit, "LICENSE"), os.path.join(model, "LICENSE"),
                  os.path.join(model, os.pardir, "LICENSE")]
    licenses = [path for path in candidates if os.path.isfile(path)]
    if not licenses:
        fail("%s: no such file: ICT-FaceKit's MIT license must travel with the data"
             % candidates[0])
    return model, neutral, os.path.normpath(licenses[0])


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("facekit", help="an ICT-FaceKit checkout (or its FaceXModel folder)")
    parser.add_argument("out", help="the folder to write (e.g. ../shared/data/ict-face)")
    parser.add_argument("--expressions", default="",
                        help="comma list of expression names (default: every OBJ but the "
                             "neutral and the identities whose skin moves)")
    parser.add_argument("--teeth_tolerance", type=float, default=1e-3,
                        help="cm: write NAME.teeth.obj when the teeth move more than this")
    parser.add_argument("--min_skin_motion", type=float, default=0.01,
                        help="cm: without --expressions, skip OBJs whose skin moves less")
    parser.add_argument("--max_motion", type=float, default=10.0,
                        help="cm: a skin vertex moving more stops the script (offsets?)")
    args = parser.parse_args()
    model, neutral_path, license_path = find_inputs(args.facekit)
    if args.expressions:
        names = [name.strip() for name in args.expressions.split(",") if name.strip()]
        for name in names:
            path = os.path.join(model, name + ".obj")
            if not os.path.isfile(path):
                fail("%s: no such file (expression '%s' of --expressions)" % (path, name))
    else:
        names = sorted(f[:-4] for f in os.listdir(model)
                       if f.endswith(".obj") and f != NEUTRAL_FILE
                       and not IDENTITY_FILE.match(f))
        if not names:
            fail("%s: no expression OBJ beside %s" % (model, NEUTRAL_FILE))

    neutral, faces = read_obj(neutral_path, with_faces=True)
    skin_faces, teeth_faces = part_faces(faces, SKIN), part_faces(faces, TEETH)
    if not skin_faces or not teeth_faces:
        fail("%s: no face uses only %s vertices" % (
            neutral_path, "skin [0, 13294)" if not skin_faces else "teeth [17039, 21451)"))
    poses = os.path.join(args.out, "poses")
    try:
        os.makedirs(poses, exist_ok=True)
    except OSError as e:
        fail("%s: cannot make the folder: %s" % (poses, e.strerror))

    written, with_teeth, skipped = [], [], []
    for name in names:
        path = os.path.join(model, name + ".obj")
        vertices, _ = read_obj(path, with_faces=False)
        skin_motion, vertex = max_motion(vertices, neutral, SKIN)
        if skin_motion > args.max_motion:
            fail("%s: skin vertex %d moves %.3g cm from the neutral, more than --max_motion "
                 "%g: not an expression in absolute positions?" % (path, vertex, skin_motion,
                                                                     args.max_motion))
        if not args.expressions and skin_motion <= args.min_skin_motion:
            skipped.append(name)
            print("skipped %s: its skin moves %.2g cm at most (--min_skin_motion %g)"
                  % (path, skin_motion, args.min_skin_motion))
            continue
        teeth_motion, _ = max_motion(vertices, neutral, TEETH)
        pose_path = os.path.join(poses, name + ".obj")
        write_atomically(pose_path, obj_text(vertices, SKIN, skin_faces))
        teeth_path = os.path.join(poses, name + ".teeth.obj")
        note = ""
        if teeth_motion > args.teeth_tolerance:
            write_atomically(teeth_path, obj_text(vertices, TEETH, teeth_faces))
            with_teeth.append(name)
            note = "; teeth up to %.3g cm: %s" % (teeth_motion, teeth_path)
        elif os.path.exists(teeth_path):
            os.remove(teeth_path)  # an earlier run's (another tolerance): the teeth rest now
            note = "; removed the stale %s" % teeth_path
        written.append(name)
        print("wrote %s (skin up to %.3g cm%s)" % (pose_path, skin_motion, note))

    if not written:
        fail("%s: no expression whose skin moves more than --min_skin_motion %g cm"
             % (model, args.min_skin_motion))
    skin_path = os.path.join(args.out, "skin_neutral.obj")
    teeth_path = os.path.join(args.out, "teeth_neutral.obj")
    write_atomically(skin_path, obj_text(neutral, SKIN, skin_faces))
    write_atomically(teeth_path, obj_text(neutral, TEETH, teeth_faces))
    try:
        with open(license_path) as src:
            license_text = src.read()
    except (OSError, UnicodeDecodeError):
        fail("%s: cannot read" % license_path)
    write_atomically(os.path.join(args.out, "LICENSE"), license_text)
    print("wrote %s: %d vertices, %d faces" % (skin_path, SKIN[1] - SKIN[0], len(skin_faces)))
    print("wrote %s: %d vertices, %d faces" % (teeth_path, TEETH[1] - TEETH[0],
                                               len(teeth_faces)))
    print("wrote %s (from %s)" % (os.path.join(args.out, "LICENSE"), license_path))
    print("%d expressions in %s; teeth files for %d (%s)%s" % (
        len(written), poses, len(with_teeth), ", ".join(with_teeth) or "none",
        "; skipped %d (%s)" % (len(skipped), ", ".join(skipped)) if skipped else ""))


if __name__ == "__main__":
    main()
