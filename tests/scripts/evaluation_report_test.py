#!/usr/bin/env python3
"""Runs scripts/evaluation_report.py on a tiny synthetic evaluation (a 4 x 3 grid of quads
standing for the face) and checks that it writes the pictures and the HTML page, and that
bad input gets a message naming the file.

    evaluation_report_test.py SCRIPT

Exit status: 0 passed; 1 failed; 77 skipped (this Python lacks matplotlib or numpy: then
only the script's own message for that case is checked, and CTest reports the test as
skipped, not passed).
"""

import html
import math
import os
import shutil
import struct
import subprocess
import sys
import tempfile

SKIP = 77


def grid(offset):
    """Vertices of a 5 x 4 grid in the plane z = 0 (displaced by offset(x, y)), faces up."""
    vertices = []
    for j in range(4):
        for i in range(5):
            x, y = float(i), float(j)
            dx, dy, dz = offset(x, y)
            vertices.append((x + dx, y + dy, dz))
    quads = []
    for j in range(3):
        for i in range(4):
            a = j * 5 + i
            quads.append((a, a + 1, a + 6, a + 5))  # counter-clockwise seen from +z
    return vertices, quads


def write_obj(path, vertices, quads):
    with open(path, "w") as f:
        for v in vertices:
            f.write("v %.17g %.17g %.17g\n" % v)
        for q in quads:
            f.write("f " + " ".join(str(k + 1) for k in q) + "\n")


def write_ply(path, vertices, quads, values):
    with open(path, "w") as f:
        f.write("ply\nformat ascii 1.0\ncomment color_max 1\nelement vertex %d\n" % len(vertices))
        for p in ("x", "y", "z"):
            f.write("property double %s\n" % p)
        for p in ("red", "green", "blue"):
            f.write("property uchar %s\n" % p)
        f.write("property double value\nelement face %d\n" % len(quads))
        f.write("property list uchar int vertex_indices\nend_header\n")
        for v, e in zip(vertices, values):
            f.write("%.17g %.17g %.17g 0 0 0 %.17g\n" % (v + (e,)))
        for q in quads:
            f.write("4 " + " ".join(str(k) for k in q) + "\n")


def write_matrix(path, columns):
    """A util/matrix_io.h file whose columns are the given lists (column-major)."""
    rows = len(columns[0])
    with open(path, "wb") as f:
        f.write(b"AQSMAT1\n" + struct.pack("<qq", rows, len(columns)))
        for column in columns:
            f.write(struct.pack("<%dd" % rows, *column))


