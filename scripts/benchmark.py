#!/usr/bin/env python3
"""Side-by-side benchmark of our `colmap global_mapper` and COLMAP's stock
incremental `mapper` (and, with --reference_colmap, another COLMAP build's
`global_mapper`, e.g. upstream COLMAP 4.x).

For every dataset folder (a `database.db`, optionally an `images/` folder and a
ground-truth model in `gt/`), the mappers run one after the other, each run on
its own copy of the database in a fresh output folder. With --repeats N every
mapper runs N times per input, alternating (ours, stock, reference, ours,
stock, ...) so that a change of the machine's load hits all of them alike; the
table shows the median wall time with its spread (min-max) and the medians of
the other figures. Recorded per run: wall time (and, for the global
mapper, the time of each stage from its log lines `Stage <name>: <seconds> s`),
peak memory, registered images, mean reprojection error and mean track length
(`colmap model_analyzer`), and the ground-truth metrics (`colmap
model_evaluator`: pairwise pose AUC at 0.5/1/3/5/10 degrees -- 0.5 only
with an evaluator that has --pose_thresholds --, camera position errors).

With --seeds, our global mapper runs once per seed
(`--GlobalMapper.random_seed`); the stock mapper runs once per dataset. The
main table then shows, for ours, the median over all its runs (seeds x
repeats) and the spread.

The reports start with the provenance: the exact command (shell-quoted
sys.argv) and its working folder, the source commit (+dirty with changes to
tracked files), build type (CMAKE_BUILD_TYPE of the CMakeCache.txt beside the
binary's bin/ folder) and path of each binary, and the machine (CPU model,
cores, memory, kernel).

Synthetic scenes (--synthetic N) are cached under <output_dir>/scenes/ with a
stamp file (the generator's options and the sha256 of make_synthetic_scene);
a scene whose stamp differs is generated anew.

A "bars" table checks every run of ours against the acceptance bars of issue
10: all images registered; AUC@3 at least the better of the reference mappers'
figures in the dataset's README minus 0.5; no registered camera farther than
5% of the scene size from ground truth (`cameras_beyond` of model_evaluator);
KITTI_sequence_1 a mean position error of at most 0.02 m. On a dataset whose
README has the stock `mapper` but no upstream `global_mapper` figures
(dino-363), or one named by --stock_relative, the bars are relative to the
stock mapper of the same benchmark run instead: every image it registers is
registered by ours, AUC@3 at most 1 point below it, at most half its time
(the README's stock figures stand in when the stock mapper was skipped).

Camera setups (--camera_setup): the databases as they are ("database"), or
rewritten by scripts/rewrite_cameras.py into <output_dir>/camera_setups/ the
way a user's project often has them: one shared camera ("shared"), one camera
per image without a focal prior ("per_image", feature_extractor's default
without EXIF), or one per image with an EXIF-like focal --exif_error off the
ground truth ("per_image_exif"), each of --camera_model. Every mapper runs on
the same rewritten copy; the main table's "cameras" column names the setup,
and the bars are judged against the stock mapper of the same run (the
READMEs' reference figures are for the databases as they are).

Writes to --output_dir: results.json, results.md (Markdown tables),
runtime_per_stage.png and auc_per_dataset.png (gnuplot). With --readme, also
replaces the benchmark section of the README and copies the AUC plot next to
it.

Regenerate the README's figures with:
    python3 scripts/benchmark.py --seeds 0,1,2,3,4 --readme README.md

Check the script's own logic (no colmap needed): --self_test.

Only the Python standard library is used (gnuplot draws the plots).
"""

import argparse
import datetime
import hashlib
import json
import os
import platform
import re
import shlex
import shutil
import sqlite3
import statistics
import struct
import subprocess
import sys
import tempfile
import time

REPO_DIR = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DEFAULT_COLMAP = os.path.join(REPO_DIR, "build", "bin", "colmap")
DEFAULT_OUTPUT = os.path.join(REPO_DIR, "build", "benchmark")
DEFAULT_DATASETS = os.path.join(os.path.dirname(REPO_DIR), "shared", "datasets")
# Pose AUC thresholds in degrees (upstream's benchmark reports 0.5/1/5/10).
AUC_THRESHOLDS = ["0.5", "1", "3", "5", "10"]
# model_evaluator's option for the pose AUC thresholds (its default is
# 1,3,5,10); passed only when its -h lists it.
POSE_THRESHOLDS_OPTION = "--pose_thresholds"
MAPPERS = {
    "global": "global_mapper",
    "incremental": "mapper",
    "reference": "global_mapper",
}
# Order of the mappers within one repeat, and their labels.
MAPPER_ORDER = ["global", "incremental", "reference"]
MAPPER_LABELS = {
    "global": "ours `global_mapper`",
    "incremental": "COLMAP 3.8 `mapper`",
    "reference": "reference `global_mapper`",
}
# Runs per mapper and input without --repeats.
DEFAULT_REPEATS = 3
DEFAULT_SYNTHETIC_REPEATS = 1
# Stamp of a cached synthetic scene, inside its folder.
SCENE_STAMP = "benchmark_stamp.json"
# Bar colours of the global mapper's stages in the runtime plot.
STAGE_COLORS = ["#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd",
                "#8c564b", "#e377c2", "#bcbd22", "#17becf", "#393b79",
                "#637939", "#843c39"]
# The README section that --readme replaces.
README_BEGIN = "<!-- benchmark:begin -->"
README_END = "<!-- benchmark:end -->"

# Acceptance bars (issue 10).
# AUC@3 at least the better reference mapper's figure minus this.
AUC_BAR_MARGIN = 0.5
# Stock-relative datasets (dino-363): AUC@3 at least the stock mapper's minus
# this, in at most this fraction of its wall time.
STOCK_AUC_MARGIN = 1.0
STOCK_TIME_RATIO = 0.5
# model_evaluator's default of --max_position_error_fraction; the bar allows
# no registered camera farther than this fraction of the scene size.
BEYOND_FRACTION = 0.05
# Per-dataset maximum mean position error, in ground-truth units.
MAX_POSITION_ERROR = {"KITTI_sequence_1": 0.02}
# Value of a "not applicable" bar (True: met, False: failed, None: could not
# be checked).
NOT_APPLICABLE = "n/a"

# The global mapper's last line, e.g. "Global mapper finished in 12.3 s: 1
# model(s), 47 of 47 images registered; pose verification re-placed 0 and
# left out 0 image(s)." (older binaries end after "registered").
FINISH_RE = re.compile(
    r"Global mapper finished in\s+([0-9.]+)\s*s:\s*(\d+)\s+model\(s\),\s*"
    r"(\d+)\s+of\s+(\d+)\s+images registered"
    r"(?:;\s*pose verification re-placed\s+(\d+)\s+and left out\s+(\d+))?")

# Tolerant match of the global mapper's stage lines, e.g.
# "Stage rotation_averaging: 1.23 s (...)" or "Stage Rotation averaging : 1.2s"
# possibly behind a glog prefix.
STAGE_RE = re.compile(
    r"Stage\s+[\"'`]?([A-Za-z][\w \-/]*?)[\"'`]?\s*:\s*([0-9]+(?:\.[0-9]*)?"
    r"(?:[eE][-+]?[0-9]+)?)\s*s\b")


def log(message):
    print(message, flush=True)


def is_model_dir(path):
    for ext in (".bin", ".txt"):
        if all(os.path.isfile(os.path.join(path, name + ext))
               for name in ("cameras", "images", "points3D")):
            return True
    return False


def run_measured(command, log_path, timeout_s):
    """Runs `command` with stdout+stderr to log_path. Returns (exit code, wall
    seconds, peak RSS in MB or None, whether it timed out)."""
    time_path = log_path + ".time"
    gnu_time = shutil.which("time") or (
        "/usr/bin/time" if os.path.exists("/usr/bin/time") else None)
    if gnu_time:
        wrapped = [gnu_time, "-v", "-o", time_path] + command
    else:
        # Fallback without GNU time: a fresh Python process whose children
        # are only this command, so RUSAGE_CHILDREN is this run's peak.
        wrapped = [sys.executable, "-c",
                   "import resource, subprocess, sys\n"
                   "code = subprocess.call(sys.argv[2:])\n"
                   "rss = resource.getrusage(resource.RUSAGE_CHILDREN)"
                   ".ru_maxrss\n"
                   "open(sys.argv[1], 'w').write("
                   "'Maximum resident set size (kbytes): %d\\n' % rss)\n"
                   "sys.exit(code)\n",
                   time_path] + command
    timed_out = False
    start = time.monotonic()
    with open(log_path, "w") as log_file:
        log_file.write("$ " + " ".join(command) + "\n")
        log_file.flush()
        process = subprocess.Popen(wrapped, stdout=log_file,
                                   stderr=subprocess.STDOUT)
        try:
            code = process.wait(timeout=timeout_s)
        except subprocess.TimeoutExpired:
            process.kill()
            code = process.wait()
            timed_out = True
    wall_s = time.monotonic() - start
    peak_mb = None
    if os.path.exists(time_path):
        with open(time_path) as f:
            match = re.search(r"Maximum resident set size \(kbytes\):\s*(\d+)",
                              f.read())
        if match:
            peak_mb = int(match.group(1)) / 1024.0
    return code, wall_s, peak_mb, timed_out


def capture(command):
    """Runs a short command; returns (exit code, stdout+stderr)."""
    result = subprocess.run(command, stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, text=True)
    return result.returncode, result.stdout


def analyze_model(colmap, path):
    code, text = capture([colmap, "model_analyzer", "--path", path])
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
    command = [colmap, "model_evaluator", "--input_path", model_path,
               "--gt_path", gt_path, "--json_path", json_path]
    if position_thresholds:
        command += ["--position_thresholds", position_thresholds]
    if pose_thresholds:
        command += [POSE_THRESHOLDS_OPTION, pose_thresholds]
    code, text = capture(command)
    if code != 0 or not os.path.exists(json_path):
        return None, text.strip().splitlines()[-1:] or ["no output"]
    with open(json_path) as f:
        return json.load(f), None


def evaluator_pose_thresholds(colmap):
    """The --pose_thresholds value for AUC_THRESHOLDS if the model_evaluator
    of `colmap` has that option (else None: it reports 1/3/5/10 only)."""
    code, text = capture([colmap, "model_evaluator", "-h"])
    if POSE_THRESHOLDS_OPTION in text:
        return ",".join(AUC_THRESHOLDS)
    return None


def parse_stages(log_path):
    stages = []
    with open(log_path, errors="replace") as f:
        for line in f:
            match = STAGE_RE.search(line)
            if match:
                name = match.group(1).strip().replace(" ", "_").lower()
                stages.append([name, float(match.group(2))])
    return stages


