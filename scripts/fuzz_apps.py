#!/usr/bin/env python3
"""Fuzz the ActiveQS apps with mutated inputs and flags (issue 12, "nothing silent").

Builds a small set of seed inputs with the apps themselves (the finger example's mesh,
fixed vertices and actuation; its rest and two actuated surfaces; a model prepared,
pre-trained and trained from them; markers, point clouds and a latent file), then runs
cases: an app scenario (aqs_simulate on a mesh or a model, aqs_fit on a pose, markers or
a scan, aqs_collide, aqs_prepare, aqs_pretrain, aqs_train, aqs_evaluate, aqs_pipeline run
again over its own model) with one input
file mutated (bytes flipped, lines dropped or repeated, numbers replaced by nan, inf,
0x10, 1e308 or -1, truncated, emptied, a 2 MB line, a directory, a FIFO, a link to
/dev/zero, NaN written into a binary model file, ...) and/or one flag set to a bad value
(0, -1, nan, inf, 1e308, 2147483647, 1e-9, a word, ...); in about 8% of the cases the
flags are read from a flagfile with a line gflags mishandles (one that includes the file
itself, dashes only, ...) or mutated text. Every run has a timeout and a
memory limit (RLIMIT_AS) and is classified:

  exit 0      ok, and its outputs and its log are checked for nan/inf: if any, the case
              is "nonfinite 0" (a silent non-finite result: a failure)
  exit 1      a clean refusal, if the output has a line "<app>: error: <message>" (the
              apps' own refusals) or one of gflags' refusals of a flag ("ERROR: unknown
              command line flag 'f'", "ERROR: illegal value 'x' specified for double flag
              'f'", "ERROR: flag '--f' is missing its argument", ...); else "silent 1": a
              failure
  exit 2, 3   a solve did not converge / no gradient (allowed)
  crash       killed by a signal (an abort, a segfault): a failure
  hang        the timeout was reached: a failure
  memory      the memory limit was hit (bad_alloc, "Cannot allocate"): a failure
  other       any other exit status: a failure

It prints a table of outcomes per scenario and, for every failure, the command that
reproduces it (the mutated inputs are kept under <work>/failures/). The exit status is 1
if any case failed, 0 otherwise. Only the Python standard library is used.

  python3 scripts/fuzz_apps.py --build build [--cases 80] [--budget 60] [--seed 1]
"""

import argparse
import os
import random
import re
import resource
import shutil
import signal
import struct
import subprocess
import sys
import tempfile
import time

FAILURES = ("crash", "hang", "memory", "nonfinite 0", "silent 1", "other")

# Bad values for flags, by kind of flag.
REAL_VALUES = ["0", "-1", "nan", "inf", "-inf", "1e308", "-1e308", "1e-308", "1e-9",
               "2147483647", "0x10", "abc", "", "1e400", "-0"]
COUNT_VALUES = ["0", "-1", "-2147483648", "9999999999", "abc", "1.5", "", "nan"]
THREAD_VALUES = COUNT_VALUES + ["100000", "2147483647"]

