"""A mapper's models and their figures: `colmap model_analyzer` (registered
images, points, track length, reprojection error), `colmap model_evaluator`
(metrics against ground truth), the registered images' names, and the image
count of a database."""

import json
import os
import re
import sqlite3
import struct
import tempfile

from glomap_bench import run

# model_evaluator's option for the pose AUC thresholds (its default is
# 1,3,5,10); passed only when its -h lists it.
POSE_THRESHOLDS_OPTION = "--pose_thresholds"
# model_evaluator's default of --max_position_error_fraction: its
# cameras_beyond counts the registered cameras farther than this fraction of
# the scene size from ground truth.
BEYOND_FRACTION = 0.05


def is_model_dir(path):
    """Whether path holds a COLMAP model (binary or text)."""
    for ext in (".bin", ".txt"):
        if all(os.path.isfile(os.path.join(path, name + ext))
               for name in ("cameras", "images", "points3D")):
            return True
    return False


def analyze_model(colmap, path):
    """{"registered", "points", "mean_track_length", "mean_reproj_error_px"}
    of `colmap model_analyzer`; None if it fails."""
    code, text = run.capture([colmap, "model_analyzer", "--path", path])
    if code != 0:
        return None

    def number(label):
        match = re.search(label + r":\s*([-0-9.eE+]+)", text)
        return float(match.group(1)) if match else None

    registered = number("Registered images")
    return {
        "registered": int(registered) if registered is not None else 0,
        "points": number("Points"),
        "mean_track_length": number("Mean track length"),
        "mean_reproj_error_px": number("Mean reprojection error"),
    }


def pick_model(colmap, output_path):
    """The model with most registered images in output_path or its
    sub-folders; (path, analysis) or (None, None)."""
    candidates = []
    if is_model_dir(output_path):
        candidates.append(output_path)
    if os.path.isdir(output_path):
        for name in sorted(os.listdir(output_path)):
            sub = os.path.join(output_path, name)
            if os.path.isdir(sub) and is_model_dir(sub):
                candidates.append(sub)
    best_path, best = None, None
    for path in candidates:
        analysis = analyze_model(colmap, path)
        if analysis and (best is None
                         or analysis["registered"] > best["registered"]):
            best_path, best = path, analysis
    return best_path, best


def evaluate_model(colmap, model_path, gt_path, json_path,
                   position_thresholds, pose_thresholds=None):
    """(metrics of `colmap model_evaluator`, None), or (None, its last
    output line as a list) if it fails."""
    command = [colmap, "model_evaluator", "--input_path", model_path,
               "--gt_path", gt_path, "--json_path", json_path]
    if position_thresholds:
        command += ["--position_thresholds", position_thresholds]
    if pose_thresholds:
        command += [POSE_THRESHOLDS_OPTION, pose_thresholds]
    code, text = run.capture(command)
    if code != 0 or not os.path.exists(json_path):
        return None, text.strip().splitlines()[-1:] or ["no output"]
    with open(json_path) as f:
        return json.load(f), None


def evaluator_pose_thresholds(colmap, thresholds):
    """The --pose_thresholds value for thresholds (degrees, strings) if the
    model_evaluator of `colmap` has that option (else None: it reports
    1/3/5/10 only)."""
    code, text = run.capture([colmap, "model_evaluator", "-h"])
    if POSE_THRESHOLDS_OPTION in text:
        return ",".join(thresholds)
    return None


def count_db_images(database):
    """Images in a database (a copy: sqlite may touch the file); None if it
    cannot be read."""
    try:
        connection = sqlite3.connect(database)
        try:
            return connection.execute(
                "SELECT COUNT(*) FROM images").fetchone()[0]
        finally:
            connection.close()
    except sqlite3.Error:
        return None


def read_image_names_bin(path):
    """Image names of a COLMAP images.bin."""
    names = []
    with open(path, "rb") as f:
        (count,) = struct.unpack("<Q", f.read(8))
        for _ in range(count):
            # image id, qvec, tvec, camera id
            if len(f.read(4 + 7 * 8 + 4)) != 64:
                raise ValueError("truncated " + path)
            name = bytearray()
            while True:
                char = f.read(1)
                if not char:
                    raise ValueError("truncated " + path)
                if char == b"\0":
                    break
                name += char
            (num_points,) = struct.unpack("<Q", f.read(8))
            f.seek(24 * num_points, os.SEEK_CUR)
            names.append(name.decode("utf-8"))
    return names


def read_image_names_txt(path):
    """Image names of a COLMAP images.txt: after the comments, two lines per
    image (the second, its 2-D points, may be empty)."""
    with open(path, errors="replace") as f:
        lines = f.read().split("\n")
    first = 0
    while first < len(lines) and lines[first].startswith("#"):
        first += 1
    names = []
    for line in lines[first::2]:
        fields = line.strip().split(None, 9)
        if len(fields) == 10:
            names.append(fields[9])
    return names


def read_image_names(colmap, model_path):
    """Set of the registered images' names of a model; None if unreadable.
    A binary model is read directly, or else converted with `colmap
    model_converter --output_type TXT` into a temporary folder."""
    if not model_path:
        return None
    text_path = os.path.join(model_path, "images.txt")
    if os.path.isfile(text_path):
        return set(read_image_names_txt(text_path))
    bin_path = os.path.join(model_path, "images.bin")
    if not os.path.isfile(bin_path):
        return None
    try:
        return set(read_image_names_bin(bin_path))
    except (OSError, ValueError, struct.error, UnicodeDecodeError):
        pass
    with tempfile.TemporaryDirectory() as tmp:
        code, _ = run.capture([colmap, "model_converter", "--input_path",
                               model_path, "--output_path", tmp,
                               "--output_type", "TXT"])
        text_path = os.path.join(tmp, "images.txt")
        if code == 0 and os.path.isfile(text_path):
            return set(read_image_names_txt(text_path))
    return None
