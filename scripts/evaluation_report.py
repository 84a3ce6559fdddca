#!/usr/bin/env python3
"""Pictures and an HTML page for an ActiveQS evaluation (aqs_evaluate's output folder).

    python3 evaluation_report.py --evaluation DIR [--model MODEL] [--output DIR]
                                 [--training_pictures 3] [--error_vertices 0:9409]

Reads DIR/evaluation.csv (per pose and method: mean, rms, max vertex error; the error
budget's rows `floor` and `pretrain`), DIR/evaluation.md (its warnings and its sentence on
the auto-encoder's training, repeated on the page; where it is missing the page says so),
the held-out poses' surfaces DIR/fitted/<pose>_target.obj
and DIR/fitted/<pose>_<method>.obj (method: physics, autoencoder, pca, floor), and, with
--model, the model's neutral.obj, train/log.csv (the training curve) and pretrain/log.csv
(the pre-training curve, where recorded). Writes into the
output folder (default: DIR):

    images/held_out/<pose>.png  per held-out pose: front views of the pose, of each
                                method's surface and of each method's error map, on one
                                colour scale
    images/budget.png           the error budget, per pose
    images/training/<pose>.png  the budget's error maps of the training poses with the
                                largest trained error (from DIR/budget/training_errors.bin)
    images/training_curve.png
    images/pretraining_curve.png
    index.html               the tables, the error budget and the pictures

A picture's file name is its pose's name (a file stem, unique in its split; the page quotes
it for the link), in a folder per split, so no two poses and no pose and chart share a
file. Every input is read and checked before anything is written; the pictures are drawn
into a temporary folder in images/ and then replace the earlier ones (both split folders'
PNG files are removed, so that a pose no longer evaluated leaves no picture behind), and
index.html is written last, through a temporary file: bad input leaves the output folder
untouched, and a failure while drawing leaves the earlier page and pictures as they were.

Error maps colour the distance of every vertex to the pose (model units) on the pose's
surface, with one scale (viridis, 0 to the 98th percentile of the methods' errors) for
all methods of a pose; vertices outside --error_vertices (not measured) are grey.

Exit status: 0 done; 1 bad input (a missing or malformed file, named, with the line where
it has lines) or an output that cannot be written; 2 bad arguments (argparse: e.g. a
negative --training_pictures); 3 matplotlib or numpy cannot be imported (install
python3-matplotlib and python3-numpy).
"""

import argparse
import csv
import html
import math
import os
import shutil
import sys
import tempfile
import urllib.parse

MISSING_PACKAGE_STATUS = 3
METHODS = ["physics", "autoencoder", "pca", "pca_neutral"]
BASELINES = ["autoencoder", "pca", "pca_neutral"]
METHOD_NAMES = {"neutral": "neutral", "physics": "physics", "autoencoder": "auto-encoder",
                "pca": "PCA", "pca_neutral": "PCA (neutral)", "floor": "floor",
                "pretrain": "after pre-training"}


class InputError(Exception):
    """Bad input: the message names the file."""


def import_plotting():
    """Imports numpy and matplotlib (Agg backend); exits with status 3 if one is missing."""
    try:
        import numpy  # noqa: F401
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot  # noqa: F401
        import matplotlib.collections  # noqa: F401
    except ImportError as e:
        sys.stderr.write(
            "evaluation_report.py: %s (Python %s at %s). Install python3-matplotlib and "
            "python3-numpy (Debian: apt-get install python3-matplotlib python3-numpy, or "
            "scripts/install_deps.sh); the evaluation's tables were written.\n"
            % (e, sys.version.split()[0], sys.executable))
        sys.exit(MISSING_PACKAGE_STATUS)


# ---------------------------------------------------------------- reading


def read_obj(path):
    """Vertices (N x 3) and triangles (T x 3, 0-based; polygons fanned) of an OBJ file.
    A malformed line (a 'v' without three finite numbers, a face with fewer than three
    corners or a corner that is not a vertex index) is an InputError naming path:line."""
    import numpy as np
    vertices, triangles, faces = [], [], []
    try:
        with open(path) as f:
            for number, line in enumerate(f, 1):
                parts = line.split()
                if not parts:
                    continue
                try:
                    if parts[0] == "v":
                        vertex = [float(x) for x in parts[1:4]]
                        if len(vertex) != 3 or not all(math.isfinite(x) for x in vertex):
                            raise ValueError
                        vertices.append(vertex)
                    elif parts[0] == "f":
                        corners = []
                        for item in parts[1:]:
                            index = int(item.split("/")[0])
                            if index == 0:
                                raise ValueError
                            corners.append(index - 1 if index > 0 else len(vertices) + index)
                        if len(corners) < 3:
                            raise ValueError
                        faces.append((number, min(corners), max(corners)))
                        for k in range(1, len(corners) - 1):
                            triangles.append([corners[0], corners[k], corners[k + 1]])
                except (ValueError, IndexError):
                    raise InputError("%s:%d: malformed '%s' line" % (path, number, parts[0]))
    except OSError as e:
        raise InputError("%s: cannot be read (%s)" % (path, e.strerror))
    except UnicodeDecodeError:
        raise InputError("%s: not a text (OBJ) file" % path)
    for number, lowest, highest in faces:
        if lowest < 0 or highest >= len(vertices):
            raise InputError("%s:%d: a face refers to a vertex that does not exist (the file "
                             "has %d)" % (path, number, len(vertices)))
    v = np.array(vertices, dtype=float).reshape(-1, 3)
    t = np.array(triangles, dtype=int).reshape(-1, 3)
    return v, t


