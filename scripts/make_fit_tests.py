#!/usr/bin/python3
"""Makes held-out test sets for fitting (aqs_bench_fit, aqs_fit) from the ICT face data:
random sparse blendshape mixes, marker subsets of them, partial noisy scans of them, and
a smooth marker sequence. The ICT face data (--ict) are made from ICT-FaceKit by
scripts/ict_facekit_to_aqs.py (docs/tutorial_face.md, "Getting the full ICT face").

Usage: /usr/bin/python3 scripts/make_fit_tests.py --ict ../shared/data/ict-face --out DIR
       [--seed 1] [--mixes 20] [--min_expressions 2] [--max_expressions 5]
       [--min_weight 0.3] [--max_weight 1.0] [--markers 20,60] [--marker_noise 0.01]
       [--scan_points 4000] [--scan_noise 0.02] [--scan_min_z 8] [--scan_outliers 0]
       [--landmark_noise 0.1] [--scan_markers 0] [--own_scan_generator]
       [--frames 100] [--sequence_markers 60] [--sequence_expressions 6]

Every mix is target = neutral + sum_i w_i (pose_i - neutral) over 2 to 5 of the 55
expressions (uniform), weights uniform in [min_weight, max_weight] (ICT blendshapes are
linear). Written into DIR (made if absent; files are replaced):

  mixes.csv                  mix,expressions   (e.g. "mix_000,jawOpen:0.52 mouthSmile_L:0.9")
  poses/mix_NNN.obj          the mix (v records only, the neutral's vertex order)
  marker_sets/mK.txt         the K marker vertices (one index per line): farthest-point
                             samples of the front of the face (vertices 0:9409 whose
                             neutral z >= 6 cm), the first K of one ordering, so the sets
                             are nested
  markers/mix_NNN_mK.txt     "vertex x y z" lines: the mix at those vertices plus Gaussian
                             noise of marker_noise cm per coordinate
  scans/mix_NNN.ply          scan_points points uniform by area on the mix's triangles whose
                             corners all have z >= scan_min_z (the front, as one depth
                             camera sees it), noise scan_noise cm per coordinate, shuffled,
                             plus scan_outliers points 1 to 3 cm off the surface
  scans/mix_NNN_landmarks.txt  "vertex x y z" lines: 10 landmarks of the scan, as a face
                             tracker finds them in its image (the inner and outer eye
                             corners, the mouth corners, the middles of the upper and lower
                             lip, the nose tip, the chin: face_landmarks below), with
                             Gaussian noise of landmark_noise cm per coordinate (drawn from
                             a generator of their own, so the other files do not change);
                             with --scan_markers K > 0 instead the K-marker set's vertices
                             (markers the scan shows: painted dots, motion-capture markers)
  sequence/markers/frame_NNNN.txt, sequence/truth/frame_NNNN.obj, sequence/weights.csv:
                             a smooth sequence of `frames` frames (30 per second): each of
                             sequence_expressions expressions (jawOpen always among them)
                             follows w(t) = clip(a sin(2 pi f t + phase), 0, 1), f 0.3 to
                             0.8 Hz; markers on the sequence_markers set

Fixed seed: the same arguments give the same files. Needs numpy (Debian's python3).
A development-time tool; the project's tests do not run it."""
import argparse
import os
import shutil
import sys

import numpy as np

FACE_VERTICES = 9409  # the ICT face region is vertices [0, 9409)
MARKER_MIN_Z = 6.0


def read_vertices(path):
    try:
        with open(path) as src:
            rows = [line.split()[1:4] for line in src if line.startswith("v ")]
    except OSError as e:
        sys.exit("make_fit_tests.py: error: %s: %s" % (path, e.strerror))
    return np.array(rows, dtype=float)


def read_triangles(path):
    triangles = []
    with open(path) as src:
        for line in src:
            if line.startswith("f "):
                corners = [int(token.split("/")[0]) - 1 for token in line.split()[1:]]
                for k in range(1, len(corners) - 1):
                    triangles.append((corners[0], corners[k], corners[k + 1]))
    return np.array(triangles, dtype=int)


def write_atomically(path, text):
    temp = path + ".tmp%d" % os.getpid()
    with open(temp, "w") as out:
        out.write(text)
    os.replace(temp, path)


def obj_text(vertices, comment):
    lines = ["# %s\n" % comment]
    lines += ["v %.6f %.6f %.6f\n" % tuple(v) for v in vertices]
    return "".join(lines)


