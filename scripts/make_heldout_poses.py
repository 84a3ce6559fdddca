#!/usr/bin/python3
"""Writes a held-out pose list for aqs_evaluate (--test_poses): every ICT expression that a
model's training list does not name, with absolute paths. The ICT face data (--ict) are
made from ICT-FaceKit by scripts/ict_facekit_to_aqs.py (docs/tutorial_face.md).

Usage: python3 scripts/make_heldout_poses.py --ict ../shared/data/ict-face
       --train data/ict-face-demo/train.txt --out out/heldout_poses.txt

The demo trains on 12 of the 55 expressions and holds out 4 (data/ict-face-demo/test.txt);
this list holds the 43 it does not train on (those 4 among them), so that a comparison
with the baselines does not rest on 4 poses (docs/results.md). The demo's settings were
chosen on these 43 (docs/goals.md): they are a validation set, not an untouched test set. Training entries are matched by file name
(poses/jawOpen.obj and jawOpen.obj are the same expression); the teeth poses
(*.teeth.obj) are not expressions. A development-time tool; the tests do not run it."""
import argparse
import os
import sys


def expression_names(list_path):
    """The expression names (file stems) of a pose list: one path per line, '#' comments."""
    names = set()
    with open(list_path) as f:
        for line in f:
            line = line.split('#', 1)[0].strip()
            if line:
                names.add(os.path.splitext(os.path.basename(line))[0])
    return names


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--ict', required=True, help='the ICT face data (poses/*.obj)')
    parser.add_argument('--train', required=True, help="the model's training pose list")
    parser.add_argument('--out', required=True, help='the pose list to write')
    args = parser.parse_args()

    pose_dir = os.path.abspath(os.path.join(args.ict, 'poses'))
    if not os.path.isdir(pose_dir):
        sys.exit(f'{pose_dir}: not a folder (--ict must hold poses/*.obj)')
    try:
        training = expression_names(args.train)
    except OSError as e:
        sys.exit(f'{args.train}: {e.strerror}')
    held_out = sorted(
        name[:-len('.obj')] for name in os.listdir(pose_dir)
        if name.endswith('.obj') and not name.endswith('.teeth.obj')
        and name[:-len('.obj')] not in training)
    if not held_out:
        sys.exit(f'{pose_dir}: no expression is left out of {args.train}')
    os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
    temporary = args.out + '.tmp'
    with open(temporary, 'w') as f:
        f.write(f'# the ICT expressions that {args.train} does not name '
                f'(scripts/make_heldout_poses.py)\n')
        for name in held_out:
            f.write(os.path.join(pose_dir, name + '.obj') + '\n')
    os.replace(temporary, args.out)
    print(f'wrote {args.out}: {len(held_out)} held-out expressions')


if __name__ == '__main__':
    main()