def read_ply_values(path):
    """The per-vertex `value` property of an ASCII PLY (as aqs_evaluate writes): one line
    per element instance (blank lines skipped), the vertex element's lines after those of
    the elements declared before it. A malformed header line or vertex line (a count or
    a value that is not a number, too few or too many values, a file shorter than its
    counts) is an InputError naming path:line."""
    import numpy as np
    try:
        with open(path) as f:
            lines = f.read().splitlines()
    except OSError as e:
        raise InputError("%s: cannot be read (%s)" % (path, e.strerror))
    except UnicodeDecodeError:
        raise InputError("%s: not an ASCII PLY file" % path)
    # Elements in header order: [name, count, properties].
    elements, body = [], None
    for number, line in enumerate(lines, 1):
        parts = line.split()
        if not parts:
            continue
        if parts[0] == "format" and parts[1:2] != ["ascii"]:
            raise InputError("%s: only ASCII PLY is read" % path)
        if parts[0] == "element":
            try:
                if len(parts) != 3 or int(parts[2]) < 0:
                    raise ValueError
                elements.append([parts[1], int(parts[2]), []])
            except ValueError:
                raise InputError("%s:%d: malformed 'element' line (expected 'element NAME "
                                 "COUNT', COUNT 0 or more)" % (path, number))
        elif parts[0] == "property" and elements:
            if len(parts) < 3:
                raise InputError("%s:%d: malformed 'property' line" % (path, number))
            if elements[-1][0] == "vertex" and parts[1] == "list":
                raise InputError("%s:%d: a list property of the vertex element is not read"
                                 % (path, number))
            elements[-1][2].append(parts[-1])
        elif parts[0] == "end_header":
            body = number  # 0-based index of the first line after the header
            break
    names = [e[0] for e in elements]
    if body is None or "vertex" not in names or \
            "value" not in elements[names.index("vertex")][2]:
        raise InputError("%s: no vertex element with a 'value' property" % path)
    data = [(number, line.split()) for number, line in enumerate(lines[body:], body + 1)
            if line.strip()]
    _, count, properties = elements[names.index("vertex")]
    first = sum(e[1] for e in elements[:names.index("vertex")])
    column = properties.index("value")
    if len(data) < first + count:
        raise InputError("%s: truncated: the header declares %d vertices (after %d lines of "
                         "other elements), the file has %d data lines"
                         % (path, count, first, len(data)))
    values = []
    for number, parts in data[first:first + count]:
        try:
            numbers = [float(x) for x in parts]
            if len(numbers) != len(properties) or not math.isfinite(numbers[column]):
                raise ValueError
        except ValueError:
            raise InputError("%s:%d: malformed vertex line (expected %d numbers, a finite "
                             "'value' in column %d)" % (path, number, len(properties),
                                                        column + 1))
        values.append(numbers[column])
    return np.array(values, dtype=float)


def read_matrix(path):
    """A util/matrix_io.h file (magic AQSMAT1, int64 rows and cols, column-major
    little-endian doubles) as a rows x cols array."""
    import struct
    import numpy as np
    try:
        with open(path, "rb") as f:
            data = f.read()
    except OSError as e:
        raise InputError("%s: cannot be read (%s)" % (path, e.strerror))
    if data[:8] != b"AQSMAT1\n" or len(data) < 24:
        raise InputError("%s: not a matrix file (magic AQSMAT1)" % path)
    rows, cols = struct.unpack("<qq", data[8:24])
    if rows < 0 or cols < 0 or len(data) != 24 + 8 * rows * cols:
        raise InputError("%s: %d x %d does not match the file's size" % (path, rows, cols))
    return np.frombuffer(data, dtype="<f8", offset=24).reshape(cols, rows).T


def read_evaluation_csv(path):
    """Rows of evaluation.csv as dicts (split, pose, method, mean, rms, max as floats).
    Pose names are file stems (aqs_evaluate's): never empty, no '/' (they name files)."""
    fields = ("split", "pose", "method", "mean", "rms", "max")
    try:
        with open(path, newline="") as f:
            reader = csv.DictReader(f)
            if reader.fieldnames is None or not set(fields) <= set(reader.fieldnames):
                raise InputError("%s:1: expected the header %s" % (path, ",".join(fields)))
            rows, seen = [], {}
            for number, row in enumerate(reader, 2):
                try:
                    parsed = {"split": row["split"], "pose": row["pose"],
                              "method": row["method"], "mean": float(row["mean"]),
                              "rms": float(row["rms"]), "max": float(row["max"])}
                except (KeyError, TypeError, ValueError):
                    raise InputError("%s:%d: expected split,pose,method,mean,rms,max" %
                                     (path, number))
                pose = parsed["pose"]
                if not pose or "/" in pose or "\0" in pose or pose in (".", ".."):
                    raise InputError("%s:%d: the pose name '%s' is not a file stem"
                                     % (path, number, pose))
                if any(math.isinf(parsed[k]) for k in ("mean", "rms", "max")):
                    raise InputError("%s:%d: an infinite error" % (path, number))
                key = (parsed["split"], pose, parsed["method"])
                if key in seen:
                    raise InputError("%s:%d: %s of pose '%s' (%s) again (first on line %d)"
                                     % (path, number, parsed["method"], pose, parsed["split"],
                                        seen[key]))
                seen[key] = number
                # A value that could not be measured (NaN) is n/a, as a missing row is.
                if not any(math.isnan(parsed[k]) for k in ("mean", "rms", "max")):
                    rows.append(parsed)
    except OSError as e:
        raise InputError("%s: cannot be read (%s); run aqs_evaluate first" % (path, e.strerror))
    except (UnicodeDecodeError, csv.Error) as e:
        raise InputError("%s: not a CSV file (%s)" % (path, e))
    return rows


def read_log_columns(path, keys):
    """The columns `keys` of a CSV log with a header line, as lists of floats."""
    try:
        with open(path, newline="") as f:
            reader = csv.DictReader(f)
            columns = {}
            for number, row in enumerate(reader, 2):
                try:
                    for key in keys:
                        columns.setdefault(key, []).append(float(row[key]))
                except (KeyError, TypeError, ValueError):
                    raise InputError("%s:%d: expected %s,..." % (path, number, ",".join(keys)))
    except OSError as e:
        raise InputError("%s: cannot be read (%s)" % (path, e.strerror))
    except (UnicodeDecodeError, csv.Error) as e:
        raise InputError("%s: not a CSV file (%s)" % (path, e))
    return columns


def read_training_log(path):
    """Columns of train/log.csv (iteration, loss, mean_surface_error, ...) as lists."""
    return read_log_columns(path, ("iteration", "loss", "mean_surface_error",
                                   "max_surface_error"))


def read_pretraining_log(path):
    """Columns of pretrain/log.csv (iteration, loss, gradient_norm, seconds) as lists."""
    return read_log_columns(path, ("iteration", "loss", "gradient_norm", "seconds"))