# Numeric flags per app: (flag, kind). Iteration counts get COUNT_VALUES only (a
# large count is a legitimate request for long work, bounded by the user).
FLAGS = {
    "aqs_simulate": [("mu", "real"), ("tolerance", "real"), ("max_iterations", "count"),
                     ("threads", "threads"), ("newton_relative_force", "real"),
                     ("max_memory_gb", "real")],
    "aqs_fit": [("fit_regularization", "real"), ("fit_iterations", "count"),
                ("max_distance", "real"), ("robust_scale", "real"), ("rounds", "count"),
                ("fit_tolerance", "real"), ("threads", "threads"), ("target_kind", "word"),
                ("latent_prior", "real"), ("scan_latent_prior", "real")],
    "aqs_collide": [("thickness", "real"), ("contact_stiffness", "real"),
                    ("search_radius", "real"), ("exclusion_rings", "count"),
                    ("max_depth", "real"), ("contact_rounds", "count"),
                    ("path_steps", "count"), ("contact_tolerance", "real")],
    "aqs_prepare": [("spacing", "real"), ("shell", "real"), ("cut_margin", "real"),
                    ("mu", "real"), ("fixed_depth", "real"),
                    ("attachment_stiffness", "real"), ("prepare_tolerance", "real"),
                    ("threads", "threads"), ("max_memory_gb", "real"),
                    ("min_vertex_elements", "count")],
    "aqs_pretrain": [("latent_dim", "threads"), ("hidden", "hidden"), ("output_scale", "real"),
                     ("grid_spacing", "real"), ("grid_spacing_factor", "real"),
                     ("latent_regularization", "real"), ("pretrain_iterations", "count"),
                     ("train_tolerance", "real"), ("max_memory_gb", "real")],
    "aqs_train": [("latent_regularization", "real"), ("train_iterations", "count"),
                  ("train_minutes", "real"), ("train_tolerance", "real"),
                  ("checkpoint_every", "count"), ("train_restarts", "count"),
                  ("latent_dim", "threads"), ("hidden", "hidden"),
                  ("latent_refit_iterations", "count"), ("latent_refit_every", "count")],
    "aqs_pipeline": [("attachment_stiffness", "real"), ("spacing", "real"),
                     ("pretrain_iterations", "count"), ("train_iterations", "count"),
                     ("latent_regularization", "real"), ("prepare_tolerance", "real")],
    "aqs_evaluate": [("baseline_iterations", "count"), ("fit_iterations", "count"),
                     ("attachment_stiffness", "real"), ("prepare_tolerance", "real"),
                     ("latent_regularization", "real"), ("fit_regularization", "real"),
                     ("latent_prior", "real")],
}
HIDDEN_VALUES = ["0", "-1", "1000000", "100000,100000", "8,,8", "abc", "2147483647"]
WORD_VALUES = ["pose", "markers", "points", "scan", ""]

# gflags' refusals of a flag (it then exits with status 1): each names the flag.
GFLAGS_REFUSAL = re.compile(
    r"^ERROR: (unknown command line flag '[^']+'|illegal value '.*' specified for \w+ flag "
    r"'[^']+'|flag '--[^']+' is missing its argument|boolean value \(\w+\) specified for "
    r"\w+ command line flag|failed validation of new value '.*' for flag '[^']+')",
    re.MULTILINE)

# A reader's report of a damaged input names the value it refused, in quotes ("... got
# 'inf'", "grid coordinate 'nan' of node 33 is not an integer").
REPORTED_NONFINITE = re.compile(
    r"is not finite \((nan|inf|-inf)\)|(got|coordinate|value) '[-+]?(nan|inf|infinity)'",
    re.IGNORECASE)
NONFINITE = re.compile(r"(?<![A-Za-z_])[-+]?(nan|inf|infinity)(?![A-Za-z_])", re.IGNORECASE)


def log(message):
    print(message, flush=True)


def run(command, cwd, timeout, memory_bytes):
    """Runs command; returns (returncode or None on timeout, output, seconds)."""

    def limits():
        resource.setrlimit(resource.RLIMIT_AS, (memory_bytes, memory_bytes))
        resource.setrlimit(resource.RLIMIT_CORE, (0, 0))
        resource.setrlimit(resource.RLIMIT_FSIZE, (1 << 30, 1 << 30))

    start = time.time()
    process = subprocess.Popen(command, cwd=cwd, stdout=subprocess.PIPE,
                               stderr=subprocess.STDOUT, preexec_fn=limits,
                               start_new_session=True)
    try:
        output, _ = process.communicate(timeout=timeout)
        code = process.returncode
    except subprocess.TimeoutExpired:
        os.killpg(process.pid, signal.SIGKILL)
        output, _ = process.communicate()
        code = None
    return code, output.decode("utf-8", "replace"), time.time() - start