def parse_finish(log_path):
    """The counts of the global mapper's final log line (empty if absent)."""
    found = {}
    with open(log_path, errors="replace") as f:
        for line in f:
            match = FINISH_RE.search(line)
            if match:
                found = {"mapper_seconds": float(match.group(1)),
                         "models": int(match.group(2))}
                if match.group(5) is not None:
                    found["replaced_images"] = int(match.group(5))
                    found["left_out_images"] = int(match.group(6))
    return found


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
        code, _ = capture([colmap, "model_converter", "--input_path",
                           model_path, "--output_path", tmp,
                           "--output_type", "TXT"])
        text_path = os.path.join(tmp, "images.txt")
        if code == 0 and os.path.isfile(text_path):
            return set(read_image_names_txt(text_path))
    return None


def parse_number(cell):
    """The leading number of a table cell ("8.7s", "90.0"); None for "–",
    "failed", ... ."""
    match = re.match(r"\s*(-?[0-9]+(?:\.[0-9]*)?)", cell)
    return float(match.group(1)) if match else None


def parse_reference_text(text):
    """The reference mappers' figures of a dataset README's table:
    {"incremental": row, "upstream": row} (either may be missing), each row
    {"label", "auc@3", "registered": [n, total] or None, "wall_time_s"}.
    Rows of this project's own runs are ignored. None without such rows."""
    rows = {}
    columns = None
    for line in text.splitlines():
        line = line.strip()
        if not line.startswith("|"):
            columns = None  # A table ends.
            continue
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        normalized = [c.replace("\\`", "`").replace("°", "").lower()
                      for c in cells]
        if columns is None:
            if any(c.replace(" ", "") == "auc@3" for c in normalized):
                columns = {c.replace(" ", ""): k
                           for k, c in enumerate(normalized)}
            continue
        if all(re.fullmatch(r":?-+:?", c) for c in cells if c):
            continue  # The separator row.
        label = cells[0].replace("\\`", "`")
        lower = label.lower()
        if "this project" in lower:
            continue
        if "incremental" in lower and "3.8" in lower:
            key = "incremental"
        elif "global_mapper" in lower and ("upstream" in lower
                                           or "4.1" in lower):
            key = "upstream"
        else:
            continue

        def cell(name):
            k = columns.get(name)
            return cells[k] if k is not None and k < len(cells) else ""

        registered = re.match(r"\s*(\d+)\s*/\s*(\d+)", cell("registered"))
        rows[key] = {
            "label": label,
            "auc@3": parse_number(cell("auc@3")),
            "registered": [int(registered.group(1)), int(registered.group(2))]
            if registered else None,
            "wall_time_s": parse_number(cell("walltime")),
        }
    return rows or None


def parse_reference(dataset):
    path = os.path.join(dataset, "README.md")
    if not os.path.isfile(path):
        return None
    with open(path, errors="replace") as f:
        return parse_reference_text(f.read())


def last_lines(path, count=3):
    with open(path, errors="replace") as f:
        lines = [line.rstrip() for line in f if line.strip()]
    return lines[-count:]


# --------------------------------------------------------------------------
# Provenance
# --------------------------------------------------------------------------

def format_command(argv, cwd):
    """The exact command (sys.argv, shell-quoted) and the folder it ran in:
    `python3 <argv>` for a script path, argv itself otherwise."""
    words = list(argv)
    if words and words[0].endswith(".py"):
        words = ["python3"] + words
    return shlex.join(words), cwd


def git_commit(path):
    """`git rev-parse --short HEAD` of the tree at path, with "+dirty" when
    `git status --porcelain` lists changes to tracked files; None if it is
    not a git tree."""
    try:
        head = subprocess.run(["git", "-C", path, "rev-parse", "--short",
                               "HEAD"], stdout=subprocess.PIPE,
                              stderr=subprocess.DEVNULL, text=True)
        if head.returncode != 0 or not head.stdout.strip():
            return None
        status = subprocess.run(["git", "-C", path, "status", "--porcelain",
                                 "--untracked-files=no"],
                                stdout=subprocess.PIPE,
                                stderr=subprocess.DEVNULL, text=True)
    except OSError:
        return None
    dirty = status.returncode != 0 or bool(status.stdout.strip())
    return head.stdout.strip() + ("+dirty" if dirty else "")


def parse_cmake_cache(text):
    """(CMAKE_BUILD_TYPE or "unknown", CMAKE_HOME_DIRECTORY or None) of a
    CMakeCache.txt's text."""
    build = re.search(r"^CMAKE_BUILD_TYPE(?::\w+)?=(.*)$", text, re.M)
    home = re.search(r"^CMAKE_HOME_DIRECTORY(?::\w+)?=(.*)$", text, re.M)
    build = build.group(1).strip() if build else ""
    return build or "unknown", home.group(1).strip() if home else None


def binary_info(binary, source_dir=None):
    """Path, build type and source commit of a colmap binary: the build type
    from <build>/CMakeCache.txt for <build>/bin/<binary> ("unknown" without
    one); the commit of source_dir, else of the cache's source folder."""
    binary = os.path.abspath(binary)
    cache = os.path.join(os.path.dirname(os.path.dirname(binary)),
                         "CMakeCache.txt")
    build_type, home = "unknown", None
    try:
        with open(cache, errors="replace") as f:
            build_type, home = parse_cmake_cache(f.read())
    except OSError:
        pass
    source = source_dir or home
    return {"path": binary, "build_type": build_type, "source": source,
            "commit": git_commit(source) if source else None}


def machine_info():
    """CPU model, core count, total memory (GiB) and kernel."""
    info = {"cpu": platform.processor() or platform.machine(),
            "cores": os.cpu_count(), "memory_gib": None,
            "kernel": "%s %s" % (platform.system(), platform.release())}
    try:
        with open("/proc/cpuinfo") as f:
            match = re.search(r"model name\s*:\s*(.+)", f.read())
            if match:
                info["cpu"] = match.group(1).strip()
    except OSError:
        pass
    try:
        with open("/proc/meminfo") as f:
            match = re.search(r"MemTotal:\s*(\d+)\s*kB", f.read())
            if match:
                info["memory_gib"] = int(match.group(1)) / 1024.0 ** 2
    except OSError:
        pass
    return info


def provenance_lines(meta):
    """The lines that head the reports: command, source and binaries,
    machine, runs."""
    lines = ["Command: `%s` (in `%s`)." % (meta["command"], meta["cwd"])]
    binaries = []
    for key, label in (("colmap", "ours"), ("reference_colmap",
                                            "reference")):
        info = meta.get(key)
        if not info:
            continue
        text = "%s `%s` (%s" % (label, info["path"], info["build_type"])
        if key != "colmap":
            text += ", source %s" % ("commit %s of `%s`" % (
                info["commit"], info["source"]) if info.get("commit")
                else "unknown")
        binaries.append(text + ")")
    ours = meta.get("colmap") or {}
    lines.append("Source: commit %s of `%s`; binaries: %s." % (
        ours.get("commit") or "unknown", ours.get("source") or "?",
        "; ".join(binaries)))
    machine = meta["machine"]
    lines.append("Machine: %s, %s cores, %s GiB memory, %s; %s." % (
        machine["cpu"], machine["cores"],
        fmt(machine.get("memory_gib"), 1), machine["kernel"], meta["date"]))
    if meta.get("camera_setup"):
        lines.append("Cameras: %s." % meta["camera_setup"])
    repeats = meta.get("repeats") or {}
    if repeats:
        names = {"global": "ours", "incremental": "stock",
                 "reference": "reference"}
        order = [names[m] for m in meta.get("mappers") or MAPPER_ORDER]
        lines.append("Runs per mapper and input: %s, %s, each from a fresh "
                     "output folder%s." % (
                         ", ".join("%d for %s" % (n, what) for what, n in
                                   sorted(repeats.items())),
                         "alternating between the mappers (%s, ...)" %
                         ", ".join(order + order[:1]) if len(order) > 1
                         else "one mapper",
                         "; ours once per seed (%s) in each" % ",".join(
                             str(x) for x in meta["seeds"])
                         if len(meta.get("seeds") or []) > 1 else ""))
    return lines


# --------------------------------------------------------------------------
# Datasets and runs
# --------------------------------------------------------------------------

def find_datasets(paths):
    datasets = []
    for path in paths:
        path = os.path.abspath(path)
        if os.path.isfile(os.path.join(path, "database.db")):
            datasets.append(path)
        elif os.path.isdir(path):
            # A folder of datasets.
            for name in sorted(os.listdir(path)):
                sub = os.path.join(path, name)
                if os.path.isfile(os.path.join(sub, "database.db")):
                    datasets.append(sub)
    return datasets


CAMERA_SETUPS = ("database", "shared", "per_image", "per_image_exif")


def camera_setup_label(setup, model, exif_error):
    """The main table's "cameras" cell of a setup."""
    if setup == "database":
        return "as in the database"
    where = "shared" if setup == "shared" else "per image"
    prior = ("EXIF %g%% off" % (100 * exif_error) if setup == "per_image_exif"
             else "no prior")
    return "%s %s, %s" % (where, model, prior)


def camera_setup_dataset(args, dataset):
    """A dataset folder whose database.db is `dataset`'s rewritten to
    --camera_setup (scripts/rewrite_cameras.py; the input is only copied),
    with gt/ and images/ linked; `dataset` itself for "database"."""
    if args.camera_setup == "database":
        return dataset
    name = os.path.basename(dataset)
    slug = "%s_%s" % (args.camera_setup, args.camera_model)
    target = os.path.join(args.output_dir, "camera_setups", slug, name)
    if os.path.isdir(target):
        shutil.rmtree(target)
    os.makedirs(target)
    command = [sys.executable,
               os.path.join(REPO_DIR, "scripts", "rewrite_cameras.py"),
               "--database_path", os.path.join(dataset, "database.db"),
               "--output_path", os.path.join(target, "database.db"),
               "--camera_mode",
               "shared" if args.camera_setup == "shared" else "per_image",
               "--camera_model", args.camera_model]
    if args.camera_setup == "per_image_exif":
        command += ["--focal", "exif", "--gt_path",
                    os.path.join(dataset, "gt"),
                    "--exif_error", str(args.exif_error)]
    code, text = capture(command)
    if code != 0:
        sys.exit("error: rewriting the cameras of %s failed:\n%s" % (
            dataset, text))
    for sub in ("gt", "images"):
        if os.path.isdir(os.path.join(dataset, sub)):
            os.symlink(os.path.join(dataset, sub), os.path.join(target, sub))
    return target


def synthetic_options(num_images):
    """make_synthetic_scene's options (but --output_path) for a scene of
    num_images images."""
    options = ["--num_images", str(num_images)]
    if num_images > 300:
        # Large scenes: an aerial survey with ground-truth verification (the
        # generator's COLMAP verification would dominate the run).
        options += ["--layout", "grid", "--verification", "ground_truth",
                    "--wrong_match_ratio", "0.3", "--prior_focal_length", "0"]
    return options