def markers_text(vertices, positions, comment):
    lines = ["# %s\n# vertex x y z\n" % comment]
    lines += ["%d %.6f %.6f %.6f\n" % (v, p[0], p[1], p[2]) for v, p in zip(vertices, positions)]
    return "".join(lines)


def farthest_point_order(points, count, rng):
    """Indices into points: a random first one, then each the farthest from those chosen."""
    chosen = [int(rng.integers(len(points)))]
    distance = np.linalg.norm(points - points[chosen[0]], axis=1)
    while len(chosen) < count:
        nxt = int(np.argmax(distance))
        chosen.append(nxt)
        distance = np.minimum(distance, np.linalg.norm(points - points[nxt], axis=1))
    return chosen


def scan(surface, triangles, count, noise, min_z, outliers, rng):
    front = triangles[np.all(surface[triangles][:, :, 2] >= min_z, axis=1)]
    a, b, c = (surface[front[:, k]] for k in range(3))
    area = 0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1)
    pick = rng.choice(len(front), size=count, p=area / area.sum())
    u, v = rng.random(count), rng.random(count)
    flip = u + v > 1
    u[flip], v[flip] = 1 - u[flip], 1 - v[flip]
    points = a[pick] + u[:, None] * (b[pick] - a[pick]) + v[:, None] * (c[pick] - a[pick])
    points += rng.normal(0.0, noise, points.shape)
    if outliers > 0:
        normal = np.cross(b - a, c - a)
        normal /= np.maximum(np.linalg.norm(normal, axis=1, keepdims=True), 1e-12)
        where = rng.choice(len(front), size=outliers)
        base = (a[where] + b[where] + c[where]) / 3
        offset = rng.uniform(1.0, 3.0, outliers) * rng.choice([-1.0, 1.0], outliers)
        points = np.vstack([points, base + offset[:, None] * normal[where]])
    rng.shuffle(points)
    return points


def face_landmarks(neutral, jaw_open, triangles):
    """Vertex indices of 10 facial landmarks of the ICT face topology, found from its
    geometry: the eye corners are the innermost and outermost (|x|) vertices of each
    eyelid opening (the boundary loops above y = 2); the mouth corners are the extreme-x
    vertices of the lip seam (the edges of the mouth region that jawOpen stretches more
    than 3x, their front vertices, z > 8); the lip middles, the nose tip and the chin are
    the most forward (largest z) vertices near x = 0 just above and below the seam, overall,
    and more than 2.5 cm below it."""
    face = np.arange(FACE_VERTICES)
    edges = {}
    for t in triangles:
        for k in range(3):
            a, b = sorted((int(t[k]), int(t[(k + 1) % 3])))
            edges[(a, b)] = edges.get((a, b), 0) + 1
    landmarks = []
    boundary = {v for (a, b), n in edges.items() if n == 1 for v in (a, b) if v < FACE_VERTICES}
    for sign in (1, -1):
        loop = np.array([v for v in boundary if neutral[v, 1] > 2 and neutral[v, 0] * sign > 0])
        landmarks.append(int(loop[np.argmin(np.abs(neutral[loop, 0]))]))
        landmarks.append(int(loop[np.argmax(np.abs(neutral[loop, 0]))]))
    pairs = np.array([e for e in edges if e[1] < FACE_VERTICES])
    a, b = pairs[:, 0], pairs[:, 1]
    stretch = (np.linalg.norm(jaw_open[a] - jaw_open[b], axis=1) /
               np.linalg.norm(neutral[a] - neutral[b], axis=1))
    mouth = (np.abs(neutral[a, 0]) < 4) & (neutral[a, 1] < -3) & (neutral[a, 1] > -8)
    seam = np.unique(np.concatenate([a[mouth & (stretch > 3)], b[mouth & (stretch > 3)]]))
    seam = seam[neutral[seam, 2] > 8]
    if len(seam) == 0:
        sys.exit("make_fit_tests.py: error: no lip seam found (is this the ICT face?)")
    landmarks.append(int(seam[np.argmax(neutral[seam, 0])]))
    landmarks.append(int(seam[np.argmin(neutral[seam, 0])]))
    seam_y = neutral[seam, 1].mean()
    middle = np.abs(neutral[face, 0]) < 0.3
    y = neutral[face, 1]

    def most_forward(mask):
        return int(face[mask][np.argmax(neutral[face[mask], 2])])
    landmarks.append(most_forward(middle & (y > seam_y) & (y < seam_y + 1.5)))
    landmarks.append(most_forward(middle & (y < seam_y) & (y > seam_y - 1.5)))
    landmarks.append(most_forward(middle))
    landmarks.append(most_forward(middle & (y < seam_y - 2.5)))
    return landmarks