# ---------------------------------------------------------------------------------
# Seeds.

# The seed model's pipeline (setup_seeds), run again by the "pipeline" scenario.
PIPELINE_FLAGS = ["--neutral=neutral.obj", "--poses=poses", "--model=model", "--spacing=0.5",
                  "--lattice=kuhn", "--fixed_box=-2,-2,-1,2,2,0.3", "--latent_dim=2",
                  "--hidden=8", "--grid_spacing=1.5", "--pretrain_iterations=20",
                  "--stages=prepare,pretrain,train", "--threads=1"]


def setup_seeds(build, source, seeds, timeout, memory_bytes):
    """Makes the seed inputs in `seeds` with the apps; returns a dict of paths."""
    apps = os.path.join(build, "apps")
    finger = os.path.join(source, "data", "examples", "finger")
    meshes = os.path.join(source, "data", "test_meshes")
    os.makedirs(os.path.join(seeds, "poses"), exist_ok=True)
    for name in ["finger.msh", "fixed.txt", "actuation.txt"]:
        shutil.copy(os.path.join(finger, name), os.path.join(seeds, name))
    for name in ["torus.node", "torus.ele", "blob.msh"]:
        shutil.copy(os.path.join(meshes, name), os.path.join(seeds, name))
    simulate = [os.path.join(apps, "aqs_simulate"), "--mesh=finger.msh", "--fixed=fixed.txt",
                "--threads=1"]
    commands = [
        simulate + ["--output=neutral.obj,finger.mesh"],
        simulate + ["--actuation=actuation.txt", "--output=poses/bend_x.obj"],
        simulate + ["--actuation=" + os.path.join(finger, "actuation_y.txt"),
                    "--output=poses/bend_y.obj"],
        [os.path.join(apps, "aqs_pipeline")] + PIPELINE_FLAGS + ["--train_iterations=1"],
        [os.path.join(apps, "aqs_fit"), "--model=model", "--target=poses/bend_y.obj",
         "--output=fitted.obj", "--latent_output=latent.txt", "--threads=1"],
    ]
    for command in commands:
        code, output, _ = run(command, seeds, timeout * 3, memory_bytes)
        if code != 0:
            raise SystemExit("fuzz_apps: setting up the seeds failed: %s\n%s"
                             % (" ".join(command), output))
    # Markers, scans (ASCII and binary PLY, OBJ points) from the pose bend_x.
    vertices = [line.split()[1:4] for line in open(os.path.join(seeds, "poses", "bend_x.obj"))
                if line.startswith("v ")]
    with open(os.path.join(seeds, "markers.txt"), "w") as out:
        out.write("# vertex x y z\n")
        for v in range(0, len(vertices), 37):
            out.write("%d %s %s %s\n" % (v, *vertices[v]))
    scan = vertices[::3]
    with open(os.path.join(seeds, "scan.ply"), "w") as out:
        out.write("ply\nformat ascii 1.0\ncomment a scan\nelement vertex %d\n"
                  "property float x\nproperty float y\nproperty float z\n"
                  "property uchar red\nelement face 0\nproperty list uchar int vertex_indices\n"
                  "end_header\n" % len(scan))
        for v in scan:
            out.write("%s %s %s 200\n" % tuple(v))
    with open(os.path.join(seeds, "scan_binary.ply"), "wb") as out:
        out.write(b"ply\nformat binary_little_endian 1.0\nelement vertex %d\n"
                  b"property double x\nproperty double y\nproperty double z\nend_header\n"
                  % len(scan))
        for v in scan:
            out.write(struct.pack("<3d", *map(float, v)))
    with open(os.path.join(seeds, "scan.obj"), "w") as out:
        for v in scan:
            out.write("v %s %s %s\n" % tuple(v))
    return seeds


# ---------------------------------------------------------------------------------
# Mutations.