def make_evaluation(root, test_poses=("smile",)):
    evaluation = os.path.join(root, "evaluation")
    model = os.path.join(root, "model")
    for d in ("fitted", "fields"):
        os.makedirs(os.path.join(evaluation, d))
    os.makedirs(os.path.join(model, "train"))
    neutral, quads = grid(lambda x, y: (0.0, 0.0, 0.0))
    write_obj(os.path.join(model, "neutral.obj"), neutral, quads)
    target, _ = grid(lambda x, y: (0.0, 0.0, 0.3 * x))
    for test in test_poses:
        write_obj(os.path.join(evaluation, "fitted", test + "_target.obj"), target, quads)
        for k, method in enumerate(("physics", "autoencoder", "pca", "floor")):
            surface, _ = grid(lambda x, y: (0.0, 0.0, 0.3 * x + 0.02 * (k + 1) * y))
            errors = [abs(s[2] - t[2]) for s, t in zip(surface, target)]
            write_obj(os.path.join(evaluation, "fitted", "%s_%s.obj" % (test, method)), surface,
                      quads)
            write_ply(os.path.join(evaluation, "fields", "%s_%s.ply" % (test, method)), surface,
                      quads, errors)
    # The training poses' budget: per pose floor, after pre-training (NaN for train_0: not
    # recorded), trained; and the pose surfaces in the model (3 x vertices each).
    os.makedirs(os.path.join(evaluation, "budget"))
    os.makedirs(os.path.join(model, "poses"))
    columns = []
    for p in range(2):
        pose, _ = grid(lambda x, y: (0.0, 0.0, 0.1 * (p + 1) * y))
        write_matrix(os.path.join(model, "poses", "%04d.bin" % p), pose)
        columns += [[0.001 * x for x, _, _ in pose],
                    [math.nan if p == 0 else 0.03 * y for _, y, _ in pose],
                    [0.01 * (x + y) for x, y, _ in pose]]
    write_matrix(os.path.join(evaluation, "budget", "training_errors.bin"), columns)
    rows = ["split,pose,method,mean,rms,max"]
    for pose in ("train_0", "train_1"):
        for k, method in enumerate(("neutral", "physics", "autoencoder", "pca", "floor",
                                    "pretrain")):
            rows.append("train,%s,%s,%g,%g,%g" % (pose, method, 0.1 / (k + 1), 0.12 / (k + 1),
                                                  0.3 / (k + 1)))
    for test in test_poses:
        for k, method in enumerate(("neutral", "physics", "autoencoder", "pca", "floor")):
            rows.append("test,%s,%s,%g,%g,%g" % (test, method, 0.05 * (k + 1), 0.06 * (k + 1),
                                                 0.1 * (k + 1)))
    with open(os.path.join(evaluation, "evaluation.csv"), "w") as f:
        f.write("\n".join(rows) + "\n")
    with open(os.path.join(model, "train", "log.csv"), "w") as f:
        f.write("iteration,loss,mean_surface_error,max_surface_error,gradient_norm,step_norm,"
                "seconds,function_evaluations\n")
        for it in range(6):
            f.write("%d,%g,%g,%g,0.1,0.1,%d,1\n" % (it, 0.01 / (it + 1), 0.05 / (it + 1),
                                                    0.5 / (it + 1), it))
    os.makedirs(os.path.join(model, "pretrain"), exist_ok=True)
    with open(os.path.join(model, "pretrain", "log.csv"), "w") as f:
        f.write("iteration,loss,gradient_norm,seconds\n")
        for it in range(4):
            f.write("%d,%g,%g,%g\n" % (it, 0.1 / (it + 1), 0.01, 0.5 * it))
    return evaluation, model


def has_plotting():
    try:
        import matplotlib  # noqa: F401
        import numpy  # noqa: F401
        return True
    except ImportError:
        return False


def run(command):
    return subprocess.run(command, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                          universal_newlines=True)


def run_with_file(command, path, edit):
    """Runs command with the text file at path replaced by edit(its text) (the file as it
    was afterwards)."""
    with open(path) as f:
        text = f.read()
    try:
        with open(path, "w") as f:
            f.write(edit(text))
        return run(command)
    finally:
        with open(path, "w") as f:
            f.write(text)


def snapshot(folder):
    """Every file under folder (path relative to it -> its bytes)."""
    files = {}
    for parent, _, names in os.walk(folder):
        for name in names:
            path = os.path.join(parent, name)
            with open(path, "rb") as f:
                files[os.path.relpath(path, folder)] = f.read()
    return files


def decimals_problems(script):
    """The page prints errors with the decimals evaluation.md's tables use: three
    significant digits at the median error (4 decimals in cm, 6 in metres; 4 to 12)."""
    import importlib.util
    spec = importlib.util.spec_from_file_location("evaluation_report_decimals", script)
    report = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(report)
    def rows(*means):
        return [{"split": "test", "pose": "p", "method": "physics", "mean": m, "rms": m,
                 "max": m} for m in means]
    problems = []
    for means, expected in (((0.02, 0.05, 0.3), 4), ((0.0002, 0.0005, 0.003), 6), ((), 4),
                            ((0.0,), 4), ((1e-30,), 12), ((123.0,), 4)):
        got = report.table_decimals(rows(*means))
        if got != expected:
            problems.append("table_decimals%s: %d, expected %d" % (means, got, expected))
    report.DECIMALS = 6
    if report.format_mean({"mean": 0.00012345}) != "mean 0.000123":
        problems.append("format_mean does not use the table's decimals: %s"
                        % report.format_mean({"mean": 0.00012345}))
    return problems


