#!/usr/bin/env python3
"""Runs scripts/ict_facekit_to_aqs.py on a synthetic ICT-FaceKit checkout and checks that
it takes the skin and the teeth apart as the face configs expect, and that bad input gets
exit 1 with a message naming the file.

    ict_facekit_to_aqs_test.py SCRIPT DEMO

DEMO is data/ict-face-demo. The checkout's FaceXModel has the whole model's 26,719
vertices: the demo's skin (13,294 vertices, ICT's [0, 13294)) and teeth (4,412, ICT's
[17039, 21451)) at their ICT places, filler vertices and faces for the other parts (eye
sockets, gums, eyes), faces with /vt/vn corners, and faces that join the skin or the teeth
to a filler part (they belong to neither). Its expressions: jawOpen and jawLeft (the
demo's skin and teeth poses), mouthFunnel (the teeth moved by 1e-4 cm, below the
tolerance), PupilDilate_L (only filler moves: skipped) and identity000 (not an
expression: it has 5 vertices and must not be read).

Exit status: 0 passed; 1 failed.
"""

import os
import shutil
import subprocess
import sys
import tempfile

ICT_VERTICES = 26719
SKIN = (0, 13294)
TEETH = (17039, 21451)


def read_obj(path):
    """Vertices (tuples of floats) and faces (tuples of 0-based indices) of an OBJ file."""
    vertices, faces = [], []
    with open(path) as f:
        for line in f:
            if line.startswith("v "):
                vertices.append(tuple(float(x) for x in line.split()[1:4]))
            elif line.startswith("f "):
                faces.append(tuple(int(t.split("/")[0]) - 1 for t in line.split()[1:]))
    return vertices, faces


def filler(i):
    """A made-up position for ICT vertex i of a part the script leaves out."""
    return (0.01 * (i % 97) - 0.5, 0.02 * (i % 89) - 1.0, 0.005 * (i % 83))


def write_ict_obj(path, vertices, faces=()):
    """An OBJ file as FaceXModel's: a comment block, mtllib, vertices in shortest form,
    texture coordinates and normals, faces with v/vt/vn corners under usemtl lines."""
    lines = ["#" * 40 + "\n# synthetic ICT-FaceKit file\n" + "#" * 40 + "\n\n",
             "mtllib ICTFaceModelMaterial.mtl\n"]
    lines += ["v %r %r %r\n" % tuple(v) for v in vertices]
    if faces:
        lines += ["vt 0.5 0.5\n", "vn 0 0 1\n", "usemtl M_Face\ng face\n"]
        for face in faces:
            lines.append("f " + " ".join("%d/1/1" % (k + 1) for k in face) + "\n")
    with open(path, "w") as f:
        f.write("".join(lines))


def full_model(skin, teeth, moved=0.0):
    """26,719 vertices: skin at [0, 13294), teeth at [17039, 21451), filler elsewhere
    (shifted by moved in x)."""
    vertices = [None] * ICT_VERTICES
    vertices[SKIN[0]:SKIN[1]] = skin
    vertices[TEETH[0]:TEETH[1]] = teeth
    for i in list(range(SKIN[1], TEETH[0])) + list(range(TEETH[1], ICT_VERTICES)):
        x, y, z = filler(i)
        vertices[i] = (x + moved, y, z)
    return vertices