def ply_text(points, comment):
    head = ("ply\nformat ascii 1.0\ncomment %s\nelement vertex %d\nproperty float x\n"
            "property float y\nproperty float z\nend_header\n" % (comment, len(points)))
    return head + "".join("%.5f %.5f %.5f\n" % tuple(p) for p in points)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--ict", required=True, help="the ICT face folder (skin_neutral.obj, poses/)")
    parser.add_argument("--out", required=True)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--mixes", type=int, default=20)
    parser.add_argument("--min_expressions", type=int, default=2)
    parser.add_argument("--max_expressions", type=int, default=5)
    parser.add_argument("--min_weight", type=float, default=0.3)
    parser.add_argument("--max_weight", type=float, default=1.0)
    parser.add_argument("--markers", default="20,60")
    parser.add_argument("--marker_noise", type=float, default=0.01)
    parser.add_argument("--scan_points", type=int, default=4000)
    parser.add_argument("--scan_noise", type=float, default=0.02)
    parser.add_argument("--scan_min_z", type=float, default=8.0)
    parser.add_argument("--scan_outliers", type=int, default=0)
    parser.add_argument("--landmark_noise", type=float, default=0.1)
    parser.add_argument("--scan_markers", type=int, default=0,
                        help="landmarks: the K-marker set's vertices instead of 10 tracker "
                             "landmarks (K among --markers)")
    parser.add_argument("--own_scan_generator", action="store_true",
                        help="draw each mix's scan from a generator of its own (seed, 2, mix), "
                             "so that sets with other --scan_points, --scan_noise or "
                             "--scan_outliers share their mixes and markers (other mixes "
                             "than without it)")
    parser.add_argument("--frames", type=int, default=100)
    parser.add_argument("--sequence_markers", type=int, default=60)
    parser.add_argument("--sequence_expressions", type=int, default=6)
    args = parser.parse_args()
    marker_counts = [int(k) for k in args.markers.split(",") if k]
    if args.frames > 0 and args.sequence_markers not in marker_counts:
        marker_counts.append(args.sequence_markers)
    if args.scan_markers > 0 and args.scan_markers not in marker_counts:
        sys.exit("make_fit_tests.py: error: --scan_markers %d is not among --markers %s"
                 % (args.scan_markers, args.markers))
    rng = np.random.default_rng(args.seed)

    neutral = read_vertices(os.path.join(args.ict, "skin_neutral.obj"))
    triangles = read_triangles(os.path.join(args.ict, "skin_neutral.obj"))
    pose_dir = os.path.join(args.ict, "poses")
    names = sorted(f[:-4] for f in os.listdir(pose_dir) if f.endswith(".obj") and ".teeth" not in f)
    deltas = {}
    for name in names:
        pose = read_vertices(os.path.join(pose_dir, name + ".obj"))
        if pose.shape != neutral.shape:
            sys.exit("make_fit_tests.py: error: %s: %d vertices, the neutral has %d"
                     % (os.path.join(pose_dir, name + ".obj"), len(pose), len(neutral)))
        deltas[name] = pose - neutral
    if "jawOpen" not in deltas:
        sys.exit("make_fit_tests.py: error: %s: no jawOpen.obj (the landmarks need it)" % pose_dir)
    landmarks = face_landmarks(neutral, neutral + deltas["jawOpen"], triangles)
    landmark_rng = np.random.default_rng([args.seed, 1])

    # The folders this script writes start empty: an earlier run's files (other mixes,
    # more frames) would otherwise be read with this run's (aqs_bench_fit reads whole
    # folders).
    for sub in ["poses", "marker_sets", "markers", "scans", "sequence"]:
        shutil.rmtree(os.path.join(args.out, sub), ignore_errors=True)
    for sub in ["poses", "marker_sets", "markers", "scans", "sequence/markers", "sequence/truth"]:
        os.makedirs(os.path.join(args.out, sub), exist_ok=True)

    # Marker layouts: one farthest-point ordering of the front of the face.
    candidates = np.array([v for v in range(FACE_VERTICES) if neutral[v, 2] >= MARKER_MIN_Z])
    order = candidates[farthest_point_order(neutral[candidates], max(marker_counts), rng)]
    marker_sets = {}
    for k in marker_counts:
        marker_sets[k] = order[:k]
        write_atomically(os.path.join(args.out, "marker_sets", "m%d.txt" % k),
                         "# %d marker vertices (farthest-point samples of the face front)\n" % k
                         + "".join("%d\n" % v for v in order[:k]))

    manifest = ["mix,expressions\n"]
    for m in range(args.mixes):
        count = int(rng.integers(args.min_expressions, args.max_expressions + 1))
        chosen = sorted(rng.choice(len(names), size=count, replace=False))
        weights = rng.uniform(args.min_weight, args.max_weight, count)
        surface = neutral.copy()
        for i, w in zip(chosen, weights):
            surface += w * deltas[names[i]]
        label = "mix_%03d" % m
        recipe = " ".join("%s:%.3f" % (names[i], w) for i, w in zip(chosen, weights))
        manifest.append("%s,%s\n" % (label, recipe))
        write_atomically(os.path.join(args.out, "poses", label + ".obj"), obj_text(surface, recipe))
        for k, vertices in marker_sets.items():
            positions = surface[vertices] + rng.normal(0.0, args.marker_noise, (len(vertices), 3))
            write_atomically(os.path.join(args.out, "markers", "%s_m%d.txt" % (label, k)),
                             markers_text(vertices, positions, "%s: %s" % (label, recipe)))
        scan_rng = np.random.default_rng([args.seed, 2, m]) if args.own_scan_generator else rng
        points = scan(surface, triangles, args.scan_points, args.scan_noise, args.scan_min_z,
                      args.scan_outliers, scan_rng)
        write_atomically(os.path.join(args.out, "scans", label + ".ply"),
                         ply_text(points, "scan of %s: %s" % (label, recipe)))
        if args.scan_markers > 0:
            scan_landmarks = marker_sets[args.scan_markers]
            what = "the %d-marker set's vertices" % args.scan_markers
        else:
            scan_landmarks = landmarks
            what = ("eye corners: left inner, left outer, right inner, right outer; mouth "
                    "corners left, right; upper and lower lip; nose tip; chin")
        positions = surface[scan_landmarks] + landmark_rng.normal(0.0, args.landmark_noise,
                                                                  (len(scan_landmarks), 3))
        write_atomically(os.path.join(args.out, "scans", label + "_landmarks.txt"),
                         markers_text(scan_landmarks, positions,
                                      "landmarks of the scan of %s: %s (%s)"
                                      % (label, recipe, what)))
    write_atomically(os.path.join(args.out, "mixes.csv"), "".join(manifest))

    if args.frames > 0:
        others = [n for n in names if n != "jawOpen"]
        chosen = ["jawOpen"] + list(rng.choice(others, size=args.sequence_expressions - 1,
                                               replace=False))
        amplitude = rng.uniform(0.5, 1.3, len(chosen))
        frequency = rng.uniform(0.3, 0.8, len(chosen))
        phase = rng.uniform(0, 2 * np.pi, len(chosen))
        rows = ["frame," + ",".join(chosen) + "\n"]
        vertices = marker_sets[args.sequence_markers]
        for f in range(args.frames):
            t = f / 30.0
            w = np.clip(amplitude * np.sin(2 * np.pi * frequency * t + phase), 0.0, 1.0)
            surface = neutral.copy()
            for name, weight in zip(chosen, w):
                surface += weight * deltas[name]
            rows.append("%d," % f + ",".join("%.4f" % x for x in w) + "\n")
            recipe = " ".join("%s:%.3f" % (n, x) for n, x in zip(chosen, w))
            label = "frame_%04d" % f
            write_atomically(os.path.join(args.out, "sequence", "truth", label + ".obj"),
                             obj_text(surface, recipe))
            positions = surface[vertices] + rng.normal(0.0, args.marker_noise, (len(vertices), 3))
            write_atomically(os.path.join(args.out, "sequence", "markers", label + ".txt"),
                             markers_text(vertices, positions, "%s: %s" % (label, recipe)))
        write_atomically(os.path.join(args.out, "sequence", "weights.csv"), "".join(rows))
    print("wrote %d mixes (%s markers), scans and a %d-frame sequence to %s"
          % (args.mixes, ",".join(str(k) for k in marker_counts), args.frames, args.out))


if __name__ == "__main__":
    main()