SPECIAL_NUMBERS = ["nan", "inf", "-inf", "0x10", "1e308", "-1", "0", "1e-308", "-0",
                   "2147483648", "99999999999999999999", "1e154", "-1e154", "abc", "1,5"]


def mutate_text(data, rng):
    """A mutated copy of text bytes and a description."""
    lines = data.split(b"\n")
    kind = rng.choice(["number", "number", "drop_line", "repeat_line", "truncate", "garbage",
                       "swap_lines", "empty", "long_line", "flip", "extra_token"])
    if kind == "number":
        numbers = [m for m in re.finditer(rb"-?\d+(\.\d+)?([eE][-+]?\d+)?", data)]
        if numbers:
            m = rng.choice(numbers)
            value = rng.choice(SPECIAL_NUMBERS).encode()
            return data[:m.start()] + value + data[m.end():], "number %r -> %r" % (
                m.group(0)[:20].decode(), value.decode())
        kind = "garbage"
    if kind == "drop_line" and len(lines) > 1:
        i = rng.randrange(len(lines))
        return b"\n".join(lines[:i] + lines[i + 1:]), "line %d dropped" % (i + 1)
    if kind == "repeat_line" and lines:
        i = rng.randrange(len(lines))
        return b"\n".join(lines[:i + 1] + lines[i:]), "line %d repeated" % (i + 1)
    if kind == "swap_lines" and len(lines) > 2:
        i, j = rng.randrange(len(lines)), rng.randrange(len(lines))
        lines[i], lines[j] = lines[j], lines[i]
        return b"\n".join(lines), "lines %d and %d swapped" % (i + 1, j + 1)
    if kind == "truncate" and data:
        n = rng.randrange(len(data))
        return data[:n], "truncated to %d of %d bytes" % (n, len(data))
    if kind == "empty":
        return b"", "emptied"
    if kind == "long_line":
        return data + b"1 " * (1 << 20) + b"\n", "a 2 MB line appended"
    if kind == "flip" and data:
        buffer = bytearray(data)
        for _ in range(rng.randint(1, 8)):
            buffer[rng.randrange(len(buffer))] = rng.randrange(256)
        return bytes(buffer), "bytes flipped"
    if kind == "extra_token" and lines:
        i = rng.randrange(len(lines))
        lines[i] += b" " + rng.choice(SPECIAL_NUMBERS).encode()
        return b"\n".join(lines), "a token appended to line %d" % (i + 1)
    return data + b"\n# garbage \x00\xff junk 1 2 3\nv 1 2\n", "garbage appended"


def mutate_binary(data, rng):
    """A mutated copy of an ActiveQS matrix file (24-byte header, doubles)."""
    kind = rng.choice(["nan", "inf", "huge", "truncate", "header", "flip", "append"])
    buffer = bytearray(data)
    count = (len(data) - 24) // 8
    if kind in ("nan", "inf", "huge") and count > 0:
        i = rng.randrange(count)
        value = {"nan": float("nan"), "inf": float("inf"), "huge": 1e300}[kind]
        buffer[24 + 8 * i:32 + 8 * i] = struct.pack("<d", value)
        return bytes(buffer), "entry %d -> %s" % (i, kind)
    if kind == "truncate":
        n = rng.randrange(len(data)) if data else 0
        return data[:n], "truncated to %d bytes" % n
    if kind == "header" and len(data) >= 24:
        buffer[8:24] = struct.pack("<2q", rng.choice([-1, 0, 1 << 40, 3]), rng.choice([-5, 7, 1 << 50]))
        return bytes(buffer), "header sizes changed"
    if kind == "append":
        return data + b"\x00" * 8, "8 bytes appended"
    if buffer:
        buffer[rng.randrange(len(buffer))] ^= 0xFF
    return bytes(buffer), "a byte flipped"