def read_evaluation_markdown(path):
    """What the page repeats of evaluation.md: its '**Warning:**' paragraphs (the text
    after the marker, lines joined) and the paragraph on the auto-encoder's training
    ('The auto-encoder trained ...'), as {"warnings": [...], "autoencoder": text or None,
    "problem": None, or why the file could not be read}. A missing or unreadable
    evaluation.md is no error: the page says so."""
    result = {"warnings": [], "autoencoder": None, "problem": None}
    try:
        with open(path) as f:
            text = f.read()
    except FileNotFoundError:
        result["problem"] = ("%s is missing: any warning of the evaluation's is not shown here"
                             % path)
        return result
    except OSError as e:
        result["problem"] = ("%s cannot be read (%s): any warning of the evaluation's is not "
                             "shown here" % (path, e.strerror))
        return result
    except UnicodeDecodeError:
        result["problem"] = ("%s is not a text file: any warning of the evaluation's is not "
                             "shown here" % path)
        return result
    # Paragraphs: runs of lines between blank lines; a warning, a heading or a table line
    # starts a new one.
    paragraphs = []
    for line in text.splitlines():
        line = line.strip()
        if not line:
            paragraphs.append([])
        elif not paragraphs or line.startswith(("**Warning:**", "#", "|")) or \
                (paragraphs[-1] and paragraphs[-1][0].startswith(("#", "|"))):
            paragraphs.append([line])
        else:
            paragraphs[-1].append(line)
    for lines in paragraphs:
        if not lines:
            continue
        paragraph = " ".join(lines)
        if paragraph.startswith("**Warning:**"):
            result["warnings"].append(paragraph[len("**Warning:**"):].strip())
        elif paragraph.startswith("The auto-encoder trained ") and not result["autoencoder"]:
            result["autoencoder"] = paragraph
    return result


def parse_vertex_ranges(text, count):
    """A boolean mask of the vertices in 'a:b,c,d-e' (a to b-1, c, d to e), or all."""
    import numpy as np
    if not text:
        return np.ones(count, dtype=bool)
    mask = np.zeros(count, dtype=bool)
    for item in text.split(","):
        item = item.strip()
        if not item:
            continue
        try:
            if ":" in item:
                a, b = (int(x) for x in item.split(":"))
            elif "-" in item[1:]:
                a, b = (int(x) for x in item.split("-"))
                b += 1
            else:
                a = int(item)
                b = a + 1
        except ValueError:
            raise InputError("--error_vertices: '%s' is not a vertex range" % item)
        mask[max(0, a):min(count, b)] = True
    return mask


# ---------------------------------------------------------------- rendering


class FrontView:
    """An orthographic front view (looking along -z, y up) of surfaces that share the
    triangles of one mesh: back-facing triangles are dropped, the rest drawn from back
    to front (painter's algorithm) with Lambert shading."""

    def __init__(self, triangles, frame_vertices, mask):
        import numpy as np
        self.triangles = triangles
        framed = frame_vertices[mask] if mask.any() else frame_vertices
        lo, hi = framed[:, :2].min(axis=0), framed[:, :2].max(axis=0)
        margin = 0.04 * (hi - lo).max()
        self.xlim = (lo[0] - margin, hi[0] + margin)
        self.ylim = (lo[1] - margin, hi[1] + margin)
        self.mask = mask
        self.light = np.array([-0.35, 0.45, 1.0])
        self.light /= np.linalg.norm(self.light)

    def _visible(self, vertices):
        import numpy as np
        corners = vertices[self.triangles]  # T x 3 x 3
        normals = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
        lengths = np.linalg.norm(normals, axis=1)
        keep = (normals[:, 2] > 0) & (lengths > 0)
        normals = normals[keep] / lengths[keep, None]
        order = np.argsort(corners[keep][:, :, 2].mean(axis=1))  # far (small z) first
        shade = np.clip(normals[order] @ self.light, 0.0, 1.0)
        return np.flatnonzero(keep)[order], corners[keep][order], shade

    def draw(self, ax, vertices, values=None, cmap=None, norm=None, title=""):
        """Draws the surface (grey, shaded) or, with values, its error map."""
        import numpy as np
        from matplotlib.collections import PolyCollection
        faces, corners, shade = self._visible(vertices)
        if values is None:
            grey = 0.25 + 0.7 * shade
            colors = np.stack([grey * 0.93, grey * 0.9, grey * 0.87, np.ones_like(grey)], axis=1)
        else:
            face_values = values[self.triangles[faces]].mean(axis=1)
            colors = cmap(norm(face_values))
            measured = self.mask[self.triangles[faces]].all(axis=1)
            colors[~measured] = (0.82, 0.82, 0.82, 1.0)
            colors[:, :3] *= (0.72 + 0.28 * shade)[:, None]
        collection = PolyCollection(corners[:, :, :2], facecolors=colors, edgecolors=colors,
                                    linewidths=0.15, antialiaseds=False)
        ax.add_collection(collection)
        ax.set_xlim(*self.xlim)
        ax.set_ylim(*self.ylim)
        ax.set_aspect("equal")
        ax.set_axis_off()
        ax.set_title(title, fontsize=10)


def percentile_scale(arrays, mask, q=98.0):
    import numpy as np
    pooled = np.concatenate([a[mask] for a in arrays if a is not None])
    top = float(np.percentile(pooled, q)) if pooled.size else 1.0
    return top if top > 0 else 1.0


def label_colour_bar(fig, bar, text="vertex error (model units)"):
    """Labels a vertical colour bar along its length, or, where the bar is shorter than that
    label (a wide, short surface makes a short figure), across it, beside the bar in two
    lines: savefig's tight box would cut a label longer than its bar at the bar's ends."""
    bar.set_label(text, fontsize=9)
    renderer = fig.canvas.get_renderer()
    if bar.ax.yaxis.label.get_window_extent(renderer).height > \
            bar.ax.get_window_extent(renderer).height:
        bar.set_label(text.replace(" (", "\n("), fontsize=9, rotation=0, ha="left",
                      va="center")