def make_checkout(root, demo):
    """The synthetic checkout (root/FaceXModel, root/LICENSE); returns the demo's parts."""
    skin, skin_faces = read_obj(os.path.join(demo, "skin_neutral.obj"))
    teeth, teeth_faces = read_obj(os.path.join(demo, "teeth_neutral.obj"))
    assert len(skin) == SKIN[1] - SKIN[0] and len(teeth) == TEETH[1] - TEETH[0], \
        "the demo's skin and teeth are not ICT's 13,294 and 4,412 vertices"
    model = os.path.join(root, "FaceXModel")
    os.makedirs(model)
    shutil.copy(os.path.join(demo, "LICENSE"), os.path.join(root, "LICENSE"))
    # ICT's order of faces: skin, eye sockets, gums (one joins the skin: [13293, 13294,
    # 13295]), teeth, eyes (one joins the teeth: [21450, 21451, 21452]).
    faces = list(skin_faces)
    faces += [(13294 + 3 * k, 13295 + 3 * k, 13296 + 3 * k) for k in range(20)]
    faces += [(13293, 13294, 13295), (17036, 17037, 17038, 17035), (17038, 17039, 17040)]
    faces += [tuple(k + TEETH[0] for k in face) for face in teeth_faces]
    faces += [(21450, 21451, 21452)] + [(21451 + 4 * k, 21452 + 4 * k, 21453 + 4 * k,
                                         21454 + 4 * k) for k in range(30)]
    write_ict_obj(os.path.join(model, "generic_neutral_mesh.obj"), full_model(skin, teeth),
                  faces)
    poses = {}
    for name in ("jawOpen", "jawLeft", "mouthFunnel"):
        pose_skin, _ = read_obj(os.path.join(demo, "poses", name + ".obj"))
        teeth_path = os.path.join(demo, "poses", name + ".teeth.obj")
        if os.path.exists(teeth_path):
            pose_teeth, _ = read_obj(teeth_path)
        else:  # rounding noise, as ICT's expressions have on the teeth
            pose_teeth = [(x + 1e-4, y - 1e-4, z) for x, y, z in teeth]
        poses[name] = (pose_skin, pose_teeth if os.path.exists(teeth_path) else None)
        write_ict_obj(os.path.join(model, name + ".obj"),
                      full_model(pose_skin, pose_teeth, moved=0.3), faces)
    write_ict_obj(os.path.join(model, "PupilDilate_L.obj"), full_model(skin, teeth, 0.2),
                  faces)
    write_ict_obj(os.path.join(model, "identity000.obj"), skin[:5])
    return model, (skin, skin_faces), (teeth, teeth_faces), poses


def run(command):
    return subprocess.run(command, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                          universal_newlines=True)


def compare(failures, path, expected_vertices, expected_faces):
    if not os.path.exists(path):
        failures.append("%s was not written" % path)
        return
    vertices, faces = read_obj(path)
    if vertices != list(expected_vertices):
        wrong = [i for i, (a, b) in enumerate(zip(vertices, expected_vertices)) if a != b]
        failures.append("%s: %d vertices (expected %d), %d differ (first: %s)"
                        % (path, len(vertices), len(expected_vertices), len(wrong), wrong[:3]))
    if faces != list(expected_faces):
        failures.append("%s: %d faces, not the expected %d (or not in their order)"
                        % (path, len(faces), len(expected_faces)))


def expect_error(failures, what, command, named):
    result = run(command)
    if result.returncode != 1 or named not in result.stdout or "Traceback" in result.stdout:
        failures.append("%s must exit 1 naming '%s', got %d:\n%s"
                        % (what, named, result.returncode, result.stdout))