def mutate_file(path, rng):
    """Mutates the file at path in place; returns a description."""
    kind = rng.random()
    if kind < 0.04:
        os.remove(path)
        os.mkdir(path)
        return "replaced by a directory"
    if kind < 0.07:
        os.remove(path)
        os.mkfifo(path)
        return "replaced by a FIFO"
    if kind < 0.10:
        os.remove(path)
        os.symlink("/dev/zero", path)
        return "replaced by a link to /dev/zero"
    if kind < 0.12:
        os.remove(path)
        return "removed"
    with open(path, "rb") as f:
        data = f.read()
    if path.endswith(".bin") or (path.endswith(".ply") and b"binary" in data[:100]):
        mutated, what = mutate_binary(data, rng) if path.endswith(".bin") else mutate_text(data, rng)
    else:
        mutated, what = mutate_text(data, rng)
    with open(path, "wb") as f:
        f.write(mutated)
    return what


# Flags gflags itself must refuse (exit 1 naming the flag, never an abort): an unknown
# name, a missing value, a boolean form of a numeric flag.
def gflags_mutation(flag, rng):
    return rng.choice(["--%s_typo=1" % flag, "--%s" % flag, "--no%s" % flag])


# Flagfiles: the case's flags written to run.flags, which the app then reads, with one of
# the line forms gflags itself mishandles (a file that includes itself, directly or
# through another, overflowed its stack; a line of dashes threw), or text mutations.
def flagfile_flags(flags, case_dir, rng):
    """Writes flags to case_dir/run.flags, mutated; returns (the app's flags, description)."""
    lines = list(flags)
    kind = rng.choice(["self", "cycle", "dashes", "not_a_flag", "space", "text"])
    if kind == "self":
        lines.insert(rng.randrange(len(lines) + 1), "--flagfile=run.flags")
    elif kind == "cycle":
        with open(os.path.join(case_dir, "other.flags"), "w") as f:
            f.write("--flagfile=run.flags\n")
        lines.insert(rng.randrange(len(lines) + 1), "--flagfile=other.flags")
    elif kind == "dashes":
        lines.insert(rng.randrange(len(lines) + 1), rng.choice(["--", "---", "-"]))
    elif kind == "not_a_flag":
        lines.insert(rng.randrange(len(lines) + 1), rng.choice(["threads=1", "x", "# ok", ""]))
    elif kind == "space" and lines:
        i = rng.randrange(len(lines))
        lines[i] = lines[i].replace("=", " ", 1)
    text = ("\n".join(lines) + "\n").encode()
    if kind == "text":
        text, _ = mutate_text(text, rng)
    with open(os.path.join(case_dir, "run.flags"), "wb") as f:
        f.write(text)
    return ["--flagfile=run.flags"], "flagfile: " + kind


def flag_value(kind, rng):
    if kind == "count":
        return rng.choice(COUNT_VALUES)
    if kind == "threads":
        return rng.choice(THREAD_VALUES)
    if kind == "hidden":
        return rng.choice(HIDDEN_VALUES)
    if kind == "word":
        return rng.choice(WORD_VALUES)
    return rng.choice(REAL_VALUES)


# ---------------------------------------------------------------------------------
# Scenarios: (app, flags, input files that may be mutated, output files).