def pose_sheet(path, pose, surfaces, errors, neutral, triangles, mask, stats):
    """One PNG: top row the pose and each method's surface, bottom row the error maps."""
    import numpy as np
    import matplotlib.pyplot as plt
    from matplotlib import colors as mcolors
    target = surfaces["target"]
    methods = [m for m in METHODS + ["floor"] if m in surfaces]
    view = FrontView(triangles, target, mask)
    vmax = percentile_scale([errors[m] for m in methods], mask)
    norm = mcolors.Normalize(vmin=0.0, vmax=vmax)
    cmap = plt.get_cmap("viridis")
    columns = 1 + len(methods)
    aspect = (view.ylim[1] - view.ylim[0]) / (view.xlim[1] - view.xlim[0])
    width = 2.6
    fig, axes = plt.subplots(2, columns, figsize=(width * columns + 0.9, 2 * width * aspect + 1.0),
                             squeeze=False)
    view.draw(axes[0][0], target, title="%s (the pose)" % pose)
    if neutral is not None:
        motion = np.linalg.norm(target - neutral, axis=1)
        view.draw(axes[1][0], target, motion, cmap, norm,
                  title="neutral: %s" % format_mean(stats.get(("neutral", pose))))
    else:
        axes[1][0].set_axis_off()
    for k, method in enumerate(methods, 1):
        view.draw(axes[0][k], surfaces[method], title=METHOD_NAMES[method])
        view.draw(axes[1][k], target, errors[method], cmap, norm,
                  title="%s: %s" % (METHOD_NAMES[method], format_mean(stats.get((method, pose)))))
    fig.subplots_adjust(left=0.01, right=0.90, top=0.93, bottom=0.02, wspace=0.03, hspace=0.12)
    bar_axes = fig.add_axes([0.915, 0.06, 0.015, 0.38])
    bar = fig.colorbar(plt.cm.ScalarMappable(norm=norm, cmap=cmap), cax=bar_axes, extend="max")
    label_colour_bar(fig, bar)
    fig.savefig(path, dpi=110, bbox_inches="tight", pad_inches=0.1)
    plt.close(fig)
    return vmax


def training_sheet(path, pose, target, errors, triangles, mask, stats):
    """One PNG for a training pose: the pose, then the error maps of the budget's stages
    (floor, after pre-training, trained) on one scale."""
    import numpy as np
    import matplotlib.pyplot as plt
    from matplotlib import colors as mcolors
    stages = [(key, title) for key, title in (("floor", "(a) floor"),
                                              ("pretrain", "(b) after pre-training"),
                                              ("physics", "(c) trained"))
              if key in errors and not np.isnan(errors[key]).any()]
    view = FrontView(triangles, target, mask)
    vmax = percentile_scale([errors[k] for k, _ in stages], mask)
    norm = mcolors.Normalize(vmin=0.0, vmax=vmax)
    cmap = plt.get_cmap("viridis")
    aspect = (view.ylim[1] - view.ylim[0]) / (view.xlim[1] - view.xlim[0])
    width = 2.6
    fig, axes = plt.subplots(1, 1 + len(stages),
                             figsize=(width * (1 + len(stages)) + 0.9, width * aspect + 0.6),
                             squeeze=False)
    view.draw(axes[0][0], target, title="%s (training pose)" % pose)
    for k, (key, title) in enumerate(stages, 1):
        view.draw(axes[0][k], target, errors[key], cmap, norm,
                  title="%s: %s" % (title, format_mean(stats.get((key, pose)))))
    fig.subplots_adjust(left=0.01, right=0.90, top=0.9, bottom=0.02, wspace=0.03)
    bar_axes = fig.add_axes([0.915, 0.1, 0.015, 0.75])
    bar = fig.colorbar(plt.cm.ScalarMappable(norm=norm, cmap=cmap), cax=bar_axes, extend="max")
    label_colour_bar(fig, bar)
    fig.savefig(path, dpi=110, bbox_inches="tight", pad_inches=0.1)
    plt.close(fig)
    return vmax, [title for _, title in stages]


def format_mean(row):
    return "mean %s" % number(row["mean"]) if row else "n/a"


def read_embedding_floor(path):
    """The mean over poses of poses.txt's embedding_mean_error (None if unreadable)."""
    values = []
    try:
        with open(path) as f:
            for line in f:
                parts = line.split("#")[0].split()
                if len(parts) == 4:
                    values.append(float(parts[2]))
    except (OSError, ValueError):
        return None
    return sum(values) / len(values) if values else None