def file_sha256(path):
    digest = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def scene_stamp(tool, options):
    """What a cached scene depends on: the generator's options and a
    fingerprint of the generator binary (sha256; size and mtime for the
    reader)."""
    stat = os.stat(tool)
    return {"generator": os.path.abspath(tool), "options": list(options),
            "sha256": file_sha256(tool), "size": stat.st_size,
            "mtime": int(stat.st_mtime)}


def read_stamp(path):
    try:
        with open(path) as f:
            stamp = json.load(f)
        return stamp if isinstance(stamp, dict) else None
    except (OSError, ValueError):
        return None


def stamp_matches(old, new):
    """Whether a cached scene's stamp (None: none) still fits: the same
    options and the same generator binary (by content; its path, size and
    mtime are only for the reader)."""
    return (old is not None and old.get("options") == new["options"]
            and old.get("sha256") == new["sha256"])


def make_synthetic(args, num_images):
    """The folder of a synthetic scene under <output_dir>/scenes/, generated
    unless a cached one has a matching stamp; None if it cannot be made."""
    tool = os.path.join(os.path.dirname(os.path.abspath(args.colmap)),
                        "make_synthetic_scene")
    path = os.path.join(args.output_dir, "scenes", "synthetic_%d" % num_images)
    stamp_path = os.path.join(path, SCENE_STAMP)
    cached = os.path.isfile(os.path.join(path, "database.db"))
    options = synthetic_options(num_images)
    if not os.path.exists(tool):
        if cached:
            log("synthetic scene: %s not found, using the cached %s "
                "unchecked" % (tool, path))
            return path
        log("synthetic scene: %s not found, skipped" % tool)
        return None
    stamp = scene_stamp(tool, options)
    if cached:
        old = read_stamp(stamp_path)
        if stamp_matches(old, stamp):
            log("synthetic scene: cached %s (stamp matches)" % path)
            return path
        log("synthetic scene: %s is stale (%s), generated anew" % (
            path, "no stamp" if old is None else
            "other options" if old.get("options") != options
            else "other generator"))
    if os.path.isdir(path):
        shutil.rmtree(path)
    os.makedirs(path)
    command = [tool, "--output_path", path] + options
    log("synthetic scene: $ " + shlex.join(command))
    code, text = capture(command)
    if code != 0 or not os.path.isfile(os.path.join(path, "database.db")):
        log("synthetic scene: %s failed: %s" %
            (tool, (text.strip().splitlines() or ["no output"])[-1]))
        return None
    # Written last: an interrupted generation leaves no stamp.
    with open(stamp_path, "w") as f:
        json.dump(stamp, f, indent=2)
    return path


def run_schedule(mappers, seeds, repeats):
    """The runs on one input, [(mapper, seed, repeat)]: repeat by repeat,
    the mappers in MAPPER_ORDER (ours once per seed), so that the mappers
    alternate instead of all runs of ours coming first."""
    schedule = []
    for repeat in range(repeats):
        for mapper in MAPPER_ORDER:
            if mapper not in mappers:
                continue
            if mapper == "global":
                schedule += [(mapper, seed, repeat) for seed in seeds]
            else:
                schedule.append((mapper, None, repeat))
    return schedule


def run_dir_name(mapper, seed, repeat=0):
    name = "global_seed%d" % seed if mapper == "global" else mapper
    return name + "_run%d" % (repeat + 1)


def check_reference(binary):
    """Exits with a message unless `binary` is a colmap with global_mapper."""
    if not os.access(binary, os.X_OK) or os.path.isdir(binary):
        sys.exit("error: --reference_colmap %s is not an executable" % binary)
    try:
        code, text = capture([binary, "global_mapper", "-h"])
    except OSError as error:
        sys.exit("error: --reference_colmap %s cannot run: %s" % (binary,
                                                                 error))
    if "not recognized" in text or "--database_path" not in text:
        sys.exit("error: --reference_colmap %s has no `global_mapper` "
                 "command (`%s global_mapper -h` exited with %d: %s); it "
                 "needs a COLMAP build with the global mapper, e.g. upstream "
                 "COLMAP 4.x" % (binary, binary, code, (text.strip()
                                                        .splitlines()
                                                        or ["no output"])[-1]))


def run_one(args, dataset, mapper, seed, index, total, repeat=0, repeats=1):
    """One run; seed: --GlobalMapper.random_seed of ours (None for the
    others); repeat: 0-based, of repeats. Every run starts from a fresh
    folder with its own copy of the database (the original is never opened
    by a mapper: a newer COLMAP may migrate its schema)."""
    name = os.path.basename(dataset)
    command_name = MAPPERS[mapper]
    binary = args.reference_colmap if mapper == "reference" else args.colmap
    work = os.path.join(args.output_dir, "runs", name,
                        run_dir_name(mapper, seed, repeat))
    if os.path.isdir(work):
        shutil.rmtree(work)
    os.makedirs(work)
    database = os.path.join(work, "database.db")
    shutil.copyfile(os.path.join(dataset, "database.db"), database)
    image_path = os.path.join(dataset, "images")
    if not os.path.isdir(image_path):
        # The mappers need an existing folder; without images the models just
        # have no colours.
        image_path = os.path.join(work, "no_images")
        os.makedirs(image_path)
    output_path = os.path.join(work, "sparse")
    os.makedirs(output_path)
    log_path = os.path.join(work, "log.txt")

    record = {"dataset": name, "mapper": mapper, "command": command_name,
              "binary": binary, "status": "ok", "repeat": repeat,
              "camera_setup": camera_setup_label(
                  args.camera_setup, args.camera_model, args.exif_error)}
    if seed is not None:
        record["seed"] = seed
    record["db_images"] = count_db_images(database)
    details = [] if seed is None else ["seed %d" % seed]
    if repeats > 1:
        details.append("run %d/%d" % (repeat + 1, repeats))
    title = ("reference " if mapper == "reference" else "") + command_name + (
        " (%s)" % ", ".join(details) if details else "")
    log("[%d/%d] %s: %s ..." % (index, total, name, title))
    command = [binary, command_name, "--database_path", database,
               "--image_path", image_path, "--output_path", output_path]
    if seed is not None:
        command += ["--GlobalMapper.random_seed", str(seed)]
    code, wall_s, peak_mb, timed_out = run_measured(command, log_path,
                                                    args.timeout)
    record.update({"wall_time_s": round(wall_s, 3), "peak_rss_mb":
                   round(peak_mb, 1) if peak_mb is not None else None,
                   "exit_code": code, "log": log_path})
    if mapper == "global":
        record["stages"] = parse_stages(log_path)
        record.update(parse_finish(log_path))

    model_path, analysis = (None, None)
    if timed_out:
        record["status"] = "failed: timeout after %d s" % args.timeout
    elif code != 0:
        # COLMAP 3.8's mapper exits with an error when it finds no model.
        no_model = pick_model(args.colmap, output_path)[0] is None
        record["status"] = "failed: %sexit %d" % (
            "no model, " if no_model else "", code)
        record["error"] = last_lines(log_path)
    else:
        model_path, analysis = pick_model(args.colmap, output_path)
        if model_path is None and binary != args.colmap:
            # A model our COLMAP 3.8 cannot analyze: the reference's own
            # model_analyzer (the evaluation still uses ours).
            model_path, analysis = pick_model(binary, output_path)
        if model_path is None:
            record["status"] = "failed: no model"
    if model_path is not None:
        record["model_path"] = model_path
        record.update(analysis)
        gt_path = os.path.join(dataset, "gt")
        if is_model_dir(gt_path):
            metrics, error = evaluate_model(
                args.colmap, model_path, gt_path,
                os.path.join(work, "evaluation.json"),
                args.position_thresholds, args.pose_thresholds)
            if metrics is not None:
                record["evaluation"] = metrics
            else:
                record["evaluation_error"] = error

    summary = "%s, %.1f s" % (record["status"], wall_s)
    if peak_mb is not None:
        summary += ", %.0f MB" % peak_mb
    evaluation = record.get("evaluation")
    if evaluation:
        summary += ", %d/%d registered, AUC@3 %.1f" % (
            evaluation["registered"], evaluation["images"],
            evaluation.get("auc@3") or 0.0)
        if evaluation.get("cameras_beyond") is not None:
            summary += ", %d camera(s) beyond %g%% of the scene" % (
                evaluation["cameras_beyond"], 100 * evaluation.get(
                    "cameras_beyond_fraction", BEYOND_FRACTION))
    elif analysis:
        summary += ", %d registered" % analysis["registered"]
    if record.get("replaced_images") is not None:
        summary += ", re-placed %d, left out %d" % (
            record["replaced_images"], record["left_out_images"])
    log("[%d/%d] %s: %s %s" % (index, total, name, title, summary))
    return record


# --------------------------------------------------------------------------
# Reports
# --------------------------------------------------------------------------

def fmt(value, digits=1, suffix=""):
    if value is None:
        return "–"
    return ("%." + str(digits) + "f%s") % (value, suffix)


def fmt_error(value):
    return "–" if value is None else "%.4g" % value


def fmt_span(values, digits=0):
    """"3" or "2–5" (min–max) of the non-None values; "–" if none."""
    values = [v for v in values if v is not None]
    if not values:
        return "–"
    low, high = fmt(min(values), digits), fmt(max(values), digits)
    return low if low == high else low + "–" + high


def fmt_range(values, digits=1):
    """"min–max" of the non-None values, also when equal."""
    values = [v for v in values if v is not None]
    if not values:
        return "–"
    return fmt(min(values), digits) + "–" + fmt(max(values), digits)


def median(values):
    """Median of the non-None values (None if none); an int when the values
    are ints and the median is whole (counts stay counts)."""
    values = [v for v in values if v is not None]
    if not values:
        return None
    result = statistics.median(values)
    if all(isinstance(v, int) for v in values) and result == int(result):
        return int(result)
    return result


def time_spread(runs):
    """(median, min, max) of the wall times of runs (None, None, None for
    none)."""
    times = [r.get("wall_time_s") for r in runs
             if r.get("wall_time_s") is not None]
    if not times:
        return None, None, None
    return statistics.median(times), min(times), max(times)