def main():
    if len(sys.argv) != 3:
        print("usage: ict_facekit_to_aqs_test.py SCRIPT DEMO")
        return 1
    script, demo = sys.argv[1], sys.argv[2]
    root = tempfile.mkdtemp(prefix="aqs_ict_facekit_test_")
    failures = []
    try:
        checkout = os.path.join(root, "ICT-FaceKit")
        model, (skin, skin_faces), (teeth, teeth_faces), poses = make_checkout(checkout,
                                                                             demo)
        out = os.path.join(root, "ict-face")
        os.makedirs(os.path.join(out, "poses"))
        stale = os.path.join(out, "poses", "mouthFunnel.teeth.obj")  # an earlier run's
        with open(stale, "w") as f:
            f.write("v 0 0 0\n")
        result = run([sys.executable, script, checkout, out])
        print(result.stdout, end="")
        if result.returncode != 0:
            failures.append("the conversion exited %d" % result.returncode)
        compare(failures, os.path.join(out, "skin_neutral.obj"), skin, skin_faces)
        compare(failures, os.path.join(out, "teeth_neutral.obj"), teeth, teeth_faces)
        for name, (pose_skin, pose_teeth) in sorted(poses.items()):
            compare(failures, os.path.join(out, "poses", name + ".obj"), pose_skin,
                    skin_faces)
            if pose_teeth is not None:
                compare(failures, os.path.join(out, "poses", name + ".teeth.obj"),
                        pose_teeth, teeth_faces)
        written = sorted(os.listdir(os.path.join(out, "poses")))
        expected = ["jawLeft.obj", "jawLeft.teeth.obj", "jawOpen.obj", "jawOpen.teeth.obj",
                    "mouthFunnel.obj"]
        if written != expected:
            failures.append("poses/ holds %s, expected %s (teeth only where they moved; "
                            "the stale mouthFunnel.teeth.obj removed; PupilDilate_L "
                            "skipped)" % (written, expected))
        with open(os.path.join(demo, "LICENSE")) as a, open(os.path.join(out, "LICENSE")) as b:
            if a.read() != b.read():
                failures.append("LICENSE is not a copy of the checkout's")
        if "skipped" not in result.stdout or "PupilDilate_L" not in result.stdout:
            failures.append("the skipped PupilDilate_L is not reported")
        # Only v and f records; quads stay quads.
        with open(os.path.join(out, "skin_neutral.obj")) as f:
            kinds = {line.split()[0] for line in f if line.strip()}
        if kinds != {"#", "v", "f"}:
            failures.append("skin_neutral.obj has records %s, expected only v and f"
                            % sorted(kinds))

        # Bad input: exit 1 naming the file.
        expect_error(failures, "a missing folder",
                     [sys.executable, script, os.path.join(root, "nosuch"), out], "nosuch")
        expect_error(failures, "a missing expression",
                     [sys.executable, script, checkout, out, "--expressions=jawOpen,nosuch"],
                     "nosuch.obj")
        short = os.path.join(model, "short.obj")
        with open(os.path.join(model, "jawOpen.obj")) as f:
            lines = f.readlines()
        last_vertex = max(i for i, line in enumerate(lines) if line.startswith("v "))
        with open(short, "w") as f:
            f.writelines(lines[:last_vertex] + lines[last_vertex + 1:])
        expect_error(failures, "an expression of 26,718 vertices",
                     [sys.executable, script, checkout, out, "--expressions=short"],
                     "short.obj: 26718 vertices")
        neutral = full_model(skin, teeth)
        offsets = [tuple(a - b for a, b in zip(p, q)) for p, q in
                   zip(full_model(poses["jawOpen"][0], poses["jawOpen"][1]), neutral)]
        write_ict_obj(os.path.join(model, "offsets.obj"), offsets)
        expect_error(failures, "an expression given as offsets",
                     [sys.executable, script, checkout, out, "--expressions=offsets"],
                     "offsets.obj: skin vertex")
        bare = os.path.join(root, "bare")  # no generic_neutral_mesh.obj, then no LICENSE
        os.makedirs(os.path.join(bare, "FaceXModel"))
        shutil.copy(os.path.join(model, "mouthFunnel.obj"), os.path.join(bare, "FaceXModel"))
        expect_error(failures, "a checkout without the neutral",
                     [sys.executable, script, bare, out], "generic_neutral_mesh.obj")
        shutil.copy(short, os.path.join(bare, "FaceXModel", "generic_neutral_mesh.obj"))
        expect_error(failures, "a checkout without LICENSE",
                     [sys.executable, script, bare, out], "LICENSE")
        shutil.copy(os.path.join(checkout, "LICENSE"), bare)
        expect_error(failures, "a neutral of 26,718 vertices",
                     [sys.executable, script, bare, out],
                     "generic_neutral_mesh.obj: 26718 vertices")
        temporary = [name for _, _, names in os.walk(out) for name in names if ".tmp" in name]
        if temporary:
            failures.append("temporary files left: %s" % temporary)
    finally:
        if os.environ.get("AQS_KEEP_TEST_FILES", "0") not in ("", "0"):
            print("kept " + root)
        else:
            shutil.rmtree(root, ignore_errors=True)
    for failure in failures:
        print("FAILED: " + failure)
    if not failures:
        print("ict_facekit_to_aqs.py: parts, poses, teeth files and bad-input messages "
              "checked")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