def colour_bar_label_problems(script):
    """Draws the sheets of a wide, short surface (41 x 3 vertices, 40 x 0.4 model units)
    in this process and returns the colour bars whose label is longer than the bar: the
    pictures are saved with a tight box, which cuts such a label at the bar's ends."""
    import importlib.util
    import numpy as np
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    spec = importlib.util.spec_from_file_location("evaluation_report", script)
    report = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(report)
    nx, ny = 41, 3
    vertices = np.array([(float(i), 0.2 * j, 0.0) for j in range(ny) for i in range(nx)])
    triangles = []
    for j in range(ny - 1):
        for i in range(nx - 1):
            a = j * nx + i
            triangles += [(a, a + 1, a + nx + 1), (a, a + nx + 1, a + nx)]
    triangles = np.array(triangles)
    values = 0.01 * vertices[:, 0]
    mask = np.ones(len(vertices), dtype=bool)
    surfaces = {"target": vertices, "physics": vertices + 0.01, "pca": vertices - 0.01}
    errors = {"physics": values, "pca": 2 * values}
    figures, close = [], plt.close
    plt.switch_backend("Agg")
    # Keep the sheets' figures to measure them (a backend switch closes "all").
    plt.close = lambda figure: figures.append(figure) if hasattr(figure, "canvas") \
        else close(figure)
    root = tempfile.mkdtemp(prefix="aqs_report_bar_")
    try:
        report.pose_sheet(os.path.join(root, "pose.png"), "wide", surfaces, errors, vertices,
                          triangles, mask, {})
        report.training_sheet(os.path.join(root, "training.png"), "wide", vertices,
                              {"floor": values, "pretrain": values, "physics": values},
                              triangles, mask, {})
    finally:
        plt.close = close
        shutil.rmtree(root, ignore_errors=True)
    problems = []
    for name, figure in zip(("held-out sheet", "training sheet"), figures):
        renderer = figure.canvas.get_renderer()
        bar = figure.axes[-1]
        label = bar.yaxis.label.get_window_extent(renderer)
        extent = bar.get_window_extent(renderer)
        if label.y0 < extent.y0 - 1 or label.y1 > extent.y1 + 1:
            problems.append("%s: the colour bar's label (%.0f px) is longer than the bar "
                            "(%.0f px) and is cut" % (name, label.height, extent.height))
        close(figure)
    return problems