def training_curve(path, log, floor):
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(7.5, 3.6))
    it = log["iteration"]
    ax.plot(it, log["mean_surface_error"], color="tab:blue", label="mean surface error")
    if floor is not None:
        ax.axhline(floor, color="tab:green", linestyle="--", linewidth=1,
                   label="(a) embedding floor")
        ax.set_ylim(bottom=0)
        ax.legend(loc="upper right", fontsize=8)
    ax.set_xlabel("L-BFGS iteration (0: after pre-training and the first latent refit)")
    ax.set_ylabel("mean surface error (model units)", color="tab:blue")
    ax.grid(True, alpha=0.3)
    right = ax.twinx()
    right.semilogy(it, log["loss"], color="tab:orange", label="loss")
    right.set_ylabel("loss (log scale)", color="tab:orange")
    ax.set_title("End-to-end training")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def pretraining_curve(path, log):
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(7.5, 3.0))
    ax.semilogy(log["iteration"], log["loss"], color="tab:orange")
    ax.set_xlabel("L-BFGS iteration (0: the decoder's random start)")
    ax.set_ylabel("loss (log scale)")
    ax.grid(True, alpha=0.3)
    ax.set_title("Pre-training: the decoder (and latents) fitted to the volumetric targets")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def budget_chart(path, rows):
    """Grouped bars per pose: the budget's stages and the baselines, one panel per split."""
    import numpy as np
    import matplotlib.pyplot as plt
    panels = []
    for split, order in (("train", ("floor", "pretrain", "physics", "autoencoder", "pca",
                                    "pca_neutral")),
                         ("test", ("neutral", "floor", "physics", "autoencoder", "pca",
                                   "pca_neutral"))):
        poses = ordered_poses(rows, split)
        present = {r["method"] for r in rows if r["split"] == split}
        methods = [m for m in order if m in present]
        if poses and methods:
            panels.append((split, poses, methods))
    if not panels:
        return False
    most = max(len(poses) for _, poses, _ in panels)
    fig, axes = plt.subplots(len(panels), 1, figsize=(max(11.0, 0.55 * most), 3.6 * len(panels)),
                             squeeze=False)
    palette = {"neutral": "#bbbbbb", "floor": "#2a9d8f", "pretrain": "#e9c46a",
               "physics": "#264653", "autoencoder": "#f4a261", "pca": "#e76f51",
               "pca_neutral": "#9b2226"}
    for ax, (split, poses, methods) in zip(axes[:, 0], panels):
        stats = {(r["method"], r["pose"]): r["mean"] for r in rows if r["split"] == split}
        width = 0.8 / len(methods)
        x = np.arange(len(poses))
        for k, method in enumerate(methods):
            values = [stats.get((method, pose), np.nan) for pose in poses]
            label = METHOD_NAMES[method]
            if method == "physics":
                label = "physics (trained)" if split == "train" else "physics (fit)"
            ax.bar(x + (k - (len(methods) - 1) / 2) * width, values, width, label=label,
                   color=palette[method])
        ax.set_xticks(x)
        ax.set_xticklabels(poses, rotation=30, ha="right", fontsize=8)
        ax.set_xlim(-0.6, len(poses) - 0.4)
        ax.set_ylabel("mean vertex error")
        ax.set_title("training poses" if split == "train" else "held-out poses", fontsize=10)
        ax.legend(fontsize=8, ncol=len(methods))
        ax.grid(True, axis="y", alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return True


# ---------------------------------------------------------------- HTML


def html_table(headings, rows, numeric_from=1):
    out = ["<table>", "<tr>" + "".join("<th>%s</th>" % html.escape(h) for h in headings) + "</tr>"]
    for row in rows:
        cells = []
        for k, cell in enumerate(row):
            align = ' class="num"' if k >= numeric_from else ""
            cells.append("<td%s>%s</td>" % (align, cell))
        out.append("<tr>" + "".join(cells) + "</tr>")
    out.append("</table>")
    return "\n".join(out)


# Decimals of every error the page prints: table_decimals of the evaluation's rows,
# set by write_report (as the tables of evaluation.md, jobs/evaluation_report.h).
DECIMALS = 4


def table_decimals(rows):
    """Three significant digits at the median of the rows' positive mean errors, 4 to 12
    decimals (TableDecimals in lib/jobs/evaluation_report.cc)."""
    means = sorted(r["mean"] for r in rows if math.isfinite(r["mean"]) and r["mean"] > 0)
    if not means:
        return 4
    return min(12, max(4, 2 - math.floor(math.log10(means[len(means) // 2]))))


def number(value, digits=None):
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return "n/a"
    return "%.*f" % (DECIMALS if digits is None else digits, value)


def split_tables(rows, split):
    """The evaluation.md table of a split: per pose neutral mean, then mean/rms/max of
    each method; a mean row (max of max)."""
    poses = ordered_poses(rows, split)
    stats = {(r["method"], r["pose"]): r for r in rows if r["split"] == split}
    body = []
    sums = {}
    for pose in poses:
        cells = [html.escape(pose), number(stats.get(("neutral", pose), {}).get("mean"))]
        for method in METHODS:
            r = stats.get((method, pose))
            cells += [number(r["mean"]), number(r["rms"]), number(r["max"])] if r else ["n/a"] * 3
            if r:
                s = sums.setdefault(method, [0.0, 0.0, 0.0, 0])
                s[0] += r["mean"]
                s[1] += r["rms"]
                s[2] = max(s[2], r["max"])
                s[3] += 1
        body.append(cells)
    # A mean over every pose only (as evaluation.md's): a method whose fit failed on a pose
    # has n/a there, and n/a as its mean (the largest vertex error is still shown).
    neutral = [stats[("neutral", p)]["mean"] for p in poses if ("neutral", p) in stats]
    mean_row = ["<b>mean</b> (max of max)",
                number(sum(neutral) / len(neutral))
                if poses and len(neutral) == len(poses) else "n/a"]
    for method in METHODS:
        s = sums.get(method)
        if s and s[3] == len(poses):
            mean_row += ["<b>%s</b>" % number(s[0] / s[3]), number(s[1] / s[3]), number(s[2])]
        else:
            mean_row += ["n/a", "n/a", number(s[2]) if s else "n/a"]
    body.append(mean_row)
    headings = ["pose", "neutral mean"]
    for method in METHODS:
        headings += ["%s mean" % METHOD_NAMES[method], "rms", "max"]
    return html_table(headings, body)


def budget_table(rows, split, columns):
    poses = ordered_poses(rows, split)
    stats = {(r["method"], r["pose"]): r for r in rows if r["split"] == split}
    body, sums, worst = [], {}, {}
    for pose in poses:
        cells = [html.escape(pose)]
        for method, _ in columns:
            r = stats.get((method, pose))
            cells.append(number(r["mean"]) if r else "n/a")
            if r:
                sums.setdefault(method, []).append(r["mean"])
                worst[method] = max(worst.get(method, 0.0), r["max"])
        body.append(cells)
    body.append(["<b>mean</b>"] + ["<b>%s</b>" % number(sum(sums[m]) / len(sums[m]))
                                   if poses and len(sums.get(m, [])) == len(poses) else "n/a"
                                   for m, _ in columns])
    body.append(["max vertex error"] + [number(worst[m]) if m in worst else "" for m, _ in columns])
    return html_table(["pose"] + [heading for _, heading in columns], body)


def ordered_poses(rows, split):
    poses = []
    for r in rows:
        if r["split"] == split and r["pose"] not in poses:
            poses.append(r["pose"])
    return poses


def method_means(rows, split, method, num_poses):
    """The method's mean over the split's poses; None unless it has all num_poses of them
    (a failed fit has no row: a mean over fewer poses would not compare)."""
    values = [r["mean"] for r in rows if r["split"] == split and r["method"] == method]
    return sum(values) / len(values) if values and len(values) == num_poses else None


STYLE = """
body { font-family: sans-serif; max-width: 1250px; margin: 1.5em auto; padding: 0 1em;
       color: #222; line-height: 1.4; }
table { border-collapse: collapse; margin: 0.6em 0 1.2em; font-size: 0.9em; }
th, td { border: 1px solid #ccc; padding: 0.2em 0.55em; }
th { background: #f2f2f2; }
td.num { text-align: right; font-variant-numeric: tabular-nums; }
img { max-width: 100%; border: 1px solid #ddd; }
figure { margin: 1em 0 2em; }
figcaption { font-size: 0.9em; color: #444; }
.note { color: #555; font-size: 0.9em; }
.warning { background: #fff4d6; border: 1px solid #e0a800; border-left-width: 5px;
           padding: 0.45em 0.8em; }
"""


def write_html(path, title, rows, figures, notes, markdown):
    """index.html (written to a temporary file, then renamed): evaluation.md's warnings
    (markdown: read_evaluation_markdown's) first, the headline, the tables, the pictures."""
    test_poses = ordered_poses(rows, "test")
    parts = ["<!DOCTYPE html>", "<html><head><meta charset='utf-8'>",
             "<title>%s</title><style>%s</style></head><body>" % (html.escape(title), STYLE),
             "<h1>%s</h1>" % html.escape(title)]
    for warning in markdown["warnings"]:
        parts.append("<p class='warning'><b>Warning:</b> %s</p>" % html.escape(warning))
    if markdown["problem"]:
        parts.append("<p class='note'>%s.</p>" % html.escape(markdown["problem"]))
    # The headline: held-out means of the physics model and the baselines.
    if test_poses:
        means = {m: method_means(rows, "test", m, len(test_poses)) for m in ["neutral"] + METHODS}
        baselines = [m for m in BASELINES if means.get(m) is not None]
        fitted = sum(1 for r in rows if r["split"] == "test" and r["method"] == "physics")
        if fitted < len(test_poses):
            parts.append("<p>The physics fit failed on %d of the %d held-out poses (n/a in the "
                         "tables): no mean over all of them to compare.</p>"
                         % (len(test_poses) - fitted, len(test_poses)))
        if means.get("physics") is not None and baselines:
            best_baseline = min(means[m] for m in baselines)
            verdict = ("lower than every baseline" if means["physics"] < best_baseline
                       else "not lower than every baseline")
            stats = {(r["method"], r["pose"]): r["mean"] for r in rows if r["split"] == "test"}
            wins = sum(1 for p in test_poses
                       if ("physics", p) in stats and all((m, p) in stats for m in baselines) and
                       stats[("physics", p)] < min(stats[(m, p)] for m in baselines))
            parts.append(
                "<p>On %d held-out poses the physics model's mean vertex error is <b>%s</b>: "
                "%s (%s; the neutral face itself %s). It is lower than every baseline on %d of "
                "the %d poses.</p>"
                % (len(test_poses), number(means["physics"]), verdict,
                   ", ".join("%s %s" % (METHOD_NAMES[m], number(means[m])) for m in baselines),
                   number(means["neutral"]), wins, len(test_poses)))
    parts.append("<p class='note'>All errors are distances between a method's surface and the "
                 "pose, per vertex, in model units, over the measured vertices. Methods: "
                 "<b>physics</b> (the learned model; held-out poses: latent and bones fitted "
                 "through the simulator), <b>auto-encoder</b> (surface-only, same latent size; "
                 "its layers: evaluation.md; held-out poses: latent fitted with the physics "
                 "model's prior rule, a Gaussian learned from its own training latents), "
                 "<b>PCA</b> (same size, about the training poses' mean), "
                 "<b>PCA (neutral)</b> (same size, about the neutral: its zero is the rest face), "
                 "<b>neutral</b> (the rest face, for reference).</p>")
    if markdown["autoencoder"]:
        parts.append("<p class='note'>%s</p>" % html.escape(markdown["autoencoder"]))
    for note in notes:
        parts.append("<p class='note'>%s</p>" % html.escape(note))
    parts.append("<h2>Held-out poses</h2>")
    if test_poses:
        parts.append(split_tables(rows, "test"))
    else:
        parts.append("<p>No held-out poses were evaluated.</p>")
    parts.append("<h2>Training poses</h2>")
    parts.append(split_tables(rows, "train"))
    parts.append("<h2>Error budget: where the error comes from</h2>")
    have_budget = any(r["method"] in ("floor", "pretrain") for r in rows)
    if have_budget:
        parts.append(
            "<p><b>(a) floor</b>: the pose's own volumetric target (prepare's embedded "
            "simulation of the pose) simulated &mdash; what a decoder that reproduced the "
            "targets exactly would reach on this simulation mesh and embedding (a reference, "
            "not a lower bound). <b>(b) after pre-training</b>: the "
            "pre-trained decoder's actuation of the pose's latent, simulated (pre-training fits "
            "the volumetric targets, not the surfaces). <b>(c) trained</b>: the end-to-end "
            "trained model, simulated. (c) &minus; (a) is what the decoder and its latent "
            "space still miss; (b) &minus; (c) what end-to-end training recovered. For held-out "
            "poses the floor is made with the bones where the physics fit put them.</p>")
        parts.append("<h3>Training poses</h3>")
        parts.append(budget_table(rows, "train", [("neutral", "neutral"), ("floor", "(a) floor"),
                                                  ("pretrain", "(b) after pre-training"),
                                                  ("physics", "(c) trained"),
                                                  ("autoencoder", "auto-encoder"),
                                                  ("pca", "PCA"),
                                                  ("pca_neutral", "PCA (neutral)")]))
        if test_poses:
            parts.append("<h3>Held-out poses</h3>")
            parts.append(budget_table(rows, "test", [("neutral", "neutral"), ("floor", "floor"),
                                                     ("physics", "physics fit"),
                                                     ("autoencoder", "auto-encoder"),
                                                     ("pca", "PCA"),
                                                     ("pca_neutral", "PCA (neutral)")]))
    else:
        parts.append("<p>Not measured (aqs_evaluate --error_budget=false).</p>")
    headings = {"train": "<h3>Where on the face: training poses</h3>",
                "curve": "<h2>Training curve</h2>", "pose": "<h2>Held-out poses, pictures</h2>"}
    for kind in ("budget", "train", "curve", "pose"):
        for figure in figures:
            if figure["kind"] != kind:
                continue
            if kind in headings and figure is next(f for f in figures if f["kind"] == kind):
                parts.append(headings[kind])
            parts.append("<figure><img src='%s' alt='%s'><figcaption>%s</figcaption></figure>"
                         % (html.escape(figure["src"]), html.escape(figure["alt"]),
                            figure["caption"]))
    parts.append("</body></html>")
    temp = path + ".tmp"
    with open(temp, "w") as f:
        f.write("\n".join(parts) + "\n")
    os.replace(temp, path)


# ---------------------------------------------------------------- main


def picture_link(split, pose):
    """The page's relative link to a pose's picture: the name quoted (a ':' would read as a
    scheme, a '#' as a fragment)."""
    return "images/%s/%s.png" % (split, urllib.parse.quote(pose))


def non_negative_int(text):
    """argparse's type of a count (--training_pictures): an integer, 0 or more. Anything
    else is a bad argument: argparse prints the usage and this message and exits 2."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError("'%s' is not an integer" % text)
    if value < 0:
        raise argparse.ArgumentTypeError("must be 0 or more, not %d" % value)
    return value


def read_inputs(args):
    """Reads and checks every file the page and its pictures need (an InputError naming
    the file otherwise), before anything is written: evaluation.csv, evaluation.md, the
    held-out poses' surfaces and error fields, the training poses' budget, the model's
    neutral, poses and logs. Returns them as a dict for write_report."""
    evaluation = args.evaluation
    rows = read_evaluation_csv(os.path.join(evaluation, "evaluation.csv"))
    inputs = {"rows": rows, "notes": [], "held_out": [], "training": [], "curves": [],
              "markdown": read_evaluation_markdown(os.path.join(evaluation, "evaluation.md"))}
    notes = inputs["notes"]

    neutral = None
    if args.model:
        neutral_path = os.path.join(args.model, "neutral.obj")
        if os.path.exists(neutral_path):
            neutral, _ = read_obj(neutral_path)
    for pose in ordered_poses(rows, "test"):
        target_path = os.path.join(evaluation, "fitted", pose + "_target.obj")
        if not os.path.exists(target_path):
            notes.append("No pictures of %s: %s is missing (aqs_evaluate --write_fields)."
                         % (pose, target_path))
            continue
        target, triangles = read_obj(target_path)
        surfaces, errors = {"target": target}, {}
        for method in METHODS + ["floor"]:
            obj = os.path.join(evaluation, "fitted", "%s_%s.obj" % (pose, method))
            ply = os.path.join(evaluation, "fields", "%s_%s.ply" % (pose, method))
            if not (os.path.exists(obj) and os.path.exists(ply)):
                continue
            surfaces[method], method_triangles = read_obj(obj)
            errors[method] = read_ply_values(ply)
            for path, count in ((obj, len(surfaces[method])), (ply, len(errors[method]))):
                if count != len(target):
                    raise InputError("%s: %d vertices, the pose has %d" %
                                     (path, count, len(target)))
        inputs["held_out"].append({
            "pose": pose, "target": target, "triangles": triangles, "surfaces": surfaces,
            "errors": errors, "mask": parse_vertex_ranges(args.error_vertices, len(target)),
            "neutral": neutral if neutral is not None and len(neutral) == len(target) else None})

    # The training poses with the largest trained error: where their error comes from.
    errors_path = os.path.join(evaluation, "budget", "training_errors.bin")
    train_poses = ordered_poses(rows, "train")
    if args.model and os.path.exists(errors_path) and train_poses:
        train_stats = {(r["method"], r["pose"]): r for r in rows if r["split"] == "train"}
        matrix = read_matrix(errors_path)
        if matrix.shape[1] != 3 * len(train_poses):
            raise InputError("%s: %d columns, expected 3 per training pose (%d)"
                             % (errors_path, matrix.shape[1], len(train_poses)))
        neutral_path = os.path.join(args.model, "neutral.obj")
        _, triangles = read_obj(neutral_path)
        if len(triangles) and triangles.max() >= matrix.shape[0]:
            raise InputError("%s: its faces refer to vertex %d, %s has %d rows (vertices)"
                             % (neutral_path, triangles.max() + 1, errors_path,
                                matrix.shape[0]))
        worst = sorted(range(len(train_poses)), key=lambda p: -train_stats.get(
            ("physics", train_poses[p]), {"mean": 0.0})["mean"])[:args.training_pictures]
        for p in worst:
            pose_path = os.path.join(args.model, "poses", "%04d.bin" % p)
            target = read_matrix(pose_path).T
            if target.shape[1] != 3:
                raise InputError("%s: %d rows, expected 3 (x, y, z)" % (pose_path,
                                                                        target.shape[1]))
            if len(target) != matrix.shape[0]:
                raise InputError("%s: %d vertices, the evaluation has %d" % (
                    pose_path, len(target), matrix.shape[0]))
            inputs["training"].append({
                "pose": train_poses[p], "target": target, "triangles": triangles,
                "errors": {"floor": matrix[:, 3 * p], "pretrain": matrix[:, 3 * p + 1],
                           "physics": matrix[:, 3 * p + 2]},
                "mask": parse_vertex_ranges(args.error_vertices, len(target)),
                "stats": train_stats})

    if args.model:
        log_path = os.path.join(args.model, "train", "log.csv")
        if os.path.exists(log_path):
            log = read_training_log(log_path)
            if log.get("iteration"):
                inputs["curves"].append(("training", log_path, log, read_embedding_floor(
                    os.path.join(args.model, "poses.txt"))))
        else:
            notes.append("No training curve: %s is missing." % log_path)
        pretrain_path = os.path.join(args.model, "pretrain", "log.csv")
        if os.path.exists(pretrain_path):
            log = read_pretraining_log(pretrain_path)
            if log.get("iteration"):
                inputs["curves"].append(("pretraining", pretrain_path, log, None))
    return inputs


def write_report(args, inputs):
    """Draws the pictures into a temporary folder in images/, then replaces the earlier
    pictures with them (the split folders' PNG files removed, so that a pose no longer
    evaluated leaves none) and writes index.html (through a temporary file): a failure
    while drawing leaves the earlier page and its pictures as they were."""
    global DECIMALS
    rows, notes = inputs["rows"], inputs["notes"]
    DECIMALS = table_decimals(rows)
    output = args.output or args.evaluation
    images = os.path.join(output, "images")
    os.makedirs(images, exist_ok=True)
    staging = tempfile.mkdtemp(prefix=".new-", dir=images)
    figures, written = [], []
    try:
        for split in ("held_out", "training"):
            os.mkdir(os.path.join(staging, split))
        stats = {(r["method"], r["pose"]): r for r in rows if r["split"] == "test"}
        for item in inputs["held_out"]:
            pose, surfaces = item["pose"], item["surfaces"]
            name = os.path.join("held_out", pose + ".png")
            vmax = pose_sheet(os.path.join(staging, name), pose, surfaces, item["errors"],
                              item["neutral"], item["triangles"], item["mask"], stats)
            written.append(name)
            shown = ", ".join(METHOD_NAMES[m] for m in METHODS + ["floor"] if m in surfaces)
            figures.append({"kind": "pose", "src": picture_link("held_out", pose), "alt": pose,
                            "caption":
                            "<b>%s</b> (held out), front view. Top: the pose and the surfaces "
                            "of %s. Bottom: each one's distance to the pose per vertex, drawn "
                            "on the pose, on one scale from 0 to %s (the 98th percentile of "
                            "the methods' errors; larger values are yellow)%s; first column: "
                            "the neutral face's distance (where the pose moves). Grey: "
                            "vertices not measured."
                            % (html.escape(pose), shown, number(vmax),
                               "" if "floor" not in surfaces else
                               "; floor: the pose's own volumetric target simulated"), })

        for item in inputs["training"]:
            pose = item["pose"]
            name = os.path.join("training", pose + ".png")
            vmax, shown = training_sheet(os.path.join(staging, name), pose, item["target"],
                                         item["errors"], item["triangles"], item["mask"],
                                         item["stats"])
            written.append(name)
            figures.append({"kind": "train", "src": picture_link("training", pose), "alt": pose,
                            "caption":
                            "<b>%s</b> (training pose, one of the %d with the largest trained "
                            "error): where its error comes from. Per vertex, on the pose, "
                            "on one scale from 0 to %s: %s." % (
                                html.escape(pose), len(inputs["training"]), number(vmax),
                                ", ".join(shown))})

        if budget_chart(os.path.join(staging, "budget.png"), rows):
            written.append("budget.png")
            figures.append({"kind": "budget", "src": "images/budget.png", "alt": "error budget",
                            "caption": "Mean vertex error per pose. Training poses: the floor "
                            "(the pose's volumetric target simulated), after pre-training, the "
                            "trained physics model, and the baselines. Held-out poses: the "
                            "neutral face (no motion), the floor, the physics model's fit and "
                            "the baselines' (dark bars below the grey one: better than not "
                            "moving at all)."})

        for kind, log_path, log, floor in inputs["curves"]:
            if kind == "training":
                training_curve(os.path.join(staging, "training_curve.png"), log, floor)
                written.append("training_curve.png")
                first, last = log["mean_surface_error"][0], log["mean_surface_error"][-1]
                figures.append({"kind": "curve", "src": "images/training_curve.png",
                                "alt": "training curve", "caption":
                                "End-to-end training (%s): mean surface error over the "
                                "training poses and all surface vertices, %s at iteration 0 "
                                "(after pre-training and the first latent refit, where "
                                "training has one) &rarr; %s after %d iterations, and the loss "
                                "(right axis)%s." % (
                                    html.escape(log_path), number(first), number(last),
                                    int(log["iteration"][-1]),
                                    "" if floor is None else "; dashed: the volumetric targets' "
                                    "embedding floor over the same vertices, %s" % number(floor))})
            else:
                pretraining_curve(os.path.join(staging, "pretraining_curve.png"), log)
                written.append("pretraining_curve.png")
                figures.append({"kind": "curve", "src": "images/pretraining_curve.png",
                                "alt": "pre-training curve", "caption":
                                "Pre-training (%s): the loss (actuation error and "
                                "regularizers) from %s to %s in %d iterations, %s s." % (
                                    html.escape(log_path), "%.4g" % log["loss"][0],
                                    "%.4g" % log["loss"][-1], int(log["iteration"][-1]),
                                    number(log["seconds"][-1], 1))})

        # Every picture is drawn: out with the earlier ones, in with these.
        for split in ("held_out", "training"):
            folder = os.path.join(images, split)
            os.makedirs(folder, exist_ok=True)
            for name in os.listdir(folder):
                if name.endswith(".png"):
                    os.remove(os.path.join(folder, name))
        for name in written:
            os.replace(os.path.join(staging, name), os.path.join(images, name))
            print("evaluation_report: wrote %s" % os.path.join(images, name))
    finally:
        shutil.rmtree(staging, ignore_errors=True)

    title = "Evaluation of %s" % (args.model or args.evaluation)
    index = os.path.join(output, "index.html")
    write_html(index, title, rows, figures, notes, inputs["markdown"])
    print("evaluation_report: wrote %s" % index)


def main(argv):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--evaluation", required=True, help="aqs_evaluate's --output_dir")
    parser.add_argument("--model", default="", help="the model directory (training curve, "
                        "neutral surface)")
    parser.add_argument("--output", default="", help="where to write (default: --evaluation)")
    # A negative count is a bad argument: argparse exits 2 (a slice [:-1] would draw all
    # training poses but one).
    parser.add_argument("--training_pictures", type=non_negative_int, default=3,
                        help="error-budget pictures of this many training poses (those "
                        "with the largest trained error; 0 or more)")
    parser.add_argument("--error_vertices", default="",
                        help="the vertices the errors are measured on, as aqs_evaluate's "
                        "--error_vertices (others are grey in error maps)")
    args = parser.parse_args(argv)
    import_plotting()

    # Every input is read and checked before anything is written: a mistyped --evaluation
    # or a malformed file leaves the output folder as it was.
    inputs = read_inputs(args)
    try:
        write_report(args, inputs)
    except OSError as e:
        raise InputError("%s: cannot be written (%s)" % (e.filename or args.output or
                                                         args.evaluation, e.strerror or e))
    return 0


if __name__ == "__main__":
    try:
        sys.exit(main(sys.argv[1:]))
    except InputError as e:
        sys.stderr.write("evaluation_report.py: %s\n" % e)
        sys.exit(1)