def scenario(name, rng):
    """The command of a scenario (relative to the case folder)."""
    model_files = ["model/fixed.txt", "model/poses.txt", "model/bones.txt", "model/embedding.txt",
                   "model/mesh.mesh", "model/neutral.obj", "model/mu.bin", "model/model.txt",
                   "model/learned/decoder.txt", "model/learned/latents.bin",
                   "model/learned/checkpoint.txt", "model/poses/0000.bin", "model/targets/0001.bin",
                   "model/learned/states/0000.bin"]
    if name == "simulate_mesh":
        mesh = rng.choice(["finger.msh", "finger.mesh", "torus.node", "blob.msh"])
        flags = ["--mesh=" + mesh, "--output=out.mesh,out.vtu,out.obj", "--max_iterations=50"]
        inputs = [mesh if mesh != "torus.node" else rng.choice(["torus.node", "torus.ele"])]
        if mesh.startswith("finger"):
            flags += ["--fixed=fixed.txt", "--actuation=actuation.txt"]
            inputs += ["fixed.txt", "actuation.txt"]
        else:
            flags += ["--solver=lm", "--max_iterations=20"]
        return "aqs_simulate", flags, inputs, ["out.mesh", "out.vtu", "out.obj"]
    if name == "simulate_model":
        source = rng.choice(["--latent=latent.txt", "--pose=bend_x"])
        return ("aqs_simulate", ["--model=model", source, "--output=out.obj,out.vtu"],
                model_files + (["latent.txt"] if "latent" in source else []),
                ["out.obj", "out.vtu"])
    if name == "fit":
        target = rng.choice(["poses/bend_x.obj", "markers.txt", "scan.ply", "scan_binary.ply",
                             "scan.obj"])
        flags = ["--model=model", "--target=" + target, "--output=out.obj",
                 "--latent_output=out_latent.txt", "--fit_iterations=8", "--rounds=2"]
        return "aqs_fit", flags, [target] * 3 + model_files, ["out.obj", "out_latent.txt"]
    if name == "collide":
        return ("aqs_collide", ["--model=model", "--pose=bend_x", "--output=out.obj",
                                "--path_steps=1", "--contact_rounds=1", "--report=out_report.txt"],
                model_files, ["out.obj", "out_report.txt"])
    if name == "prepare":
        return ("aqs_prepare", ["--neutral=neutral.obj", "--poses=poses", "--model=prepared",
                                "--spacing=0.6", "--lattice=kuhn", "--fixed_box=-2,-2,-1,2,2,0.3"],
                ["neutral.obj", "poses/bend_x.obj", "poses/bend_y.obj"],
                ["prepared/learned/latents.bin", "prepared/targets/0000.bin"])
    if name == "pretrain":
        return ("aqs_pretrain", ["--model=model", "--latent_dim=2", "--hidden=8",
                                 "--grid_spacing=1.5", "--pretrain_iterations=5"],
                model_files, ["model/learned/latents.bin", "model/learned/decoder.txt"])
    if name == "train":
        return ("aqs_train", ["--model=model", "--train_iterations=2"], model_files,
                ["model/learned/latents.bin", "model/learned/decoder.txt", "model/train/log.csv"])
    if name == "pipeline":
        # The seed model's own command again (a rerun: prepare and pre-training keep the
        # model unless an input, a model file or a flag differs), one more iteration.
        return ("aqs_pipeline", PIPELINE_FLAGS + ["--train_iterations=2"],
                model_files + ["model/pretrain/key.txt", "neutral.obj", "poses/bend_x.obj"],
                ["model/learned/latents.bin", "model/learned/decoder.txt", "model/train/log.csv"])
    if name == "evaluate":
        return ("aqs_evaluate", ["--model=model", "--test_poses=poses/bend_y.obj",
                                 "--output_dir=out_eval", "--baseline_iterations=5",
                                 "--fit_iterations=2", "--error_budget=false",
                                 "--report=false"],
                model_files + ["poses/bend_y.obj"],
                ["out_eval/evaluation.csv", "out_eval/evaluation.md"])
    raise ValueError(name)


SCENARIOS = ["simulate_mesh", "simulate_mesh", "simulate_model", "fit", "fit", "collide",
             "prepare", "pretrain", "train", "evaluate", "pipeline"]


# ---------------------------------------------------------------------------------
# Checks of outputs.

def nonfinite_in_file(path):
    """A description of a non-finite number in the file, or None."""
    if not os.path.isfile(path):
        return None
    with open(path, "rb") as f:
        data = f.read()
    if data.startswith(b"AQSMAT1\n") and len(data) >= 24:
        count = (len(data) - 24) // 8
        for i, (value,) in enumerate(struct.iter_unpack("<d", data[24:24 + 8 * count])):
            if value != value or value in (float("inf"), float("-inf")):
                return "%s: entry %d is %r" % (path, i, value)
        return None
    text = data.decode("utf-8", "replace")
    for number, line in enumerate(text.split("\n"), 1):
        if line.lstrip().startswith("#"):
            continue
        m = NONFINITE.search(line)
        if m:
            return "%s:%d: %s" % (path, number, line.strip()[:120])
    return None