def main():
    if len(sys.argv) != 2:
        print("usage: evaluation_report_test.py SCRIPT")
        return 1
    script = sys.argv[1]
    root = tempfile.mkdtemp(prefix="aqs_report_test_")
    failures = []
    try:
        evaluation, model = make_evaluation(root)
        command = [sys.executable, script, "--evaluation", evaluation, "--model", model,
                   "--error_vertices", "0:15"]
        if not has_plotting():
            result = run(command)
            if result.returncode != 3 or "python3-matplotlib" not in result.stdout:
                print("without matplotlib the script must exit 3 and say what to install:\n" +
                      result.stdout)
                return 1
            print("SKIPPED: %s lacks matplotlib or numpy; the pictures were not checked"
                  % sys.executable)
            return SKIP
        result = run(command)
        if result.returncode != 0:
            failures.append("the script failed (exit %d):\n%s" % (result.returncode,
                                                                  result.stdout))
        for name in ("images/held_out/smile.png", "images/budget.png",
                     "images/training_curve.png", "images/pretraining_curve.png",
                     "images/training/train_0.png", "images/training/train_1.png",
                     "index.html"):
            path = os.path.join(evaluation, name)
            if not os.path.isfile(path) or os.path.getsize(path) == 0:
                failures.append("%s was not written" % name)
            elif name.endswith(".png"):
                with open(path, "rb") as f:
                    if f.read(8) != b"\x89PNG\r\n\x1a\n":
                        failures.append("%s is not a PNG file" % name)
        index = os.path.join(evaluation, "index.html")
        if os.path.isfile(index):
            page = open(index).read()
            for needle in ("images/held_out/smile.png", "images/budget.png",
                           "images/training_curve.png", "images/pretraining_curve.png",
                           "images/training/train_1.png",
                           "<table>", "(a) floor", "(b) after pre-training", "smile",
                           "train_1", "0.1000"):
                if needle not in page:
                    failures.append("index.html lacks '%s'" % needle)
            # No evaluation.md in this evaluation: the page says so (its warnings unknown).
            if "evaluation.md is missing" not in page:
                failures.append("without evaluation.md the page must say it is missing")
        leftovers = [name for name in os.listdir(os.path.join(evaluation, "images"))
                     if name.startswith(".")]
        if leftovers:
            failures.append("the pictures' temporary folder was left behind: %s" % leftovers)
        # Bad input: no evaluation.csv; a malformed OBJ.
        os.remove(os.path.join(evaluation, "evaluation.csv"))
        result = run(command)
        if result.returncode != 1 or "evaluation.csv" not in result.stdout:
            failures.append("a missing evaluation.csv must exit 1 naming it, got %d:\n%s"
                            % (result.returncode, result.stdout))
        evaluation2, model2 = make_evaluation(os.path.join(root, "second"))
        with open(os.path.join(evaluation2, "fitted", "smile_pca.obj"), "a") as f:
            f.write("v 1 two 3\n")
        result = run([sys.executable, script, "--evaluation", evaluation2, "--model", model2])
        if result.returncode != 1 or "smile_pca.obj:" not in result.stdout:
            failures.append("a malformed OBJ must exit 1 naming file and line, got %d:\n%s"
                            % (result.returncode, result.stdout))
        evaluation3, model3 = make_evaluation(os.path.join(root, "third"))
        with open(os.path.join(evaluation3, "budget", "training_errors.bin"), "ab") as f:
            f.write(b"\0\0\0")
        result = run([sys.executable, script, "--evaluation", evaluation3, "--model", model3])
        if result.returncode != 1 or "training_errors.bin" not in result.stdout:
            failures.append("a truncated matrix file must exit 1 naming it, got %d:\n%s"
                            % (result.returncode, result.stdout))
        # A held-out physics fit that failed (no row, no surface): n/a, and no headline
        # mean of the physics model over fewer poses than the baselines'.
        evaluation4, model4 = make_evaluation(os.path.join(root, "fourth"))
        csv = os.path.join(evaluation4, "evaluation.csv")
        kept = [line for line in open(csv) if not line.startswith("test,smile,physics,")]
        with open(csv, "w") as f:
            f.writelines(kept)
        for name in ("smile_physics.obj", "smile_physics.ply"):
            for folder in ("fitted", "fields"):
                path = os.path.join(evaluation4, folder, name)
                if os.path.exists(path):
                    os.remove(path)
        result = run([sys.executable, script, "--evaluation", evaluation4, "--model", model4])
        page = open(os.path.join(evaluation4, "index.html")).read() if result.returncode == 0 \
            else ""
        if result.returncode != 0 or "failed on 1 of the 1 held-out poses" not in page or \
                "lower than every baseline" in page:
            failures.append("a failed physics fit must be n/a with no headline mean, got %d:\n%s"
                            % (result.returncode, result.stdout))
        # Held-out poses whose names would collide as file names made safe ('a:b', 'a_b')
        # or with a chart ('budget'): each keeps its own picture, and the chart stays.
        poses = ("budget", "a:b", "a_b", "smile#1")
        evaluation5, model5 = make_evaluation(os.path.join(root, "fifth"), poses)
        stale = os.path.join(evaluation5, "images", "held_out", "gone.png")
        os.makedirs(os.path.dirname(stale))
        open(stale, "w").close()
        result = run([sys.executable, script, "--evaluation", evaluation5, "--model", model5])
        page = open(os.path.join(evaluation5, "index.html")).read() if result.returncode == 0 \
            else ""
        for pose, link in zip(poses, ("budget", "a%3Ab", "a_b", "smile%231")):
            if not os.path.isfile(os.path.join(evaluation5, "images", "held_out", pose + ".png")):
                failures.append("held-out pose '%s' has no picture of its own" % pose)
            if "images/held_out/%s.png" % link not in page:
                failures.append("index.html lacks the quoted link to '%s'" % pose)
        if "images/budget.png" not in page or os.path.exists(stale):
            failures.append("the budget chart must stay and a stale picture must go:\n%s"
                            % result.stdout)

        # A negative --training_pictures is a bad argument (argparse: exit 2), not a slice
        # from the end (-1 drew all the training poses but one).
        evaluation6, model6 = make_evaluation(os.path.join(root, "sixth"))
        command6 = [sys.executable, script, "--evaluation", evaluation6, "--model", model6]
        images6 = os.path.join(evaluation6, "images")
        result = run(command6 + ["--training_pictures", "-1"])
        if result.returncode != 2 or "--training_pictures" not in result.stdout or \
                os.path.exists(images6):
            failures.append("--training_pictures -1 must exit 2 naming the argument, drawing "
                            "nothing, got %d:\n%s" % (result.returncode, result.stdout))
            shutil.rmtree(images6, ignore_errors=True)  # not to fail the checks below

        # Malformed PLY and OBJ lines: exit 1 with the file and line, no traceback, and
        # nothing written (every input is read before the first picture).
        fitted_pca = os.path.join(evaluation6, "fitted", "smile_pca.obj")
        field_pca = os.path.join(evaluation6, "fields", "smile_pca.ply")
        for path, edit, where, what in (
                (field_pca, lambda t: t.replace("element vertex 20", "element vertex abc"),
                 "smile_pca.ply:4:", "a PLY vertex count that is not a number"),
                (field_pca, lambda t: t.replace("\n0 0 0 0 0 0 0\n", "\n0 0 0 0 0 0 x\n"),
                 "smile_pca.ply:15:", "a PLY value that is not a number"),
                (field_pca, lambda t: t.replace("\n0 0 0 0 0 0 0\n", "\n0 0 0 0 0 0\n"),
                 "smile_pca.ply:15:", "a PLY vertex line with too few values"),
                (field_pca, lambda t: t.replace("element vertex 20", "element vertex 40"),
                 "smile_pca.ply: truncated", "a PLY shorter than its vertex count"),
                (fitted_pca, lambda t: t + "v 1 2\n", "smile_pca.obj:33:",
                 "an OBJ 'v' line with two numbers"),
                (fitted_pca, lambda t: t + "f 1 2 99\n", "smile_pca.obj:33:",
                 "an OBJ face with a vertex that does not exist")):
            result = run_with_file(command6, path, edit)
            if result.returncode != 1 or where not in result.stdout or \
                    "Traceback" in result.stdout or os.path.exists(images6):
                failures.append("%s must exit 1 naming '%s' and write nothing, got %d:\n%s"
                                % (what, where, result.returncode, result.stdout))
        # A mistyped --evaluation creates no folder there.
        typo = os.path.join(root, "typo", "evaluation")
        result = run([sys.executable, script, "--evaluation", typo])
        if result.returncode != 1 or os.path.exists(os.path.join(root, "typo")):
            failures.append("a mistyped --evaluation must exit 1 and create nothing, got "
                            "%d:\n%s" % (result.returncode, result.stdout))

        # evaluation.md's warnings head the page (escaped), above the headline; its
        # sentence on the auto-encoder's training is shown by the tables.
        warning = ("held-out pose 'smile' is within 0.001 of the training pose 'smile' "
                   "(<mean> & max): it is not held out")
        autoencoder = ("The auto-encoder trained 200 L-BFGS iterations from seed 7, loss "
                       "0.5 -> 0.01 (converged).")
        with open(os.path.join(evaluation6, "evaluation.md"), "w") as f:
            f.write("# Evaluation of %s\n\nVertex distances.\n\n%s\n\n**Warning:** %s\n"
                    "\n## Training poses\n\n| pose | neutral |\n|---|---|\n"
                    % (model6, autoencoder, warning))
        result = run(command6)
        page = open(os.path.join(evaluation6, "index.html")).read() \
            if result.returncode == 0 else ""
        escaped = ("held-out pose &#x27;smile&#x27; is within 0.001 of the training pose "
                   "&#x27;smile&#x27; (&lt;mean&gt; &amp; max): it is not held out")
        at = page.find(escaped)
        if result.returncode != 0 or at < 0 or "Warning:" not in page[:at] or \
                not 0 <= at < page.find("On 1 held-out poses") or \
                "evaluation.md is missing" in page:
            failures.append("the page must show evaluation.md's warning, escaped, above its "
                            "headline, got %d:\n%s" % (result.returncode, result.stdout))
        if html.escape(autoencoder) not in page or \
                not page.find("<h2>Held-out poses</h2>") > page.find(html.escape(autoencoder)):
            failures.append("the page must show evaluation.md's sentence on the "
                            "auto-encoder's training before the tables")

        # A malformed input leaves the earlier page and its pictures as they were (they
        # were removed before the input was read, the page left linking to none).
        before = snapshot(evaluation6)
        result = run_with_file(command6, fitted_pca, lambda t: t + "v 1 two 3\n")
        after = snapshot(evaluation6)
        changed = sorted(name for name in set(before) | set(after)
                         if before.get(name) != after.get(name))
        if result.returncode != 1 or changed or "images/held_out/smile.png" not in before:
            failures.append("a malformed OBJ must exit 1 and change nothing, got %d, changed "
                            "%s:\n%s" % (result.returncode, changed, result.stdout))

        # evaluation.csv edited by hand (the script is documented for standalone use): a
        # row given twice and an infinite error exit 1 naming the line; a file with no
        # pose (its header only) gives a page with n/a, not a ZeroDivisionError.
        csv_path = os.path.join(evaluation6, "evaluation.csv")
        for edit, where, what in (
                (lambda t: t + t.splitlines()[-1] + "\n", "again (first on line",
                 "a row given twice"),
                (lambda t: t.replace(t.splitlines()[1],
                                     ",".join(t.splitlines()[1].split(",")[:3] +
                                              ["inf", "1", "1"])),
                 "evaluation.csv:2: an infinite error", "an infinite error")):
            result = run_with_file(command6, csv_path, edit)
            if result.returncode != 1 or where not in result.stdout or \
                    "Traceback" in result.stdout:
                failures.append("%s in evaluation.csv must exit 1 naming '%s', got %d:\n%s"
                                % (what, where, result.returncode, result.stdout))
        result = run_with_file(command6, csv_path, lambda t: t.splitlines()[0] + "\n")
        if result.returncode != 0 or "Traceback" in result.stdout:
            failures.append("an evaluation.csv without rows must give a page, got %d:\n%s"
                            % (result.returncode, result.stdout))

        # A wide, short surface: the colour bar's label is not cut.
        failures += colour_bar_label_problems(script)
        failures += decimals_problems(script)
    finally:
        if os.environ.get("AQS_KEEP_TEST_FILES", "0") not in ("", "0"):
            print("kept " + root)
        else:
            shutil.rmtree(root, ignore_errors=True)
    for failure in failures:
        print("FAILED: " + failure)
    if not failures:
        print("evaluation_report.py: pictures, page and bad-input messages checked")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