def median_time_run(runs):
    """The run whose wall time is the median (the lower middle one for an
    even count)."""
    timed = [r for r in runs if r.get("wall_time_s") is not None] or runs
    order = sorted(timed, key=lambda r: r.get("wall_time_s") or 0.0)
    return order[(len(order) - 1) // 2]


def summarize_runs(runs):
    """One record for the runs of one mapper on one dataset (ours: over the
    seeds and repeats): the median of every number over the successful runs
    (wall time included), the maximum of the peak memory, the model of the
    run with the median time, and the runs themselves (for the spread). One
    run: itself."""
    if len(runs) == 1:
        return dict(runs[0], runs=runs)
    ok_runs = [r for r in runs if r["status"] == "ok"]
    pool = ok_runs or runs
    summary = {"dataset": runs[0]["dataset"], "mapper": runs[0]["mapper"],
               "camera_setup": runs[0].get("camera_setup"),
               "command": runs[0].get("command"), "runs": runs,
               "status": "ok" if ok_runs else runs[0]["status"]}
    seeds = {r.get("seed") for r in runs}
    if len(seeds) == 1 and None not in seeds:
        summary["seed"] = runs[0]["seed"]
    for key in ("wall_time_s", "registered", "points", "mean_track_length",
                "mean_reproj_error_px", "replaced_images", "left_out_images"):
        summary[key] = median(r.get(key) for r in pool)
    peaks = [r["peak_rss_mb"] for r in pool if r.get("peak_rss_mb")
             is not None]
    summary["peak_rss_mb"] = max(peaks) if peaks else None
    middle = median_time_run(pool)
    for key in ("model_path", "image_names", "db_images"):
        if key in middle:
            summary[key] = middle[key]
    evaluations = [r["evaluation"] for r in pool if r.get("evaluation")]
    if evaluations:
        evaluation = {}
        for key in evaluations[0]:
            values = [e.get(key) for e in evaluations]
            if all(isinstance(v, (int, float)) or v is None for v in values):
                evaluation[key] = median(values)
        summary["evaluation"] = evaluation
    stage_runs = [r for r in pool if r.get("stages")]
    if stage_runs:
        summary["stages"] = [
            [name, median(stage_times(r).get(name) for r in stage_runs)]
            for name in stage_order(stage_runs)]
    return summary



def summary_records(records):
    """Rows of the main table: per dataset, ours (over the seeds and
    repeats), the stock mapper and the reference (over the repeats), in the
    order of the runs."""
    rows = []
    for name in dataset_order(records):
        for mapper in MAPPER_ORDER:
            runs = [r for r in records
                    if r["dataset"] == name and r["mapper"] == mapper]
            if runs:
                rows.append(summarize_runs(runs))
    return rows


def dataset_order(records):
    names = []
    for r in records:
        if r["dataset"] not in names:
            names.append(r["dataset"])
    return names


def beyond_label(records):
    fractions = [r["evaluation"]["cameras_beyond_fraction"] for r in records
                 if (r.get("evaluation") or {}).get("cameras_beyond_fraction")
                 is not None]
    return "cameras beyond %g%%" % (100 * (fractions[0] if fractions
                                           else BEYOND_FRACTION))


def run_label(run):
    """"seed 0 run 2" / "run 2" / "seed 0" of one run."""
    words = []
    if run.get("seed") is not None:
        words.append("seed %d" % run["seed"])
    if run.get("repeat") is not None:
        words.append("run %d" % (run["repeat"] + 1))
    return " ".join(words) or "run"


def runs_note(runs):
    """"(median of 6 runs: 2 seeds × 3 repeats)", "(median of 3 runs)", ...;
    "" for one run."""
    count = len(runs)
    if count < 2:
        return ""
    seeds = len({r.get("seed") for r in runs})
    if seeds > 1 and count > seeds:
        return " (median of %d runs: %d seeds × %d repeats)" % (
            count, seeds, count // seeds)
    if seeds > 1:
        return " (median of %d seeds)" % seeds
    return " (median of %d runs)" % count


def main_table_header(records):
    """The main table's two header lines; they say how several runs are
    combined."""
    aucs = " | ".join("AUC@%s° (median)" % t for t in AUC_THRESHOLDS)
    header = ("| dataset | cameras | mapper | wall time: median (min–max) "
              "| peak memory (max) | registered (min–max) | %s "
              "| mean position error (median) | %s (min–max) "
              "| re-placed/left out (min–max) | mean reproj. error (median) "
              "| mean track length (median) |" % (aucs,
                                                  beyond_label(records)))
    return [header, "|" + "---|" * (header.count("|") - 1)]


def markdown_tables(records, meta):
    """The provenance, the main table and the per-stage table of all runs
    (records: every run, one per seed and repeat for ours)."""
    rows = summary_records(records)
    several_runs = any(len(r.get("runs", [])) > 1 for r in rows)
    lines = provenance_lines(meta) + [""]
    lines += main_table_header(records)
    for r in rows:
        runs = r.get("runs") or [r]
        ok_runs = [x for x in runs if x["status"] == "ok"] or runs
        several = len(runs) > 1
        mapper = MAPPER_LABELS.get(r["mapper"], r["mapper"]) + runs_note(runs)
        ev = r.get("evaluation") or {}
        if r["status"] != "ok":
            registered = r["status"]
        elif ev:
            registered = "%s/%d" % (fmt_span(
                [(x.get("evaluation") or {}).get("registered")
                 for x in ok_runs]), ev["images"])
        else:
            registered = fmt_span([x.get("registered") for x in ok_runs])
        failed = ["%s: %s" % (run_label(x), x["status"])
                  for x in runs if x["status"] != "ok"]
        if failed and r["status"] == "ok":
            registered += " (%s)" % "; ".join(failed)
        wall = fmt(r.get("wall_time_s"), 1, " s")
        auc3 = fmt(ev.get("auc@3"))
        if several:
            wall += " (%s)" % fmt_range([x.get("wall_time_s")
                                         for x in ok_runs])
            if ev.get("auc@3") is not None:
                auc3 += " (%s)" % fmt_range(
                    [(x.get("evaluation") or {}).get("auc@3")
                     for x in ok_runs])
        if any((x.get("evaluation") or {}).get("cameras_beyond") is not None
               for x in ok_runs):
            beyond = fmt_span([(x.get("evaluation") or {}).get(
                "cameras_beyond") for x in ok_runs])
        else:
            beyond = "–"
        if r["mapper"] == "global" and any(
                x.get("replaced_images") is not None for x in ok_runs):
            moved = "%s/%s" % (
                fmt_span([x.get("replaced_images") for x in ok_runs]),
                fmt_span([x.get("left_out_images") for x in ok_runs]))
        else:
            moved = "–"
        cells = [r["dataset"], r.get("camera_setup") or "–", mapper, wall,
                 fmt(r.get("peak_rss_mb"), 0, " MB"), registered]
        cells += [auc3 if t == "3" else fmt(ev.get("auc@" + t))
                  for t in AUC_THRESHOLDS]
        cells += [fmt_error(ev.get("pos_err_mean")), beyond, moved,
                  fmt(r.get("mean_reproj_error_px"), 3, " px"),
                  fmt(r.get("mean_track_length"), 2)]
        lines.append("| " + " | ".join(cells) + " |")

    stage_names = stage_order(rows)
    if stage_names:
        lines.append("")
        lines.append("Per-stage time of our `global_mapper` (s%s):" % (
            ", median over the runs" if several_runs else ""))
        lines.append("")
        lines.append("| dataset | " + " | ".join(stage_names) +
                     " | other | total |")
        lines.append("|---|" + "---|" * (len(stage_names) + 2))
        for r in rows:
            if r["mapper"] != "global" or not r.get("stages"):
                continue
            times = stage_times(r)
            other = max(0.0, r["wall_time_s"] - sum(times.values()))
            cells = [r["dataset"]] + [fmt(times.get(s), 2)
                                      for s in stage_names]
            cells += [fmt(other, 2), fmt(r["wall_time_s"], 2)]
            lines.append("| " + " | ".join(cells) + " |")
    lines.append("")
    lines.append("AUC: pairwise, the larger of relative-rotation and "
                 "translation-direction error per image pair, a pair with an "
                 "unregistered image counting as a failure, in percent. "
                 "Position error: mean camera-centre distance to ground truth "
                 "after a robust similarity alignment, in ground-truth units. "
                 "Cameras beyond: registered cameras farther than that "
                 "fraction of the scene size (largest distance between two "
                 "ground-truth cameras) from ground truth after the "
                 "alignment. Re-placed/left out: images the global mapper's "
                 "pose verification moved or deregistered.")
    missing = [t for t in AUC_THRESHOLDS
               if not any((r.get("evaluation") or {}).get("auc@" + t)
                          is not None for r in rows)]
    if missing and any(r.get("evaluation") for r in rows):
        lines.append("AUC@%s°: not reported by this `model_evaluator` "
                     "(it has no `%s`)." % ("°, AUC@".join(missing),
                                            POSE_THRESHOLDS_OPTION))
    if several_runs:
        lines.append("Several runs (seeds `--GlobalMapper.random_seed` of "
                     "ours, and repeats): a row shows the median over its "
                     "runs of the wall time and of every figure, with the "
                     "range (min–max) in parentheses for wall time and "
                     "AUC@3°, ranges for registered, cameras beyond and "
                     "re-placed/left out, and the largest peak memory; every "
                     "run is in results.json.")
    return "\n".join(lines) + "\n"


# --------------------------------------------------------------------------
# Acceptance bars
# --------------------------------------------------------------------------

def run_registered(record):
    """(registered, images) of a run; images None if unknown."""
    ev = record.get("evaluation") or {}
    if record["status"] != "ok":
        return 0, ev.get("images") or record.get("db_images")
    if ev:
        return ev["registered"], ev["images"]
    return record.get("registered"), record.get("db_images")


def image_names(colmap, record):
    if "image_names" in record:  # Given (self-test).
        return set(record["image_names"])
    if record["status"] != "ok":
        return set()
    return read_image_names(colmap, record.get("model_path"))


def check_bars(colmap, record, reference, stock, stock_relative,
               max_position_error=None):
    """The bars of one run of ours. reference: parse_reference() of the
    dataset; stock: the stock mapper's run on it in this benchmark (or None);
    stock_relative: bars relative to the stock mapper (dino-363). Returns a
    row {"dataset", "seed", "cells": {bar: text}, "verdicts": {bar: True /
    False / None (unchecked) / NOT_APPLICABLE}, "result"}."""
    ok = record["status"] == "ok"
    ev = record.get("evaluation") or {}
    cells, verdicts = {}, {}
    registered, images = run_registered(record)
    our_text = "%s/%s" % ("–" if registered is None else "%g" % registered,
                          "?" if images is None else images)
    stock_ref = (reference or {}).get("incremental") or {}

    # Registration.
    if stock_relative and stock is not None:
        stock_names = image_names(colmap, stock)
        our_names = image_names(colmap, record)
        if stock["status"] != "ok":
            cells["registered"] = our_text + " (stock: none)"
            verdicts["registered"] = True
        elif stock_names is not None and our_names is not None:
            missing = sorted(stock_names - our_names)
            if missing:
                cells["registered"] = "%s, misses %d of stock's %d (%s)" % (
                    our_text, len(missing), len(stock_names),
                    ", ".join(missing[:3]) + (", ..." if len(missing) > 3
                                              else ""))
            else:
                cells["registered"] = "%s ⊇ stock's %d" % (
                    our_text, len(stock_names))
            verdicts["registered"] = not missing
        else:
            # No image names: compare the counts.
            stock_count = run_registered(stock)[0]
            cells["registered"] = "%s vs stock %s (counts)" % (
                our_text, stock_count)
            verdicts["registered"] = (
                None if registered is None or stock_count is None
                else registered >= stock_count)
    elif stock_relative and stock_ref.get("registered"):
        needed = stock_ref["registered"][0]
        cells["registered"] = "%s vs stock %d (README)" % (our_text, needed)
        verdicts["registered"] = (None if registered is None
                                  else registered >= needed)
    else:
        cells["registered"] = our_text
        verdicts["registered"] = (None if registered is None or images is None
                                  else registered >= images)

    # AUC@3.
    ours = ev.get("auc@3") if ok else 0.0
    bar, source = None, None
    if stock_relative:
        if stock is not None:
            stock_ev = stock.get("evaluation") or {}
            stock_auc = (stock_ev.get("auc@3") if stock["status"] == "ok"
                         else 0.0)
            source = "stock"
        else:
            stock_auc = stock_ref.get("auc@3")
            source = "stock README"
        if stock_auc is not None:
            bar = stock_auc - STOCK_AUC_MARGIN
    else:
        figures = [row.get("auc@3") for row in (reference or {}).values()]
        figures = [f for f in figures if f is not None]
        if figures:
            bar = max(figures) - AUC_BAR_MARGIN
            source = "README"
    if bar is None:
        cells["auc@3"] = fmt(ours)
        verdicts["auc@3"] = None if stock_relative else NOT_APPLICABLE
    elif ours is None:
        cells["auc@3"] = "– (bar %.1f, %s)" % (bar, source)
        verdicts["auc@3"] = None
    else:
        # Compared as shown (one decimal, like the README figures).
        met = round(ours, 1) >= round(bar, 1) - 1e-9
        cells["auc@3"] = "%.1f %s %.1f (%s)" % (ours, "≥" if met else "<",
                                                bar, source)
        verdicts["auc@3"] = met

    # Cameras beyond 5% of the scene size.
    if not ok:
        cells["beyond"], verdicts["beyond"] = "–", NOT_APPLICABLE
    elif ev.get("cameras_beyond") is None:
        cells["beyond"] = "– (not reported)" if ev else "– (no ground truth)"
        verdicts["beyond"] = None
    else:
        fraction = ev.get("cameras_beyond_fraction", BEYOND_FRACTION)
        cells["beyond"] = str(ev["cameras_beyond"])
        if fraction is not None and abs(fraction - BEYOND_FRACTION) > 1e-9:
            cells["beyond"] += " (at %g%%)" % (100 * fraction)
        verdicts["beyond"] = ev["cameras_beyond"] == 0

    # Mean position error (KITTI_sequence_1).
    if max_position_error is None:
        cells["position"], verdicts["position"] = "–", NOT_APPLICABLE
    elif not ok:
        cells["position"] = "– (bar %g)" % max_position_error
        verdicts["position"] = False
    elif not ev:
        cells["position"] = "– (no ground truth)"
        verdicts["position"] = None
    else:
        error = ev.get("pos_err_mean")
        met = error is not None and error <= max_position_error
        cells["position"] = "%s %s %g" % (fmt_error(error),
                                          "≤" if met else ">",
                                          max_position_error)
        verdicts["position"] = met

    # Time against the stock mapper (stock-relative datasets).
    if not stock_relative:
        cells["time"], verdicts["time"] = "–", NOT_APPLICABLE
    else:
        if stock is not None:
            stock_time, source = stock.get("wall_time_s"), "stock"
        else:
            stock_time, source = stock_ref.get("wall_time_s"), "stock README"
        ours_time = record.get("wall_time_s")
        if not stock_time or ours_time is None:
            cells["time"], verdicts["time"] = "–", None
        else:
            ratio = ours_time / stock_time
            met = ratio <= STOCK_TIME_RATIO
            cells["time"] = "%.1f/%.1f s = %.2f× %s %g× (%s)" % (
                ours_time, stock_time, ratio, "≤" if met else ">",
                STOCK_TIME_RATIO, source)
            verdicts["time"] = met

    if record.get("replaced_images") is not None:
        cells["moved"] = "%g/%g" % (record["replaced_images"],
                                    record["left_out_images"])
    else:
        cells["moved"] = "–"

    names = {"registered": "registered", "auc@3": "AUC@3",
             "beyond": "cameras beyond", "position": "position error",
             "time": "time"}
    failed = [names[k] for k, v in verdicts.items() if v is False]
    unchecked = [names[k] for k, v in verdicts.items() if v is None]
    if not ok:
        failed.insert(0, record["status"])
    if failed:
        result = "**FAIL** (%s)" % ", ".join(failed)
    elif unchecked:
        result = "unchecked (%s)" % ", ".join(unchecked)
    else:
        result = "pass"
    return {"dataset": record["dataset"], "seed": record.get("seed"),
            "stock_relative": stock_relative, "cells": cells,
            "verdicts": verdicts, "failed": failed, "unchecked": unchecked,
            "result": result}


def seed_summaries(records, name):
    """Our runs on dataset `name`, one summary per seed over its repeats
    (summarize_runs: median time and figures), in seed order of the runs."""
    seeds = []
    for r in records:
        if (r["dataset"] == name and r["mapper"] == "global"
                and r.get("seed") not in seeds):
            seeds.append(r.get("seed"))
    return [summarize_runs([r for r in records if r["dataset"] == name and
                            r["mapper"] == "global" and r.get("seed") == s])
            for s in seeds]


def compute_bars(args, records, datasets):
    """The bars per seed of ours and dataset, judged on the median over the
    seed's repeats against the stock mapper's median over its repeats."""
    rows = []
    for dataset in datasets:
        name = os.path.basename(dataset)
        reference = parse_reference(dataset)
        stock_runs = [r for r in records if r["dataset"] == name
                      and r["mapper"] == "incremental"]
        stock = summarize_runs(stock_runs) if stock_runs else None
        # The README has the stock mapper's figures but no upstream
        # global_mapper's (dino-363): compare with the stock mapper.
        stock_relative = name in args.stock_relative or (
            reference is not None and "incremental" in reference
            and "upstream" not in reference)
        for r in seed_summaries(records, name):
            row = check_bars(args.colmap, r, reference, stock,
                             stock_relative, MAX_POSITION_ERROR.get(name))
            row["runs"] = len(r.get("runs") or [r])
            rows.append(row)
    return rows


def all_bars_met(bars):
    """(met, the final line)."""
    if not bars:
        return False, "all bars met: no (no run of the global mapper)"
    failing = [b for b in bars if b["failed"]]
    unchecked = [b for b in bars if not b["failed"] and b["unchecked"]]
    if not failing and not unchecked:
        return True, "all bars met: yes (%d of %d runs pass)" % (len(bars),
                                                                len(bars))
    notes = []
    if failing:
        notes.append("%d of %d runs fail" % (len(failing), len(bars)))
    if unchecked:
        notes.append("%d run(s) could not be checked" % len(unchecked))
    return False, "all bars met: no (%s)" % "; ".join(notes)


def bars_table(bars, beyond):
    repeated = any(b.get("runs", 1) > 1 for b in bars)
    lines = ["Bars of issue 10, per %s of our `global_mapper`:" % (
        "seed (the median time and figures over its repeats, against the "
        "stock mapper's median)" if repeated else "run"), "",
             "| dataset | seed | registered | AUC@3° vs bar | %s "
             "| mean position error vs bar | time vs stock mapper "
             "| re-placed/left out | result |" % beyond,
             "|---|---|---|---|---|---|---|---|---|"]
    for b in bars:
        c = b["cells"]
        cells = [b["dataset"] + (" (stock-relative)" if b["stock_relative"]
                                 else ""),
                 "–" if b["seed"] is None else str(b["seed"]),
                 c["registered"], c["auc@3"], c["beyond"], c["position"],
                 c["time"], c["moved"], b["result"]]
        lines.append("| " + " | ".join(cells) + " |")
    lines.append("")
    lines.append(
        "Bars: every image registered; AUC@3° at least the better of the "
        "reference mappers' figures in the dataset's README (COLMAP 3.8 "
        "`mapper`, COLMAP 4.1.1 `global_mapper`) minus %g; no registered "
        "camera beyond %g%% of the scene size; %s. Stock-relative datasets "
        "(README without upstream figures, e.g. dino-363): every image the "
        "stock `mapper` of this run registers, AUC@3° at most %g below it, "
        "in at most %g× its time (its README figures if it was not run). "
        "Without README figures (synthetic scenes) only the registration "
        "and cameras-beyond bars apply. AUC compared at one decimal. Times: "
        "medians over the repeats." % (
            AUC_BAR_MARGIN, 100 * BEYOND_FRACTION,
            "; ".join("%s: mean position error at most %g" % item
                      for item in sorted(MAX_POSITION_ERROR.items())),
            STOCK_AUC_MARGIN, STOCK_TIME_RATIO))
    lines.append("")
    lines.append(all_bars_met(bars)[1])
    return "\n".join(lines) + "\n"


def stage_order(records):
    names = []
    for r in records:
        for name, _ in r.get("stages") or []:
            if name not in names:
                names.append(name)
    return names


def stage_times(record):
    times = {}
    for name, seconds in record.get("stages") or []:
        times[name] = times.get(name, 0.0) + seconds
    return times


def gnuplot_label(text):
    return '"' + text.replace('"', "'") + '"'


def write_plots(records, output_dir):
    """records: the main table's rows (summary_records)."""
    gnuplot = shutil.which("gnuplot")
    if not gnuplot:
        log("gnuplot not found: no plots (apt-get install gnuplot-nox)")
        return []
    written = []
    stage_names = stage_order(records)
    has_reference = any(r["mapper"] == "reference" for r in records)
    totals = ["COLMAP 3.8 mapper (total)"] + (
        ["reference global_mapper (total)"] if has_reference else [])
    columns = stage_names + ["other"] + totals

    # Runtime: one stacked bar per run (stages of ours, total of the stock
    # mapper).
    rows = []
    for r in records:
        if r.get("wall_time_s") is None:
            continue
        values = [0.0] * len(columns)
        if r["mapper"] == "global":
            times = stage_times(r)
            for k, name in enumerate(stage_names):
                values[k] = times.get(name, 0.0)
            values[len(stage_names)] = max(
                0.0, r["wall_time_s"] - sum(times.values()))
            label = r["dataset"] + (" (global" + (
                ", median" if len(r.get("runs") or []) > 1 else "") + ")"
                if r["status"] == "ok" else " (global, failed)")
        else:
            short = "ref." if r["mapper"] == "reference" else "incr."
            values[len(stage_names) + 1 + (r["mapper"] == "reference")] = (
                r["wall_time_s"])
            label = r["dataset"] + (" (%s)" % short if r["status"] == "ok"
                                    else " (%s, failed)" % short)
        rows.append([label] + values)
    if rows:
        data_path = os.path.join(output_dir, "runtime_per_stage.dat")
        with open(data_path, "w") as f:
            f.write("run " + " ".join(gnuplot_label(c) for c in columns) +
                    "\n")
            for row in rows:
                f.write(gnuplot_label(row[0]) + " " +
                        " ".join("%.4f" % v for v in row[1:]) + "\n")
        png = os.path.join(output_dir, "runtime_per_stage.png")
        script = "\n".join([
            "set terminal pngcairo size 1200,700 noenhanced" if
            has_pngcairo(gnuplot) else "set terminal png size 1200,700",
            "set output '%s'" % png,
            "set title 'Wall time per run (global mapper split by stage)'",
            "set ylabel 'seconds'",
            "set style data histograms",
            "set style histogram rowstacked",
            "set style fill solid 0.85 border -1",
            "set boxwidth 0.7",
            "set key outside right top",
            "set xtics rotate by -35 left",
            "set grid ytics",
            "set yrange [0:*]",
            # Distinct colours for the stages, grey for the stock mapper.
            "colors = '%s'" % " ".join(
                [STAGE_COLORS[k % len(STAGE_COLORS)]
                 for k in range(len(columns) - len(totals))] +
                ["#999999", "#555555"][:len(totals)]),
            "plot for [col=2:%d] '%s' using col:xtic(1) title columnheader "
            "lc rgb word(colors, col - 1)" % (len(columns) + 1, data_path),
        ])
        if run_gnuplot(gnuplot, script, png):
            written.append(png)

    # AUC: per dataset, ours, the stock mapper and the reference, one panel
    # per threshold that some row has.
    datasets = []
    for r in records:
        if r.get("evaluation") is not None and r["dataset"] not in datasets:
            datasets.append(r["dataset"])
    thresholds = [t for t in AUC_THRESHOLDS
                  if any((r.get("evaluation") or {}).get("auc@" + t)
                         is not None for r in records)]
    mappers = [m for m in MAPPER_ORDER
               if any(r["mapper"] == m for r in records)]
    titles = {"global": "ours (global)",
              "incremental": "COLMAP 3.8 incremental",
              "reference": "reference global_mapper"}
    if datasets and thresholds:
        data_path = os.path.join(output_dir, "auc_per_dataset.dat")
        with open(data_path, "w") as f:
            # No header line: gnuplot would count it as the first cluster.
            for name in datasets:
                values = []
                for t in thresholds:
                    for mapper in mappers:
                        ev = next((r.get("evaluation") for r in records
                                   if r["dataset"] == name
                                   and r["mapper"] == mapper), None) or {}
                        value = ev.get("auc@" + t)
                        values.append("%.3f" % value if value is not None
                                      else "0")
                f.write(gnuplot_label(name) + " " + " ".join(values) + "\n")
        png = os.path.join(output_dir, "auc_per_dataset.png")
        panels = []
        for k, t in enumerate(thresholds):
            first = 2 + len(mappers) * k
            plots = ["'%s' using %d:xtic(1) title '%s'" % (
                data_path, first, titles[mappers[0]])]
            plots += ["'' using %d title '%s'" % (first + j, titles[m])
                      for j, m in enumerate(mappers) if j > 0]
            panels.append("\n".join([
                "set title 'Pairwise pose AUC @ %s deg (%%)'" % t,
                "plot " + ", ".join(plots),
            ]))
        columns = 2 if len(thresholds) <= 4 else 3
        rows = (len(thresholds) + columns - 1) // columns
        script = "\n".join([
            "set terminal pngcairo size %d,900 noenhanced" % (600 * columns)
            if has_pngcairo(gnuplot) else
            "set terminal png size %d,900" % (600 * columns),
            "set output '%s'" % png,
            "set style data histograms",
            "set style histogram clustered gap 1",
            "set style fill solid 0.85 border -1",
            "set yrange [0:100]",
            "set grid ytics",
            "set key below",
            "set xrange [-0.5:%f]" % (len(datasets) - 0.5),
            "set xtics rotate by -25 left",
            "set multiplot layout %d,%d" % (rows, columns),
        ] + panels + ["unset multiplot"])
        if run_gnuplot(gnuplot, script, png):
            written.append(png)
    return written


def has_pngcairo(gnuplot):
    code, text = capture([gnuplot, "-e", "set terminal"])
    return "pngcairo" in text


def run_gnuplot(gnuplot, script, png):
    result = subprocess.run([gnuplot], input=script, text=True,
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT)
    if result.returncode != 0 or not os.path.exists(png):
        log("gnuplot failed for %s: %s" % (png, result.stdout.strip()))
        return False
    return True


def update_readme(readme_path, table, plot_path):
    """Replaces the README section between README_BEGIN and README_END (or
    appends one) with the tables (headed by their provenance: the command
    that made them, commit, binaries, machine) and one plot, copied beside
    the README, after the provenance."""
    readme_dir = os.path.dirname(os.path.abspath(readme_path))
    provenance, _, table = table.partition("\n\n")
    section = [README_BEGIN, "", provenance, ""]
    if plot_path:
        target = os.path.join(readme_dir, "docs", "benchmark",
                              os.path.basename(plot_path))
        os.makedirs(os.path.dirname(target), exist_ok=True)
        shutil.copyfile(plot_path, target)
        section += ["![Pairwise AUC per dataset](%s)" %
                    os.path.relpath(target, readme_dir), ""]
    section += [table.rstrip(), "", README_END]
    text = open(readme_path).read() if os.path.exists(readme_path) else ""
    block = "\n".join(section)
    if README_BEGIN in text and README_END in text:
        head, rest = text.split(README_BEGIN, 1)
        _, tail = rest.split(README_END, 1)
        text = head + block + tail
    else:
        text = text.rstrip("\n") + "\n\n## Benchmark\n\n" + block + "\n"
    with open(readme_path, "w") as f:
        f.write(text)


def parse_seeds(text):
    try:
        seeds = [int(s) for s in text.split(",") if s.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError("not a list of integers: %r" % text)
    if not seeds or len(set(seeds)) != len(seeds) or min(seeds) < 0:
        raise argparse.ArgumentTypeError(
            "need distinct non-negative integers: %r" % text)
    return seeds


def self_test():
    """Checks of the parsing and of the bars on made-up input; no colmap."""
    checks = [0]

    def expect(condition, what):
        checks[0] += 1
        if not condition:
            raise AssertionError("self-test failed: " + what)

    table = ("# x\n\n## Reference figures\ntext\n\n"
             "| mapper | wall time | registered | AUC@1° | AUC@3° | AUC@5° "
             "| AUC@10° | mean position error |\n"
             "|---|---|---|---|---|---|---|---|\n"
             "| COLMAP 3.8 incremental %s | 39.7s | %s | – | %s | – | – | – |\n"
             "%s")
    upstream = ("| COLMAP 4.1.1 \\`global_mapper\\` (upstream) | 59.6s | 51/51 "
                "| 2.7 | 66.2 | 79.7 | 89.8 | 0.0146 |\n")
    ours = ("| this project's `global_mapper` at commit 3942e28 | 80.2s "
            "| 199/363 | 5.3 | 95.5 | 24.1 | 26.9 | 0.007077 |\n")
    ref = parse_reference_text(table % ("`mapper`", "failed: no model",
                                        "–", upstream))
    expect(ref["incremental"]["auc@3"] is None, "'–' is no figure")
    expect(ref["incremental"]["registered"] is None, "failed registration")
    expect(ref["upstream"]["auc@3"] == 66.2, "escaped backticks")
    expect(ref["upstream"]["wall_time_s"] == 59.6, "wall time")
    ref = parse_reference_text(table % ("\\`mapper\\`", "363/363", "70.2",
                                        ours))
    expect(set(ref) == {"incremental"}, "this project's rows are ignored")
    expect(ref["incremental"]["registered"] == [363, 363], "registered")
    expect(parse_reference_text("# no table\n| a | b |\n|---|---|\n") is None,
           "no reference table")

    expect(camera_setup_label("per_image_exif", "OPENCV", 0.02) ==
           "per image OPENCV, EXIF 2% off", "camera setup label")
    expect(camera_setup_label("shared", "PINHOLE", 0.02) ==
           "shared PINHOLE, no prior", "shared camera setup label")
    expect(FINISH_RE.search(
        "Global mapper finished in 2.0 s: 1 model(s), 51 of 51 images "
        "registered; pose verification re-placed 0 and left out 0 image(s); "
        "1 warning(s): Focal lengths not determined: ...").group(3) == "51",
        "final line with a warning")
    match = FINISH_RE.search(
        "I1201 12:00:00.1 global_mapper.cc:355] Global mapper finished in "
        "12.3 s: 1 model(s), 47 of 47 images registered; pose verification "
        "re-placed 2 and left out 1 image(s).")
    expect(match and match.group(5) == "2" and match.group(6) == "1",
           "final line")
    expect(FINISH_RE.search("Global mapper finished in 1.0 s: 2 model(s), 5 "
                            "of 8 images registered.").group(5) is None,
           "final line of an older binary")
    expect(STAGE_RE.search("Stage Final pose verification: 0.250 s (a=1)")
           .group(1) == "Final pose verification", "stage line")
    expect(STAGE_RE.search("Stage Pose verification ...") is None,
           "stage start line")

    with tempfile.TemporaryDirectory() as tmp:
        with open(os.path.join(tmp, "images.bin"), "wb") as f:
            f.write(struct.pack("<Q", 2))
            for k, (name, points) in enumerate([("a b.jpg", 2), ("c.png", 0)]):
                f.write(struct.pack("<I7dI", k + 1, 1, 0, 0, 0, 0, 0, 0, 1))
                f.write(name.encode() + b"\0" + struct.pack("<Q", points))
                f.write(struct.pack("<ddq", 1, 2, -1) * points)
        expect(read_image_names("colmap", tmp) == {"a b.jpg", "c.png"},
               "images.bin")
        with open(os.path.join(tmp, "images.txt"), "w") as f:
            f.write("# Image list\n# two lines\n"
                    "1 1 0 0 0 0 0 0 1 a b.jpg\n1.0 2.0 -1\n"
                    "2 1 0 0 0 0 0 0 1 c.png\n\n")
        expect(set(read_image_names_txt(os.path.join(tmp, "images.txt")))
               == {"a b.jpg", "c.png"}, "images.txt with an empty line")

    def run(mapper, seed, registered, auc3, wall, beyond=0, names=None,
            status="ok", pos=0.01):
        ev = {"images": 10, "registered": registered, "auc@1": 50.0,
              "auc@3": auc3, "auc@5": 90.0, "auc@10": 95.0,
              "pos_err_mean": pos}
        if beyond is not None:
            ev.update(cameras_beyond=beyond, cameras_beyond_fraction=0.05)
        record = {"dataset": "d", "mapper": mapper, "status": status,
                  "wall_time_s": wall, "evaluation": ev,
                  "replaced_images": 1, "left_out_images": 0,
                  "stages": [["relative_poses", wall / 2]]}
        if seed is not None:
            record["seed"] = seed
        if names is not None:
            record["image_names"] = names
        return record

    readme = {"incremental": {"auc@3": 90.0, "registered": [10, 10],
                              "wall_time_s": 20.0},
              "upstream": {"auc@3": 91.0, "registered": [10, 10]}}
    expect(check_bars("colmap", run("global", 0, 10, 90.5, 2), readme, None,
                      False)["result"] == "pass", "plain pass")
    row = check_bars("colmap", run("global", 0, 10, 90.44, 2), readme, None,
                     False)
    expect(row["failed"] == ["AUC@3"], "AUC below the better reference")
    row = check_bars("colmap", run("global", 0, 9, 95, 2, beyond=1), readme,
                     None, False)
    expect(row["failed"] == ["registered", "cameras beyond"],
           "registration and cameras beyond")
    row = check_bars("colmap", run("global", 0, 10, 95, 2, beyond=None),
                     readme, None, False)
    expect(row["unchecked"] == ["cameras beyond"] and not row["failed"],
           "an evaluator without cameras_beyond")
    row = check_bars("colmap", run("global", 0, 10, 95, 2, pos=0.03), readme,
                     None, False, 0.02)
    expect(row["failed"] == ["position error"], "position error bar")
    row = check_bars("colmap", run("global", 0, 10, 95, 2), None, None, False)
    expect(row["result"] == "pass" and row["verdicts"]["auc@3"] ==
           NOT_APPLICABLE, "no README figures")

    # Stock-relative (dino-363): the stock mapper of the same run.
    stock = run("incremental", None, 8, 70.2, 100.0,
                names=["1", "2", "3", "4", "5", "6", "7", "8"])
    dino = {"incremental": readme["incremental"]}
    good = run("global", 1, 9, 69.2, 50.0, beyond=0,
               names=["1", "2", "3", "4", "5", "6", "7", "8", "9"])
    row = check_bars("colmap", good, dino, stock, True)
    expect(row["result"] == "pass", "stock-relative pass: " + str(row))
    bad = run("global", 2, 9, 69.1, 50.1, beyond=0,
              names=["1", "2", "3", "4", "5", "6", "7", "9", "10"])
    row = check_bars("colmap", bad, dino, stock, True)
    expect(row["failed"] == ["registered", "AUC@3", "time"],
           "stock-relative failures: " + str(row["failed"]))
    expect("misses 1" in row["cells"]["registered"], "missing image named")
    row = check_bars("colmap", run("global", 0, 10, 89.0, 9.0), dino, None,
                     True)
    expect(row["result"] == "pass" and "README" in row["cells"]["time"],
           "stock-relative with the README's stock figures")
    failed_stock = dict(stock, status="failed: no model", evaluation=None)
    row = check_bars("colmap", good, dino, failed_stock, True)
    expect(row["verdicts"]["registered"] is True and
           row["verdicts"]["auc@3"] is True, "a failed stock mapper")
    expect(all_bars_met([])[0] is False, "no runs")
    runs = [run("global", s, 10, a, w) for s, a, w in
            [(0, 80.0, 3.0), (1, 82.0, 5.0), (2, 81.0, 4.0)]]
    runs[2]["evaluation"]["cameras_beyond"] = 2
    summary = summarize_runs(runs)
    expect(summary["wall_time_s"] == 4.0 and
           summary["evaluation"]["auc@3"] == 81.0, "median over seeds")
    meta = {"command": "python3 scripts/benchmark.py --repeats 2 "
                       "--readme '/tmp/a b/README.md'",
            "cwd": "/work/main", "date": "today", "seeds": [0, 1, 2],
            "machine": {"cpu": "Test CPU @ 2.0GHz", "cores": 2,
                        "memory_gib": 23.54, "kernel": "Linux 6.1.0"},
            "colmap": {"path": "/r/build/bin/colmap", "build_type": "Release",
                       "source": "/r", "commit": "abc1234+dirty"},
            "reference_colmap": {"path": "/u/build/bin/colmap",
                                 "build_type": "unknown", "source": None,
                                 "commit": None},
            "repeats": {"datasets": 3, "synthetic scenes": 1}}
    table = markdown_tables(runs + [stock], meta)
    expect("4.0 s (3.0–5.0)" in table and "81.0 (80.0–82.0)" in table and
           "| 0–2 |" in table, "seed spread in the table:\n" + table)

    # Repeats: median and spread of the time, accuracy as medians.
    expect(median([3.0, None, 1.0, 2.0]) == 2.0 and median([]) is None and
           repr(median([30, 30])) == "30" and median([1, 2]) == 1.5,
           "median")
    expect(time_spread([{"wall_time_s": t} for t in (5.0, 1.0, 2.0, 9.0)])
           == (3.5, 1.0, 9.0), "median and spread of an even count")
    expect(time_spread([{}]) == (None, None, None), "no times")
    expect(median_time_run([{"wall_time_s": t, "k": t}
                            for t in (5.0, 1.0, 2.0, 9.0)])["k"] == 2.0,
           "the lower middle run of an even count")
    repeated = []
    for repeat, (wall0, wall1, auc) in enumerate(
            [(3.0, 6.0, 80.0), (1.0, 2.0, 82.0), (2.0, 4.0, 81.0)]):
        for seed, wall in ((0, wall0), (1, wall1)):
            r = run("global", seed, 10, auc, wall)
            r["repeat"] = repeat
            r["model_path"] = "m%d%d" % (seed, repeat)
            repeated.append(r)
    summary = summarize_runs(repeated)
    expect(summary["wall_time_s"] == 2.5 and
           summary["evaluation"]["auc@3"] == 81.0 and
           "seed" not in summary, "median over seeds × repeats")
    per_seed = seed_summaries(repeated, "d")
    expect([x["seed"] for x in per_seed] == [0, 1] and
           per_seed[0]["wall_time_s"] == 2.0 and
           per_seed[1]["wall_time_s"] == 4.0 and
           per_seed[1]["model_path"] == "m12", "per-seed medians: " +
           str([(x.get("seed"), x["wall_time_s"]) for x in per_seed]))
    expect(runs_note(repeated) == " (median of 6 runs: 2 seeds × 3 repeats)"
           and runs_note(runs) == " (median of 3 seeds)" and
           runs_note(repeated[:1]) == "" and
           runs_note([dict(stock, repeat=k) for k in range(3)])
           == " (median of 3 runs)", "runs notes")
    failed = dict(repeated[1], status="failed: exit 1", evaluation=None)
    table = markdown_tables(repeated[:1] + [failed] + repeated[2:], meta)
    expect("2.0 s (1.0–4.0)" in table and "seed 1 run 1: failed: exit 1"
           in table, "a failed repeat:\n" + table)

    # The order of the runs: the mappers alternate.
    expect(run_schedule(["global", "incremental", "reference"], [0], 2) ==
           [("global", 0, 0), ("incremental", None, 0), ("reference", None, 0),
            ("global", 0, 1), ("incremental", None, 1),
            ("reference", None, 1)], "alternating schedule")
    expect(run_schedule(["reference", "global"], [3, 4], 1) ==
           [("global", 3, 0), ("global", 4, 0), ("reference", None, 0)],
           "schedule with seeds")
    expect(run_dir_name("global", 2, 1) == "global_seed2_run2" and
           run_dir_name("reference", None, 0) == "reference_run1",
           "a fresh folder per run")

    # The stamp of a cached synthetic scene.
    with tempfile.TemporaryDirectory() as tmp:
        tool = os.path.join(tmp, "make_synthetic_scene")
        with open(tool, "wb") as f:
            f.write(b"generator v1")
        stamp = scene_stamp(tool, synthetic_options(30))
        expect(stamp["sha256"] == hashlib.sha256(b"generator v1").hexdigest()
               and stamp["options"] == ["--num_images", "30"], "stamp")
        stamp_path = os.path.join(tmp, SCENE_STAMP)
        with open(stamp_path, "w") as f:
            json.dump(stamp, f)
        old = read_stamp(stamp_path)
        expect(stamp_matches(old, stamp), "the same stamp matches")
        expect(stamp_matches(dict(old, mtime=0, generator="/x"), stamp),
               "a copied, touched generator with the same content matches")
        expect(not stamp_matches(None, stamp), "no stamp")
        expect(read_stamp(os.path.join(tmp, "missing")) is None,
               "a missing stamp")
        expect(not stamp_matches(
            old, scene_stamp(tool, synthetic_options(2000))),
               "other options")
        with open(tool, "wb") as f:
            f.write(b"generator v2")
        expect(not stamp_matches(old, scene_stamp(tool,
                                                  synthetic_options(30))),
               "another generator")
        expect(git_commit(tmp) is None, "not a git tree")

    # The exact command, shell-quoted, and the provenance header.
    command, cwd = format_command(
        ["scripts/benchmark.py", "--readme", "/tmp/a b/README.md",
         "--synthetic", "30", "--reference_colmap=build/bin/colmap",
         "it's"], "/work/main")
    expect(command == "python3 scripts/benchmark.py --readme "
           "'/tmp/a b/README.md' --synthetic 30 "
           "--reference_colmap=build/bin/colmap 'it'\"'\"'s'" and
           shlex.split(command)[1:] == ["scripts/benchmark.py", "--readme",
                                        "/tmp/a b/README.md", "--synthetic",
                                        "30",
                                        "--reference_colmap=build/bin/colmap",
                                        "it's"] and cwd == "/work/main",
           "quoted command: " + command)
    expect(format_command(["/x/bench", "a b"], "/")[0] == "/x/bench 'a b'",
           "a command that is no .py")
    expect(parse_cmake_cache("# c\nCMAKE_BUILD_TYPE:STRING=Release\n"
                             "CMAKE_HOME_DIRECTORY:INTERNAL=/src\n") ==
           ("Release", "/src"), "CMakeCache.txt")
    expect(parse_cmake_cache("CMAKE_BUILD_TYPE:STRING=\n") ==
           ("unknown", None), "no build type")
    expect(binary_info("/nonexistent/bin/colmap")["build_type"] == "unknown",
           "a binary without CMakeCache.txt")
    header = provenance_lines(meta)
    expect(header[0] == "Command: `%s` (in `/work/main`)." % meta["command"],
           "command line: " + header[0])
    expect("commit abc1234+dirty of `/r`" in header[1] and
           "ours `/r/build/bin/colmap` (Release)" in header[1] and
           "reference `/u/build/bin/colmap` (unknown, source unknown)"
           in header[1], "source and binaries: " + header[1])
    expect(header[2] == "Machine: Test CPU @ 2.0GHz, 2 cores, 23.5 GiB "
           "memory, Linux 6.1.0; today.", "machine: " + header[2])
    expect("3 for datasets" in header[3] and "1 for synthetic scenes"
           in header[3] and "once per seed (0,1,2)" in header[3],
           "runs: " + header[3])
    table_lines = markdown_tables(repeated, meta).split("\n")
    expect(table_lines[:4] == header and table_lines[4] == "" and
           "| AUC@0.5° (median) | AUC@1° (median) | AUC@3° (median) "
           "| AUC@5° (median) | AUC@10° (median) |" in table_lines[5] and
           "wall time: median (min–max)" in table_lines[5] and
           table_lines[6].count("---") == table_lines[5].count("|") - 1,
           "table header:\n" + "\n".join(table_lines[:7]))
    expect("AUC@0.5°: not reported" in "\n".join(table_lines),
           "a missing threshold is named")

    # The README block records the command that made it.
    with tempfile.TemporaryDirectory() as tmp:
        readme = os.path.join(tmp, "README.md")
        with open(readme, "w") as f:
            f.write("# t\n\n%s\nOLD BLOCK\n%s\n\nafter\n" % (README_BEGIN,
                                                         README_END))
        update_readme(readme, markdown_tables(repeated, meta), None)
        text = open(readme).read()
        block = text.split(README_BEGIN)[1].split(README_END)[0]
        expect("OLD BLOCK" not in text and text.endswith("\nafter\n") and
               block.count(meta["command"]) == 1 and
               "Regenerate with" not in block and
               "| AUC@0.5° (median)" in block, "README block:\n" + text)
    print("self-test: %d checks passed" % checks[0])


def positive_int(text):
    try:
        value = int(text)
    except ValueError:
        value = 0
    if value < 1:
        raise argparse.ArgumentTypeError("need a positive integer: %r" % text)
    return value


def main():
    parser = argparse.ArgumentParser(
        description=__doc__.split("\n\n")[0],
        formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("datasets", nargs="*",
                        help="dataset folders (database.db, optionally images/ "
                        "and gt/), or folders of them; default: every dataset "
                        "under %s" % DEFAULT_DATASETS)
    parser.add_argument("--colmap", default=DEFAULT_COLMAP,
                        help="our colmap binary (default: %(default)s)")
    parser.add_argument("--reference_colmap", metavar="PATH",
                        help="another COLMAP build's colmap binary (e.g. "
                        "upstream COLMAP 4.x); its `global_mapper` runs as a "
                        "third mapper on a copy of each database (never the "
                        "original: a newer COLMAP may migrate the schema), "
                        "evaluated like ours; fails at once if it has no "
                        "global_mapper")
    parser.add_argument("--output_dir", default=DEFAULT_OUTPUT,
                        help="where runs and reports go; synthetic scenes "
                        "are cached in its scenes/ (default: %(default)s)")
    parser.add_argument("--repeats", type=positive_int, metavar="N",
                        help="run every mapper N times on every input, "
                        "alternating between the mappers (ours, stock, "
                        "reference, ours, ...), each run from a fresh output "
                        "folder; the table shows the median wall time with "
                        "its min-max and the medians of the other figures. "
                        "Default: %d for the datasets, %d for synthetic "
                        "scenes (--synthetic: large scenes take minutes per "
                        "run, and a scene's noise is fixed by the generator); "
                        "N given applies to both" % (
                            DEFAULT_REPEATS, DEFAULT_SYNTHETIC_REPEATS))
    parser.add_argument("--seeds", type=parse_seeds, default=[0],
                        metavar="S,S,...", help="run our global mapper once "
                        "per seed (--GlobalMapper.random_seed) in every "
                        "repeat, e.g. 0,1,2,3,4; the other mappers run once "
                        "per repeat (default: 0)")
    parser.add_argument("--synthetic", type=int, action="append", default=[],
                        metavar="N", help="also a synthetic scene of N images "
                        "(make_synthetic_scene beside --colmap), cached under "
                        "<output_dir>/scenes/ and generated anew when the "
                        "generator binary or its options change; may repeat")
    parser.add_argument("--skip_incremental", action="store_true",
                        help="do not run the stock incremental mapper")
    parser.add_argument("--skip_global", action="store_true",
                        help="do not run our global mapper")
    parser.add_argument("--stock_relative", action="append", default=[],
                        metavar="DATASET", help="judge this dataset (folder "
                        "name) against the stock mapper of this run, like "
                        "dino-363; may repeat")
    parser.add_argument("--camera_setup", choices=CAMERA_SETUPS,
                        default="database", help="run every mapper on the "
                        "databases as they are (default), or on copies "
                        "rewritten to one shared camera, one camera per image "
                        "without focal prior, or one per image with an "
                        "EXIF-like prior (scripts/rewrite_cameras.py); bars "
                        "then relative to the stock mapper")
    parser.add_argument("--camera_model", default="SIMPLE_RADIAL",
                        help="camera model of a rewritten setup (default: "
                        "%(default)s)")
    parser.add_argument("--exif_error", type=float, default=0.02,
                        help="per_image_exif: the EXIF focal is off the "
                        "ground truth by up to this fraction (default: "
                        "%(default)s)")
    parser.add_argument("--position_thresholds", default="0.01,0.05,0.1",
                        help="distance thresholds of the position AUC, in "
                        "ground-truth units (default: %(default)s)")
    parser.add_argument("--timeout", type=int, default=3600,
                        help="seconds before a run is stopped (default: "
                        "%(default)s)")
    parser.add_argument("--readme", metavar="README.md",
                        help="also put the tables and the AUC plot into this "
                        "README's benchmark section")
    parser.add_argument("--self_test", action="store_true",
                        help="check the script's parsing and bars on made-up "
                        "input, then exit")
    args = parser.parse_args()
    if args.self_test:
        self_test()
        return
    command, cwd = format_command(sys.argv, os.getcwd())
    log("$ " + command)
    args.colmap = os.path.abspath(args.colmap)
    args.output_dir = os.path.abspath(args.output_dir)

    if not os.access(args.colmap, os.X_OK):
        sys.exit("error: %s is not an executable (build colmap_exe first or "
                 "pass --colmap)" % args.colmap)
    if args.reference_colmap:
        args.reference_colmap = os.path.abspath(args.reference_colmap)
        check_reference(args.reference_colmap)
    args.pose_thresholds = evaluator_pose_thresholds(args.colmap)
    if args.pose_thresholds is None:
        log("note: %s model_evaluator has no %s; AUC@0.5 stays empty" % (
            args.colmap, POSE_THRESHOLDS_OPTION))
    datasets = find_datasets(args.datasets or [DEFAULT_DATASETS])
    os.makedirs(args.output_dir, exist_ok=True)
    synthetic = []
    for num_images in args.synthetic:
        path = make_synthetic(args, num_images)
        if path:
            datasets.append(path)
            synthetic.append(path)
    if not datasets:
        sys.exit("error: no dataset folder with a database.db found")
    if args.camera_setup != "database":
        rewritten = [camera_setup_dataset(args, d) for d in datasets]
        synthetic = [r for d, r in zip(datasets, rewritten) if d in synthetic]
        datasets = rewritten
        # The READMEs' reference figures are for the databases as they are.
        args.stock_relative += [os.path.basename(d) for d in datasets]
    mappers = []
    if not args.skip_global:
        mappers.append("global")
    if not args.skip_incremental:
        mappers.append("incremental")
    if args.reference_colmap:
        mappers.append("reference")
    if not mappers:
        sys.exit("error: no mapper to run")

    def repeats_of(dataset):
        if args.repeats is not None:
            return args.repeats
        return (DEFAULT_SYNTHETIC_REPEATS if dataset in synthetic
                else DEFAULT_REPEATS)

    repeats = {}
    if any(d not in synthetic for d in datasets):
        repeats["datasets"] = repeats_of(next(d for d in datasets
                                              if d not in synthetic))
    if synthetic:
        repeats["synthetic scenes"] = repeats_of(synthetic[0])
    meta = {
        "date": datetime.datetime.now().strftime("%Y-%m-%d %H:%M"),
        "command": command,
        "cwd": cwd,
        "argv": sys.argv,
        "machine": machine_info(),
        "colmap": binary_info(args.colmap, REPO_DIR),
        "seeds": args.seeds,
        "repeats": repeats,
        "mappers": mappers,
        "pose_auc_thresholds": args.pose_thresholds or "1,3,5,10",
        "camera_setup": camera_setup_label(args.camera_setup,
                                           args.camera_model,
                                           args.exif_error),
    }
    if args.reference_colmap:
        meta["reference_colmap"] = binary_info(args.reference_colmap)
    for line in provenance_lines(meta):
        log(line)

    schedules = [(dataset, run_schedule(mappers, args.seeds,
                                        repeats_of(dataset)))
                 for dataset in datasets]
    records = []
    total = sum(len(schedule) for _, schedule in schedules)
    index = 0
    results_path = os.path.join(args.output_dir, "results.json")
    for dataset, schedule in schedules:
        for mapper, seed, repeat in schedule:
            index += 1
            records.append(run_one(args, dataset, mapper, seed, index, total,
                                   repeat, repeats_of(dataset)))
            # Written after every run so that an interrupted benchmark keeps
            # what it measured.
            with open(results_path, "w") as f:
                json.dump({"meta": meta, "runs": records}, f, indent=2)

    bars = compute_bars(args, records, datasets)
    met, met_line = all_bars_met(bars)
    table = markdown_tables(records, meta)
    if bars:
        table += "\n" + bars_table(bars, beyond_label(records))
    with open(results_path, "w") as f:
        json.dump({"meta": meta, "runs": records, "bars": bars,
                   "all_bars_met": met}, f, indent=2)
    with open(os.path.join(args.output_dir, "results.md"), "w") as f:
        f.write("# Benchmark: global_mapper vs. incremental mapper\n\n")
        f.write(table)
    plots = write_plots(summary_records(records), args.output_dir)
    log("")
    log(table)
    log("Wrote %s" % ", ".join(
        [results_path, os.path.join(args.output_dir, "results.md")] + plots))
    if args.readme:
        auc_plot = next((p for p in plots if "auc" in p), None)
        update_readme(args.readme, table, auc_plot)
        log("Updated %s" % args.readme)
    if bars:
        log(met_line)


if __name__ == "__main__":
    main()