def classify(app, code, output, case_dir, outputs):
    """(outcome, detail) of a run of `app`."""
    if code is None:
        return "hang", "timeout"
    if code < 0:
        detail = "signal %d" % -code
        if "bad_alloc" in output or "Cannot allocate memory" in output:
            return "memory", detail + " (allocation failed)"
        return "crash", detail
    if "bad_alloc" in output or "Cannot allocate memory" in output:
        return "memory", "allocation failed"
    if code == 0:
        # The names of the case's files, longest first, are taken out of the log before it
        # is searched: an output a mutated flagfile named "out.obj inf" was logged as
        # "wrote out.obj inf", which is no non-finite number.
        try:
            names = sorted(os.listdir(case_dir), key=len, reverse=True)
        except OSError:
            names = []
        for line in output.split("\n"):
            for name in names:
                if NONFINITE.search(name):
                    line = line.replace(name, "")
            m = NONFINITE.search(line)
            # (A reader's report of a damaged input it then did without, such as
            # aqs_pipeline's "the model at M ... cannot be read (F: entry ... is not finite
            # (nan) ...)" or "(F:187: expected ... (a finite number), got 'inf')", is not a
            # non-finite result.)
            if m and "--" not in line and not REPORTED_NONFINITE.search(line):
                return "nonfinite 0", "log: " + line.strip()[:160]
        for name in outputs:
            found = nonfinite_in_file(os.path.join(case_dir, name))
            if found:
                return "nonfinite 0", found
        return "exit 0", ""
    if code == 1:
        # The apps print "<app>: error: ..." (apps/app_common.h, PrintError); gflags names
        # the flag it refuses. Anything else (a bare exit 1, a glog line) is silent.
        own = re.search(r"^%s: error: \S" % re.escape(app), output, re.MULTILINE)
        if own is None and GFLAGS_REFUSAL.search(output) is None:
            return "silent 1", output.strip()[-200:]
        return "exit 1", ""
    if code in (2, 3):
        return "exit %d" % code, ""
    return "other", "exit status %d" % code


# ---------------------------------------------------------------------------------

