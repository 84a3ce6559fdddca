#!/usr/bin/env python3
"""Writes a synthetic five-armed creature (a starfish) and eight poses of it.

    scripts/make_creature.py OUT_DIR [--resolution N]

OUT_DIR/neutral.obj is a closed surface: a disc-like body with five arms, thick in the
middle and thinning towards the rim. OUT_DIR/poses/<name>.obj are the same vertices with
arms swung about horizontal joint axes at the arms' bases (linear blend skinning over a
short blend zone), up to 60 degrees; OUT_DIR/poses.txt lists them. The centre of the
body (OUT_DIR/fixed_box.txt, the box for aqs_prepare --fixed_box) is held.

The creature is the test case of configs/creature.flags (aqs_prepare on a non-face body
whose poses are large limb rotations) and of aqs_bench_solve's limb case. Units are
arbitrary (the body is about 7 across).
"""
import argparse
import math
import os

import numpy as np

ARMS = 5
BODY_RADIUS = 1.2      # radius of the central disc
ARM_LENGTH = 2.3       # how far arms reach beyond the disc
ARM_WIDTH = 0.55       # angular half-width factor of an arm
THICKNESS = 0.55       # half-thickness at the centre
JOINT_RADIUS = 1.25    # arms swing about an axis at this distance from the centre
BLEND = 0.35           # blend zone of the skinning weights beyond the joint

# (name, {arm: angle in degrees}); positive swings an arm up (+z).
POSES = [
    ("arm0_up60", {0: 60}),
    ("arm1_down45", {1: -45}),
    ("arms02_up30", {0: 30, 2: 30}),
    ("all_up30", {a: 30 for a in range(ARMS)}),
    ("arm3_up60_arm4_down30", {3: 60, 4: -30}),
    ("arm2_down60", {2: -60}),
    ("arms14_up45", {1: 45, 4: 45}),
    ("wave", {0: 40, 1: -20, 2: 40, 3: -20, 4: 40}),
]


def outline(alpha):
    """Radius of the outline at polar angle alpha: the disc plus five arms."""
    arm = np.maximum(np.cos(ARMS * alpha / 2.0) ** 2, 0.0) ** (1.0 / ARM_WIDTH)
    return BODY_RADIUS + ARM_LENGTH * arm ** 4 + 0.0 * alpha


def make_surface(n_angle, n_radial):
    """Top and bottom sheets over a polar grid (angle, s in (0, 1]) joined at the rim.

    Returns (vertices 3 x V, triangles 3 x T), counter-clockwise seen from outside."""
    alphas = 2.0 * math.pi * np.arange(n_angle) / n_angle
    # Radial samples denser towards the rim, where the sheets turn.
    s = np.sin(0.5 * math.pi * np.arange(1, n_radial + 1) / n_radial)
    rho = outline(alphas)
    verts = [np.array([0.0, 0.0, THICKNESS]), np.array([0.0, 0.0, -THICKNESS])]
    index = {}
    for sheet, sign in ((0, 1.0), (1, -1.0)):
        for j in range(n_radial):
            for i in range(n_angle):
                if j == n_radial - 1 and sheet == 1:
                    index[(1, j, i)] = index[(0, j, i)]  # the rim is shared
                    continue
                r = s[j] * rho[i]
                # Thickness: the centre's, shrinking with the outline's local radius.
                h = THICKNESS * math.sqrt(max(0.0, 1.0 - s[j] ** 2)) * (0.55 + 0.45 * BODY_RADIUS / rho[i])
                index[(sheet, j, i)] = len(verts)
                verts.append(np.array([r * math.cos(alphas[i]), r * math.sin(alphas[i]), sign * h]))
    tris = []
    for sheet in (0, 1):
        pole = sheet
        for i in range(n_angle):
            a, b = index[(sheet, 0, i)], index[(sheet, 0, (i + 1) % n_angle)]
            tris.append((pole, a, b) if sheet == 0 else (pole, b, a))
        for j in range(n_radial - 1):
            for i in range(n_angle):
                i1 = (i + 1) % n_angle
                a, b = index[(sheet, j, i)], index[(sheet, j, i1)]
                c, d = index[(sheet, j + 1, i)], index[(sheet, j + 1, i1)]
                if sheet == 0:
                    tris += [(a, c, d), (a, d, b)]
                else:
                    tris += [(a, d, c), (a, b, d)]
    return np.array(verts).T, np.array(tris).T


def pose_vertices(v, angles):
    """Swings each arm in `angles` (degrees) about its joint axis, with blended weights."""
    out = v.copy()
    for arm, degrees in angles.items():
        phi = 2.0 * math.pi * arm / ARMS
        direction = np.array([math.cos(phi), math.sin(phi), 0.0])
        axis = np.array([-math.sin(phi), math.cos(phi), 0.0])  # horizontal, across the arm
        joint = JOINT_RADIUS * direction
        theta = -math.radians(degrees)  # positive degrees lift the arm (+z)
        k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
        rot = np.eye(3) + math.sin(theta) * k + (1 - math.cos(theta)) * k @ k
        along = direction @ (v - joint[:, None])
        # Angular distance from the arm's direction: only this arm's vertices move.
        ang = np.abs((np.arctan2(v[1], v[0]) - phi + math.pi) % (2 * math.pi) - math.pi)
        mine = ang < math.pi / ARMS
        t = np.clip(along / BLEND, 0.0, 1.0)
        w = t * t * (3 - 2 * t) * mine
        rotated = rot @ (v - joint[:, None]) + joint[:, None]
        out += w * (rotated - v)
    return out


def write_obj(path, v, t):
    tmp = path + ".tmp"
    with open(tmp, "w") as f:
        f.write("# synthetic creature (scripts/make_creature.py)\n")
        for p in v.T:
            f.write("v %.9g %.9g %.9g\n" % tuple(p))
        for tri in t.T:
            f.write("f %d %d %d\n" % tuple(tri + 1))
    os.replace(tmp, path)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("out_dir")
    parser.add_argument("--resolution", type=int, default=2,
                        help="mesh density factor (1: coarse, 2: default, 3: fine)")
    args = parser.parse_args()
    if args.resolution < 1 or args.resolution > 8:
        parser.error("--resolution must be in 1..8")
    os.makedirs(os.path.join(args.out_dir, "poses"), exist_ok=True)
    v, t = make_surface(100 * args.resolution, 30 * args.resolution)
    write_obj(os.path.join(args.out_dir, "neutral.obj"), v, t)
    names = []
    for name, angles in POSES:
        write_obj(os.path.join(args.out_dir, "poses", name + ".obj"), pose_vertices(v, angles), t)
        names.append("poses/" + name + ".obj")
    with open(os.path.join(args.out_dir, "poses.txt"), "w") as f:
        f.write("\n".join(names) + "\n")
    with open(os.path.join(args.out_dir, "fixed_box.txt"), "w") as f:
        f.write("-0.6,-0.6,-1,0.6,0.6,1\n")
    print("wrote %s: %d vertices, %d triangles, %d poses" % (args.out_dir, v.shape[1], t.shape[1], len(POSES)))


if __name__ == "__main__":
    main()
