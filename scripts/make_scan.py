#!/usr/bin/env python3
"""Makes a synthetic "scan" of a pose surface for the point-cloud fit demo: a partial,
noisy sample of its surface, without correspondence (random order),
as an ASCII PLY (x y z per point).

Usage: make_scan.py POSE.obj NEUTRAL.obj OUT.ply [--points N] [--noise SIGMA]
       [--min_z Z] [--seed S] [--landmarks OUT.txt] [--landmark_vertices V1,V2,...]
       [--landmark_noise SIGMA]
The pose file holds only `v` records (faces come from the neutral). Points are uniform
(by area) on the triangles whose three corners have z >= min_z (the front of the face,
as a single depth camera would see it), plus Gaussian noise of SIGMA per coordinate.
With --landmarks, also the scan's landmarks (aqs_fit --landmarks): the pose at the
landmark vertices plus Gaussian noise of landmark_noise per coordinate, from a generator
of their own (the scan's points do not change). The default vertices are those of the
demo's vendored scans/mouthFunnel_landmarks.txt: eye corners, mouth corners, lip middles,
nose tip, chin of the ICT face; they are the 10 that scripts/make_fit_tests.py's
face_landmarks finds except the mouth corners (6155 and 5650 here, about 0.28 cm inside
the lip seam's extreme vertices 6434 and 5929 that face_landmarks returns).
A development-time tool; the project does not run it."""
import argparse
import random
import sys

from make_fit_tests import write_atomically  # beside this script


def read_vertices(path):
    with open(path) as src:
        return [[float(x) for x in line.split()[1:4]] for line in src if line.startswith("v ")]


def read_triangles(path):
    triangles = []
    with open(path) as src:
        for line in src:
            if line.startswith("f "):
                corners = [int(token.split("/")[0]) - 1 for token in line.split()[1:]]
                for k in range(1, len(corners) - 1):
                    triangles.append((corners[0], corners[k], corners[k + 1]))
    return triangles


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("pose")
    parser.add_argument("neutral")
    parser.add_argument("output")
    parser.add_argument("--points", type=int, default=4000)
    parser.add_argument("--noise", type=float, default=0.02)
    parser.add_argument("--min_z", type=float, default=8.0)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--landmarks", default="")
    parser.add_argument("--landmark_vertices", default="6588,6548,6630,6590,6155,5650,5525,5945,4841,968")
    parser.add_argument("--landmark_noise", type=float, default=0.1)
    args = parser.parse_args()
    rng = random.Random(args.seed)
    vertices = read_vertices(args.pose)
    triangles = [t for t in read_triangles(args.neutral)
                 if all(vertices[i][2] >= args.min_z for i in t)]
    def area(t):
        a, b, c = (vertices[i] for i in t)
        e, f = [b[k] - a[k] for k in range(3)], [c[k] - a[k] for k in range(3)]
        n = [e[1] * f[2] - e[2] * f[1], e[2] * f[0] - e[0] * f[2], e[0] * f[1] - e[1] * f[0]]
        return 0.5 * sum(x * x for x in n) ** 0.5

    if not triangles:
        sys.exit("make_scan.py: no triangle of %s has every vertex at z >= %g (--min_z)"
                 % (args.neutral, args.min_z))
    try:
        landmark_vertices = [int(x) for x in args.landmark_vertices.split(",")] \
            if args.landmarks else []
    except ValueError:
        sys.exit("make_scan.py: --landmark_vertices takes vertex indices, got '%s'"
                 % args.landmark_vertices)
    for v in landmark_vertices:
        if not 0 <= v < len(vertices):
            sys.exit("make_scan.py: --landmark_vertices: vertex %d is not one of %s's %d"
                     % (v, args.pose, len(vertices)))
    chosen = rng.choices(triangles, weights=[area(t) for t in triangles], k=args.points)
    points = []
    for t in chosen:
        a, b, c = (vertices[i] for i in t)
        u, v = rng.random(), rng.random()
        if u + v > 1:
            u, v = 1 - u, 1 - v
        points.append([a[k] + u * (b[k] - a[k]) + v * (c[k] - a[k]) + rng.gauss(0, args.noise)
                       for k in range(3)])
    # Each file whole or not at all (make_fit_tests.write_atomically).
    text = ["ply\nformat ascii 1.0\n",
            "comment synthetic scan of %s: %d points on triangles with z >= %g, noise %g\n"
            % (args.pose, len(points), args.min_z, args.noise),
            "element vertex %d\nproperty float x\nproperty float y\nproperty float z\n"
            "end_header\n" % len(points)]
    text += ["%.5f %.5f %.5f\n" % tuple(p) for p in points]
    write_atomically(args.output, "".join(text))
    if args.landmarks:
        landmark_rng = random.Random(args.seed + 1000)
        text = ["# landmarks of %s: vertices of %s plus noise %g\n# vertex x y z\n"
                % (args.output, args.pose, args.landmark_noise)]
        for v in landmark_vertices:
            p = [vertices[v][k] + landmark_rng.gauss(0, args.landmark_noise) for k in range(3)]
            text.append("%d %.5f %.5f %.5f\n" % (v, p[0], p[1], p[2]))
        write_atomically(args.landmarks, "".join(text))


if __name__ == "__main__":
    main()