def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--build", required=True, help="the build folder (with apps/)")
    parser.add_argument("--source", default=os.path.dirname(os.path.dirname(os.path.abspath(__file__))),
                        help="the source folder (with data/; default: this script's repository)")
    parser.add_argument("--work", default="", help="working folder (default: a temporary one, "
                        "removed at the end unless a case failed)")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--cases", type=int, default=80, help="cases at most")
    parser.add_argument("--budget", type=float, default=60.0, help="seconds at most for the cases")
    parser.add_argument("--timeout", type=float, default=20.0, help="seconds per run")
    parser.add_argument("--memory_mb", type=int, default=2048,
                        help="address-space limit of every run (RLIMIT_AS); the apps get "
                        "--max_memory_gb of a quarter of it")
    args = parser.parse_args()

    memory_bytes = args.memory_mb << 20
    work = args.work or tempfile.mkdtemp(prefix="aqs_fuzz_")
    os.makedirs(work, exist_ok=True)
    seeds = os.path.join(work, "seeds")
    if os.path.exists(seeds):
        shutil.rmtree(seeds)
    os.makedirs(seeds)
    started = time.time()
    setup_seeds(os.path.abspath(args.build), os.path.abspath(args.source), seeds, args.timeout,
                memory_bytes)
    log("fuzz_apps: seeds made in %.1f s in %s; seed %d, up to %d cases or %.0f s"
        % (time.time() - started, work, args.seed, args.cases, args.budget))

    rng = random.Random(args.seed)
    apps = os.path.join(os.path.abspath(args.build), "apps")
    memory_flag = "--max_memory_gb=%g" % (args.memory_mb / 4096.0)
    table = {}
    failures = []
    start = time.time()
    case = 0
    while case < args.cases and time.time() - start < args.budget:
        case += 1
        name = rng.choice(SCENARIOS)
        app, flags, inputs, outputs = scenario(name, rng)
        case_dir = os.path.join(work, "case")
        if os.path.exists(case_dir):
            shutil.rmtree(case_dir)
        shutil.copytree(seeds, case_dir, symlinks=True)
        mutations = []
        what = rng.random()
        if what < 0.45 or what >= 0.9:
            target = rng.choice(inputs)
            if os.path.exists(os.path.join(case_dir, target)):
                mutations.append("%s: %s" % (target, mutate_file(os.path.join(case_dir, target), rng)))
        if what >= 0.45:
            flag, kind = rng.choice(FLAGS[app])
            if rng.random() < 0.1:
                mutated = gflags_mutation(flag, rng)
            else:
                mutated = "--%s=%s" % (flag, flag_value(kind, rng))
            flags = [f for f in flags if not f.startswith("--%s=" % flag)] + [mutated]
            mutations.append(mutated)
        if not any(f.startswith("--max_memory_gb=") for f in flags):
            flags.append(memory_flag)
        if not any(f.startswith("--threads=") for f in flags):
            flags.append("--threads=1")
        if rng.random() < 0.08:
            flags, mutation = flagfile_flags(flags, case_dir, rng)
            mutations.append(mutation)
        command = [os.path.join(apps, app)] + flags
        code, output, seconds = run(command, case_dir, args.timeout, memory_bytes)
        outcome, detail = classify(app, code, output, case_dir, outputs)
        row = table.setdefault(name, {})
        row[outcome] = row.get(outcome, 0) + 1
        if outcome in FAILURES:
            kept = os.path.join(work, "failures", "case_%d" % case)
            shutil.copytree(case_dir, kept, symlinks=True, ignore_dangling_symlinks=True)
            failures.append((case, name, outcome, detail, mutations, kept, command, output))
            log("case %d %s: %s (%s) after %s" % (case, name, outcome.upper(), detail,
                                                  "; ".join(mutations) or "no mutation"))
        shutil.rmtree(case_dir, ignore_errors=True)

    outcomes = ["exit 0", "exit 1", "exit 2", "exit 3"] + list(FAILURES)
    width = max(len(name) for name in SCENARIOS) + 2
    log("\nfuzz_apps: %d cases in %.1f s (seed %d)" % (case, time.time() - start, args.seed))
    log("%-*s" % (width, "scenario") + "".join("%12s" % o for o in outcomes))
    totals = {}
    for name in sorted(table):
        log("%-*s" % (width, name) + "".join("%12d" % table[name].get(o, 0) for o in outcomes))
        for o, n in table[name].items():
            totals[o] = totals.get(o, 0) + n
    log("%-*s" % (width, "all") + "".join("%12d" % totals.get(o, 0) for o in outcomes))
    if failures:
        log("\n%d failure(s):" % len(failures))
        for case_number, name, outcome, detail, mutations, kept, command, output in failures:
            log("\ncase %d (%s): %s: %s" % (case_number, name, outcome, detail))
            log("  mutations: %s" % ("; ".join(mutations) or "none"))
            log("  inputs kept in %s; to reproduce:" % kept)
            log("  cd %s && %s" % (kept, " ".join("'%s'" % c if " " in c or not c else c
                                                for c in command)))
            log("  output (end): " + output.strip()[-400:].replace("\n", "\n    "))
        return 1
    if not args.work:
        shutil.rmtree(work, ignore_errors=True)
    log("no crash, hang, unbounded allocation or silent non-finite output")
    return 0


if __name__ == "__main__":
    sys.exit(main())
