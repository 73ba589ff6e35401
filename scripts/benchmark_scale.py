#!/usr/bin/env python3
"""Scale benchmark of our `colmap global_mapper` on synthetic scenes (issue
14): how the time and the memory of every stage grow with the number of
images.

For every size (--sizes, default 1,000, 2,000, 5,000 and 10,000 images),
layout (--layouts: `grid`, the aerial survey, and `forward`, a long street
driven forward with one image per metre) and seed (--seeds), the synthetic
generator (make_synthetic_scene beside --colmap) writes a scene with unknown
focal length (--prior_focal_length 0), 1 px keypoint noise, 30% wrong raw
matches and ground-truth two-view verification, and the mapper runs on it
once, from a fresh output folder. Recorded per run:
  - the wall time of every stage, from the mapper's log lines
    `Stage <name>: <seconds> s (...)`, "other" (the wall time outside the
    stages: start-up, writing the models) and the total wall time of the
    mapper process;
  - the peak resident memory of the mapper process itself: the ru_maxrss of
    os.wait4() on its pid (that child's own rusage, not the maximum over all
    children of this script, which RUSAGE_CHILDREN would give after a larger
    generator run), or the largest sample below if that is higher (the
    kernel's RSS counters lag by up to a few hundred kB);
  - the peak resident memory per stage: VmRSS of /proc/<pid>/status sampled
    every --sample_interval_s seconds, each sample attributed to the stage
    that is running (from the mapper's `Stage <name> ...` and `Stage <name>:
    ...` lines, read from its log as they appear); when the process's
    high-water mark (VmHWM) rises between two samples of the same stage with
    no stage line in between, that mark counts for the stage too. Samples
    between and after the stages go to "other" (those before the first
    stage, "start-up", only to results.json). A stage shorter than the
    interval may get no sample ("–"); the whole-process peak is exact in
    any case;
  - registered images, the pairwise pose AUC at 1/3/5 degrees and the median
    rotation error of `colmap model_evaluator` against the scene's gt/
    model. The rotation error is the evaluator's `rot_err_median_deg`: the
    median over all pairs of registered images of the angle of
    R_rel_est * R_rel_gt^T, the relative-rotation error, which needs no
    alignment of the model to the ground truth (pairs with an unregistered
    image count in the AUC as failures, not in this median).
Scene generation (its time and peak memory, measured the same way) and the
evaluation are recorded separately and are not part of the mapper's figures.

Then, per layout, the slope of every stage's time and peak memory, of the
total time and of the whole-process peak memory against the number of images
on the log-log plot: the least-squares line through (log n, log value) over
the sizes whose run succeeded (medians over the seeds). Slopes above 1.2
(issue 14: "no stage's time or memory grows faster than about n^1.2") are
flagged.

Writes to --output_dir: results.json (after every run, so an interrupted
benchmark keeps what it measured), results.md (provenance, then per layout a
time table and a memory table, then the slopes), time_vs_images.png and
memory_vs_images.png (gnuplot, log-log, one panel per layout, one line per
stage, the total / whole process in black and a grey n^1.2 reference line;
skipped with a message without gnuplot). With --readme, also replaces the
README's scale section (<!-- scale-benchmark:begin --> ...
<!-- scale-benchmark:end -->; created before the benchmark section if
missing) and copies both plots to docs/benchmark/ beside it.

Scenes are cached under <output_dir>/scenes/ with a stamp (the generator's
options and the sha256 of make_synthetic_scene, as scripts/benchmark.py does)
and generated anew when either changes. Every mapper run starts in a fresh
folder under <output_dir>/runs/. A run that times out (--timeout_s) or whose
process dies is recorded as such and the benchmark goes on; Ctrl-C stops the
run in progress (recorded as interrupted), writes the reports of what was
measured and exits. --resume keeps the successful, evaluated runs of an
earlier results.json in --output_dir that ran the same mapper command with
the same colmap binary (by sha256), and runs the rest.

The issue's figures (hours on a small machine; run it alone on it):
    nice -n 10 python3 scripts/benchmark_scale.py --readme README.md

Check the script's own logic (no colmap needed): --self_test.

Only the Python standard library is used, with scripts/benchmark.py's
helpers (provenance, model analysis and evaluation, stage parsing, scene
stamps); gnuplot draws the plots.
"""

import argparse
import datetime
import json
import math
import os
import re
import shlex
import shutil
import signal
import statistics
import subprocess
import sys
import tempfile
import threading
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import benchmark as bm  # noqa: E402  (scripts/benchmark.py)

log = bm.log

REPO_DIR = bm.REPO_DIR
DEFAULT_OUTPUT = os.path.join(REPO_DIR, "build", "benchmark_scale")
DEFAULT_SIZES = [1000, 2000, 5000, 10000]
# Generator layouts and the names the reports use for them.
LAYOUT_LABELS = {"grid": "survey", "forward": "street", "ring": "ring"}
DEFAULT_LAYOUTS = ["grid", "forward"]
# make_synthetic_scene's options of every scene, besides --layout,
# --num_images, --random_seed (and --num_threads, which only its "colmap"
# verification uses and which is therefore not part of the scene's stamp).
GENERATOR_OPTIONS = ["--verification", "ground_truth",
                     "--wrong_match_ratio", "0.3",
                     "--prior_focal_length", "0",
                     "--pixel_noise_px", "1"]
# Pose AUC thresholds reported, in degrees (model_evaluator's default set
# 1,3,5,10 contains them).
AUC_THRESHOLDS = ["1", "3", "5"]
# Issue 14: no stage's time or memory grows faster than about n^SLOPE_BAR.
SLOPE_BAR = 1.2
# A stage whose time at the largest size is below this share of the total is
# marked negligible next to its flag (its slope is mostly timer noise).
NEGLIGIBLE_SHARE = 0.01
DEFAULT_SAMPLE_INTERVAL_S = 0.2
# A guard against a hung run, not a budget: the 10,000-image runs may take
# hours on a small machine.
DEFAULT_TIMEOUT_S = 43200
# Name of the time and memory outside every stage.
OTHER = "other"
# Memory samples before the first stage (process start, reading the
# options): kept in results.json, not in the tables (OTHER is what comes
# between and after the stages).
STARTUP = "start-up"
SCENE_STAMP = bm.SCENE_STAMP
README_BEGIN = "<!-- scale-benchmark:begin -->"
README_END = "<!-- scale-benchmark:end -->"
README_HEADING = "## Scale benchmark"
PLOT_FILES = ["time_vs_images.png", "memory_vs_images.png"]
# Where --readme copies the plots, relative to the README, with this prefix.
README_PLOT_DIR = os.path.join("docs", "benchmark")
README_PLOT_PREFIX = "scale_"

# The mapper's line at the start of a stage, e.g. "I1201 12:00:00.1
# global_mapper.cc:28] Stage Rotation averaging ..."; the end line is
# benchmark.STAGE_RE ("Stage Rotation averaging: 1.234 s (...)").
STAGE_BEGIN_RE = re.compile(r"\bStage\s+([A-Za-z][\w \-/]*?)\s*\.\.\.\s*$")
# The generator's summary line.
GENERATOR_RE = re.compile(r"Wrote\s+(\d+)\s+images,\s*(\d+)\s+cameras,\s*"
                          r"(\d+)\s+points,\s*(\d+)\s+verified pairs")


def stage_key(name):
    """A stage's name as benchmark.parse_stages writes it ("Rotation
    averaging" -> "rotation_averaging")."""
    return name.strip().replace(" ", "_").lower()


# --------------------------------------------------------------------------
# Measuring a process: wall time, own peak memory, memory per stage
# --------------------------------------------------------------------------

class StageTracker:
    """Follows a growing log file and knows which stage is running.
    poll() reads the lines written since the last call and returns (stage,
    whether a stage line was read): STARTUP before the first stage line,
    None between and after the stages."""

    def __init__(self, path):
        self.path = path
        self.offset = 0
        self.partial = ""
        self.current = STARTUP

    def feed(self, text):
        """Processes text appended to the log; whether it held a stage
        line."""
        changed = False
        lines = (self.partial + text).split("\n")
        self.partial = lines.pop()  # Incomplete until its newline arrives.
        for line in lines:
            begin = STAGE_BEGIN_RE.search(line)
            if begin:
                self.current = stage_key(begin.group(1))
                changed = True
            elif bm.STAGE_RE.search(line):
                self.current = None
                changed = True
        return changed

    def poll(self):
        try:
            with open(self.path, "rb") as f:
                f.seek(self.offset)
                data = f.read()
        except OSError:
            data = b""
        self.offset += len(data)
        changed = self.feed(data.decode("utf-8", errors="replace"))
        return self.current, changed


def unfinished_stage(log_path):
    """The stage a log ends in (begun, not finished); None if it ends
    between stages."""
    tracker = StageTracker(log_path)
    stage, _ = tracker.poll()
    return stage if stage != STARTUP else None


def read_proc_memory(pid):
    """(VmRSS, VmHWM) of a live process in MB; (None, None) once it has
    exited (a zombie has no memory lines) or without /proc."""
    try:
        with open("/proc/%d/status" % pid) as f:
            text = f.read()
    except OSError:
        return None, None
    rss = re.search(r"^VmRSS:\s*(\d+)\s*kB", text, re.M)
    hwm = re.search(r"^VmHWM:\s*(\d+)\s*kB", text, re.M)
    if not rss:
        return None, None
    return (int(rss.group(1)) / 1024.0,
            int(hwm.group(1)) / 1024.0 if hwm else None)


def stage_memory(samples):
    """Peak memory per stage from samples [(stage or None, stage line read
    since the previous sample, VmRSS MB, VmHWM MB)], in order: the largest
    VmRSS sampled in the stage, and the high-water mark after a rise between
    two samples of the same stage without a stage line in between (then the
    peak was reached inside the stage). None stands for OTHER. Returns
    ({stage: peak MB}, {stage: sample count})."""
    peaks, counts = {}, {}
    previous = None
    for stage, changed, rss, hwm in samples:
        name = stage or OTHER
        counts[name] = counts.get(name, 0) + 1
        peak = peaks.get(name, 0.0)
        if rss is not None:
            peak = max(peak, rss)
        if (previous is not None and not changed and previous[0] == stage
                and hwm is not None and previous[3] is not None
                and hwm > previous[3]):
            peak = max(peak, hwm)
        peaks[name] = peak
        previous = (stage, changed, rss, hwm)
    return peaks, counts


def signal_name(number):
    try:
        return signal.Signals(number).name
    except ValueError:
        return "signal %d" % number


# Set by Ctrl-C (SIGINT) or SIGTERM once main() has installed
# request_stop(): the process being measured is killed and recorded as
# interrupted, and no further run starts. A flag instead of
# KeyboardInterrupt, so that the signal cannot land in the middle of the
# bookkeeping.
STOP = threading.Event()


def request_stop(signum, frame):
    if not STOP.is_set():
        log("\n%s: stopping after the run in progress is recorded" %
            signal_name(signum))
    STOP.set()


def measure_process(command, log_path, timeout_s=None,
                    interval_s=DEFAULT_SAMPLE_INTERVAL_S):
    """Runs command with stdout+stderr to log_path, sampling its memory.
    Returns {"exit_code" (None if killed by a signal), "signal" (name or
    None), "wall_s", "peak_rss_mb" (the process's own ru_maxrss from
    os.wait4), "timed_out", "interrupted" (Ctrl-C: the process was killed),
    "stage_peak_rss_mb", "stage_rss_samples"}; peak_rss_mb is at least
    every sample (see below). A thread waits for the
    process (os.wait4), so that its end time is exact and not rounded up to
    the next sample."""
    with open(log_path, "w") as log_file:
        log_file.write("$ " + shlex.join(command) + "\n")
        log_file.flush()
        start = time.monotonic()
        process = subprocess.Popen(command, stdout=log_file,
                                   stderr=subprocess.STDOUT)
    ended = {}
    done = threading.Event()

    def wait_for_process():
        _, status, usage = os.wait4(process.pid, 0)
        ended.update(time=time.monotonic(), status=status, usage=usage)
        done.set()

    waiter = threading.Thread(target=wait_for_process, daemon=True)
    waiter.start()
    tracker = StageTracker(log_path)
    samples = []
    timed_out = interrupted = False

    def kill():
        if not done.is_set():
            try:
                os.kill(process.pid, signal.SIGKILL)
            except OSError:
                pass

    try:
        while not done.is_set():
            if STOP.is_set():
                interrupted = True
                kill()
                break
            stage, changed = tracker.poll()
            rss, hwm = read_proc_memory(process.pid)
            if rss is not None and not done.is_set():
                samples.append((stage, changed, rss, hwm))
            elif changed and samples:
                # The stage line still separates the samples around it.
                samples[-1] = samples[-1][:1] + (True,) + samples[-1][2:]
            if timeout_s and time.monotonic() - start > timeout_s:
                timed_out = True
                kill()
                break
            done.wait(interval_s)
    except KeyboardInterrupt:
        interrupted = True
        kill()
    waiter.join()
    # Ctrl-C reaches the process too, which may end before the loop sees
    # the request.
    interrupted = interrupted or STOP.is_set()
    status = ended["status"]
    # Reaped by the thread: keep Popen from waiting for the pid again.
    process.returncode = os.waitstatus_to_exitcode(status)
    peaks, counts = stage_memory(samples)
    exit_code = signal_number = None
    if os.WIFEXITED(status):
        exit_code = os.WEXITSTATUS(status)
    elif os.WIFSIGNALED(status):
        signal_number = os.WTERMSIG(status)
    # Linux reports ru_maxrss in kB. The kernel's RSS counters are
    # synchronised lazily, so a sample can exceed it by a few hundred kB:
    # the peak is the larger of both.
    peak_mb = max([ended["usage"].ru_maxrss / 1024.0] +
                  [v for sample in samples for v in sample[2:]
                   if v is not None])
    return {"exit_code": exit_code,
            "signal": signal_name(signal_number) if signal_number else None,
            "wall_s": ended["time"] - start,
            "peak_rss_mb": peak_mb,
            "timed_out": timed_out, "interrupted": interrupted,
            "stage_peak_rss_mb": peaks, "stage_rss_samples": counts}


def process_status(measured, timeout_s):
    """"ok" or why a process did not finish normally."""
    if measured["interrupted"]:
        return "interrupted"
    if measured["timed_out"]:
        return "timeout after %d s" % timeout_s
    if measured["signal"]:
        return "killed by %s%s" % (measured["signal"],
                                   " (out of memory?)"
                                   if measured["signal"] == "SIGKILL" else "")
    if measured["exit_code"] != 0:
        return "failed: exit %d" % measured["exit_code"]
    return "ok"


# --------------------------------------------------------------------------
# Scenes and runs
# --------------------------------------------------------------------------

def generator_options(layout, num_images, seed):
    """make_synthetic_scene's options of a scene (its stamp), without
    --output_path and --num_threads."""
    return (["--layout", layout, "--num_images", str(num_images)] +
            GENERATOR_OPTIONS + ["--random_seed", str(seed)])


def run_name(layout, num_images, seed):
    return "%s_%d_seed%d" % (layout, num_images, seed)


def make_scene(args, layout, num_images, seed):
    """The scene's folder under <output_dir>/scenes/, generated unless a
    cached one has a matching stamp, and its record {"path", "status",
    "cached", "wall_s", "peak_rss_mb", "verified_pairs", ...}."""
    tool = os.path.join(os.path.dirname(args.colmap), "make_synthetic_scene")
    path = os.path.join(args.output_dir, "scenes",
                        run_name(layout, num_images, seed))
    stamp_path = os.path.join(path, SCENE_STAMP)
    options = generator_options(layout, num_images, seed)
    record = {"path": path, "options": options}
    cached = os.path.isfile(os.path.join(path, "database.db"))
    if not os.path.exists(tool):
        if cached:
            log("  scene: %s not found, using the cached %s unchecked" % (
                tool, path))
            old = bm.read_stamp(stamp_path) or {}
            record.update(old.get("generation") or {})
            record.update(status="ok", cached=True)
            return record
        record["status"] = "failed: %s not found" % tool
        return record
    stamp = bm.scene_stamp(tool, options)
    if cached:
        old = bm.read_stamp(stamp_path)
        if bm.stamp_matches(old, stamp):
            record.update(old.get("generation") or {})
            record.update(status="ok", cached=True)
            log("  scene: cached %s (stamp matches; generated in %s s, "
                "%s MB)" % (path, bm.fmt(record.get("wall_s")),
                            bm.fmt(record.get("peak_rss_mb"), 0)))
            return record
        log("  scene: %s is stale (%s), generated anew" % (
            path, "no stamp" if old is None else
            "other options" if old.get("options") != options
            else "other generator"))
    if os.path.isdir(path):
        shutil.rmtree(path)
    os.makedirs(path)
    command = ([tool, "--output_path", path] + options +
               ["--num_threads", str(args.num_threads)])
    log("  scene: $ " + shlex.join(command))
    log_path = os.path.join(path, "generator_log.txt")
    measured = measure_process(command, log_path, args.timeout_s,
                               args.sample_interval_s)
    status = process_status(measured, args.timeout_s)
    generation = {"wall_s": round(measured["wall_s"], 3),
                  "peak_rss_mb": round(measured["peak_rss_mb"], 1)
                  if measured["peak_rss_mb"] is not None else None}
    with open(log_path, errors="replace") as f:
        match = GENERATOR_RE.search(f.read())
    if match:
        generation.update(points=int(match.group(3)),
                          verified_pairs=int(match.group(4)))
    record.update(generation)
    record.update(status=status, cached=False, log=log_path)
    if status == "ok" and not os.path.isfile(os.path.join(path,
                                                          "database.db")):
        record["status"] = "failed: no database.db"
    if record["status"] != "ok":
        record["error"] = bm.last_lines(log_path)
        log("  scene: %s: %s" % (record["status"], " | ".join(
            record["error"])))
        return record
    # Written last: an interrupted generation leaves no stamp.
    stamp["generation"] = generation
    with open(stamp_path, "w") as f:
        json.dump(stamp, f, indent=2)
    log("  scene: generated in %.1f s, peak %s MB%s" % (
        measured["wall_s"], bm.fmt(generation["peak_rss_mb"], 0),
        ", %d verified pairs" % generation["verified_pairs"]
        if "verified_pairs" in generation else ""))
    return record


def mapper_command(args, database, image_path, output_path, seed):
    return ([args.colmap, "global_mapper", "--database_path", database,
             "--image_path", image_path, "--output_path", output_path,
             "--GlobalMapper.random_seed", str(seed),
             "--GlobalMapper.num_threads", str(args.num_threads)] +
            args.mapper_args)


def command_key(command):
    """What makes two mapper runs the same run: the command without the
    binary and the paths (which differ per output folder)."""
    key, skip = [], False
    for word in command[1:]:
        if skip:
            skip = False
            continue
        if word in ("--database_path", "--image_path", "--output_path"):
            skip = True
            continue
        key.append(word)
    return key


def run_mapper(args, scene, layout, num_images, seed):
    """One mapper run on a scene, from a fresh folder; its record."""
    work = os.path.join(args.output_dir, "runs",
                        run_name(layout, num_images, seed))
    if os.path.isdir(work):
        shutil.rmtree(work)
    os.makedirs(work)
    # The mapper opens the database read-only (immutable): the scene's own
    # file is used, no copy (a 10,000-image database is large).
    database = os.path.join(scene["path"], "database.db")
    image_path = os.path.join(work, "no_images")
    os.makedirs(image_path)
    output_path = os.path.join(work, "sparse")
    os.makedirs(output_path)
    log_path = os.path.join(work, "log.txt")
    command = mapper_command(args, database, image_path, output_path, seed)
    record = {"layout": layout, "label": LAYOUT_LABELS.get(layout, layout),
              "images": num_images, "seed": seed, "work": work,
              "command": command, "command_key": command_key(command),
              "colmap_sha256": args.colmap_sha256, "scene": scene,
              "log": log_path}
    before = os.stat(database)
    log("  mapper: $ " + shlex.join(command))
    measured = measure_process(command, log_path, args.timeout_s,
                               args.sample_interval_s)
    record["status"] = process_status(measured, args.timeout_s)
    record.update(
        wall_time_s=round(measured["wall_s"], 3),
        peak_rss_mb=round(measured["peak_rss_mb"], 1)
        if measured["peak_rss_mb"] is not None else None,
        exit_code=measured["exit_code"], signal=measured["signal"],
        stages=bm.parse_stages(log_path),
        stage_peak_rss_mb={k: round(v, 1) for k, v in
                           measured["stage_peak_rss_mb"].items()},
        stage_rss_samples=measured["stage_rss_samples"])
    record.update(bm.parse_finish(log_path))
    if record["status"] != "ok":
        record["unfinished_stage"] = unfinished_stage(log_path)
    after = os.stat(database)
    if (before.st_size, before.st_mtime) != (after.st_size, after.st_mtime):
        log("  warning: the mapper changed %s" % database)
        record["database_changed"] = True
    if record["status"] != "ok":
        record["error"] = bm.last_lines(log_path)
        return record

    model_path, analysis = bm.pick_model(args.colmap, output_path)
    if model_path is None:
        record["status"] = "failed: no model"
        record["error"] = bm.last_lines(log_path)
        return record
    record["model_path"] = model_path
    record.update(analysis)
    start = time.monotonic()
    metrics, error = bm.evaluate_model(
        args.colmap, model_path, os.path.join(scene["path"], "gt"),
        os.path.join(work, "evaluation.json"), None)
    record["evaluation_s"] = round(time.monotonic() - start, 3)
    if metrics is not None:
        record["evaluation"] = metrics
    else:
        record["evaluation_error"] = error
    return record


def run_summary_lines(record):
    """What is printed after a run."""
    ev = record.get("evaluation") or {}
    head = "  %s, %s s, peak %s MB" % (
        record["status"], bm.fmt(record.get("wall_time_s"), 2),
        bm.fmt(record.get("peak_rss_mb"), 0))
    if ev:
        head += ", %d/%d registered, AUC@1/3/5 %s/%s/%s, median rotation " \
                "error %s deg" % (ev["registered"], ev["images"],
                                  bm.fmt(ev.get("auc@1")),
                                  bm.fmt(ev.get("auc@3")),
                                  bm.fmt(ev.get("auc@5")),
                                  fmt_deg(ev.get("rot_err_median_deg")))
    elif record.get("evaluation_error"):
        head += ", evaluation failed: %s" % " ".join(
            record["evaluation_error"])
    lines = [head]
    memory = record.get("stage_peak_rss_mb") or {}
    stages = ["%s %.2f s/%s MB" % (name, seconds,
                                   bm.fmt(memory.get(name), 0))
              for name, seconds in merged_stages(record)]
    if stages:
        lines.append("  stages: " + ", ".join(stages))
    if record.get("error"):
        lines.append("  last lines: " + " | ".join(
            line if len(line) <= 200 else line[:197] + "..."
            for line in record["error"]))
    return lines


# --------------------------------------------------------------------------
# Summaries and slopes
# --------------------------------------------------------------------------

def merged_stages(record):
    """[(stage, seconds)] in log order, a repeated stage summed."""
    times = bm.stage_times(record)
    return [(name, times[name]) for name in bm.stage_order([record])]


def other_time(record):
    """Wall time outside the stages (start-up, writing the models)."""
    if record.get("wall_time_s") is None or not record.get("stages"):
        return None
    return max(0.0, record["wall_time_s"] - sum(bm.stage_times(record)
                                                .values()))


def median_or_none(values):
    values = [v for v in values if v is not None]
    return statistics.median(values) if values else None


def summarize(records, layout, num_images):
    """One row per layout and size: the medians over the successful runs
    (seeds) of every figure; the status of the first run if none
    succeeded. None if there is no run."""
    runs = [r for r in records
            if r["layout"] == layout and r["images"] == num_images]
    if not runs:
        return None
    ok = [r for r in runs if r["status"] == "ok"]
    row = {"layout": layout, "images": num_images, "runs": len(runs),
           "ok_runs": len(ok), "status": "ok" if ok else runs[0]["status"],
           "failed": ["seed %d: %s" % (r["seed"], status_text(r))
                      for r in runs if r["status"] != "ok"]}
    if not ok:
        row["status_text"] = status_text(runs[0])
    # Without a successful run, what the failed ones measured (stages they
    # finished, time and memory until they stopped); never in the slopes and
    # plots, which take the successful rows only.
    pool = ok or runs
    names = bm.stage_order(pool)
    for r in pool:
        # A stage a run stopped in has memory samples, no time.
        if r.get("unfinished_stage") and r["unfinished_stage"] not in names:
            names.append(r["unfinished_stage"])
    row["stage_names"] = names
    row["time"] = {name: median_or_none(bm.stage_times(r).get(name)
                                        for r in pool) for name in names}
    row["time"][OTHER] = median_or_none(other_time(r) for r in ok)
    row["memory"] = {name: median_or_none(
        (r.get("stage_peak_rss_mb") or {}).get(name) for r in pool)
        for name in names + [OTHER]}
    row["total_s"] = median_or_none(r.get("wall_time_s") for r in pool)
    row["peak_rss_mb"] = median_or_none(r.get("peak_rss_mb") for r in pool)
    evaluations = [r["evaluation"] for r in ok if r.get("evaluation")]
    row["registered"] = median_or_none(e.get("registered")
                                       for e in evaluations)
    row["gt_images"] = evaluations[0]["images"] if evaluations else None
    if row["registered"] is None:
        row["registered"] = median_or_none(r.get("registered") for r in ok)
    for t in AUC_THRESHOLDS:
        row["auc@" + t] = median_or_none(e.get("auc@" + t)
                                         for e in evaluations)
    row["rot_err_median_deg"] = median_or_none(
        e.get("rot_err_median_deg") for e in evaluations)
    scenes = [r.get("scene") or {} for r in runs]
    row["generation_s"] = median_or_none(s.get("wall_s") for s in scenes)
    row["generation_peak_rss_mb"] = median_or_none(
        s.get("peak_rss_mb") for s in scenes)
    row["evaluation_s"] = median_or_none(r.get("evaluation_s") for r in ok)
    return row


def status_text(record):
    """A run's status, with the stage it stopped in when it did not
    finish."""
    text = record["status"]
    if record.get("unfinished_stage"):
        text += " in %s" % record["unfinished_stage"]
    return text


def fit_slope(points):
    """Least-squares slope of log(value) against log(images) over points
    [(images, value)], skipping values that are None or not positive; None
    with fewer than two distinct sizes."""
    pts = [(math.log(n), math.log(v)) for n, v in points
           if v is not None and v > 0 and n > 0]
    if len({x for x, _ in pts}) < 2:
        return None
    mean_x = sum(x for x, _ in pts) / len(pts)
    mean_y = sum(y for _, y in pts) / len(pts)
    sxx = sum((x - mean_x) ** 2 for x, _ in pts)
    sxy = sum((x - mean_x) * (y - mean_y) for x, y in pts)
    return sxy / sxx


def layout_order(records, layouts=None):
    order = list(layouts or [])
    for r in records:
        if r["layout"] not in order:
            order.append(r["layout"])
    return [layout for layout in order
            if any(r["layout"] == layout for r in records)]


def layout_rows(records, layout):
    sizes = sorted({r["images"] for r in records if r["layout"] == layout})
    return [summarize(records, layout, n) for n in sizes]


def ok_rows_and_stage_names(rows):
    """The successful rows, and the names of their stages in the order they
    first appear."""
    ok = [r for r in rows if r and r["status"] == "ok"]
    names = []
    for r in ok:
        for name in r["stage_names"]:
            if name not in names:
                names.append(name)
    return ok, names


def slopes(rows):
    """Per stage (then OTHER, then "total"), the time and memory slopes over
    the successful rows: [{"name", "time_slope", "memory_slope", "points",
    "time_at_max", "memory_at_max", "share_at_max", "flags"}]."""
    ok, names = ok_rows_and_stage_names(rows)
    result = []
    largest = max(ok, key=lambda r: r["images"]) if ok else None
    for name in names + [OTHER, "total"]:
        if name == "total":
            times = [(r["images"], r["total_s"]) for r in ok]
            memory = [(r["images"], r["peak_rss_mb"]) for r in ok]
        else:
            times = [(r["images"], r["time"].get(name)) for r in ok]
            memory = [(r["images"], r["memory"].get(name)) for r in ok]
        entry = {"name": name, "time_slope": fit_slope(times),
                 "memory_slope": fit_slope(memory),
                 "points": len([1 for _, v in times
                                if v is not None and v > 0])}
        if largest:
            entry["images_at_max"] = largest["images"]
            entry["time_at_max"] = (largest["total_s"] if name == "total"
                                    else largest["time"].get(name))
            entry["memory_at_max"] = (
                largest["peak_rss_mb"] if name == "total"
                else largest["memory"].get(name))
            if entry["time_at_max"] is not None and largest["total_s"]:
                entry["share_at_max"] = (entry["time_at_max"] /
                                         largest["total_s"])
        entry["flags"] = [what for what, slope in
                          (("time", entry["time_slope"]),
                           ("memory", entry["memory_slope"]))
                          if slope is not None and slope > SLOPE_BAR]
        result.append(entry)
    return result


# --------------------------------------------------------------------------
# Reports
# --------------------------------------------------------------------------

def fmt_deg(value):
    return "–" if value is None else "%.3f" % value


def fmt_slope(value):
    return "–" if value is None else "%.2f" % value


def layout_title(layout):
    return "%s (`%s` layout)" % (LAYOUT_LABELS.get(layout, layout), layout)


def setup_line(meta):
    """How the scenes were made and the mapper run."""
    return ("Scenes: `make_synthetic_scene --layout L --num_images N %s "
            "--random_seed S` (seeds %s; unknown focal length, 1 px noise, "
            "30%% wrong matches); mapper: `colmap global_mapper "
            "--GlobalMapper.random_seed S --GlobalMapper.num_threads %d%s`, "
            "once per scene, from a fresh output folder; peak memory "
            "sampled every %g s per stage." % (
                " ".join(GENERATOR_OPTIONS),
                ",".join(str(s) for s in meta["seeds"]),
                meta["num_threads"],
                "".join(" " + shlex.quote(a) for a in meta["mapper_args"]),
                meta["sample_interval_s"]))


def layout_tables(records, layout, several_seeds):
    """The time table, the memory table and the slope table of one
    layout."""
    rows = [r for r in layout_rows(records, layout) if r]
    names = []
    for r in rows:
        for name in r["stage_names"]:
            if name not in names:
                names.append(name)
    lines = ["### %s" % layout_title(layout), ""]
    note = " (median over the seeds)" if several_seeds else ""
    lines.append("Wall time per stage (s)%s, total, peak memory of the "
                 "mapper process and accuracy against ground truth (a run "
                 "that did not finish: what it measured until it "
                 "stopped):" % note)
    lines.append("")
    header = (["images"] + names + [OTHER, "total", "peak memory",
                                    "registered"] +
              ["AUC@%s°" % t for t in AUC_THRESHOLDS] +
              ["median rot. error"])
    lines.append("| " + " | ".join(header) + " |")
    lines.append("|" + "---|" * len(header))
    for r in rows:
        cells = [str(r["images"])]
        cells += [bm.fmt(r["time"].get(n), 2) for n in names]
        cells += [bm.fmt(r["time"].get(OTHER), 2),
                  bm.fmt(r["total_s"], 2),
                  bm.fmt(r["peak_rss_mb"], 0, " MB")]
        if r["status"] != "ok":
            registered = "**%s**" % r["status_text"]
        else:
            registered = ("–" if r["registered"] is None else
                          "%g/%s" % (r["registered"],
                                     r["gt_images"] or r["images"]))
            if r["failed"]:
                registered += " (%s)" % "; ".join(r["failed"])
        cells.append(registered)
        cells += [bm.fmt(r["auc@" + t]) for t in AUC_THRESHOLDS]
        cells.append(fmt_deg(r["rot_err_median_deg"]) + "°"
                     if r["rot_err_median_deg"] is not None else "–")
        lines.append("| " + " | ".join(cells) + " |")
    lines.append("")
    lines.append("Peak resident memory per stage (MB)%s, whole mapper "
                 "process, and, apart, the scene generation and the "
                 "evaluation:" % note)
    lines.append("")
    header = (["images"] + names + [OTHER, "whole process",
                                    "scene generation", "evaluation"])
    lines.append("| " + " | ".join(header) + " |")
    lines.append("|" + "---|" * len(header))
    for r in rows:
        cells = [str(r["images"])]
        cells += [bm.fmt(r["memory"].get(n), 0) for n in names + [OTHER]]
        cells.append(bm.fmt(r["peak_rss_mb"], 0))
        cells.append("%s s, %s MB" % (bm.fmt(r["generation_s"]),
                                      bm.fmt(r["generation_peak_rss_mb"], 0))
                     if r["generation_s"] is not None else "–")
        cells.append(bm.fmt(r["evaluation_s"], 1, " s"))
        lines.append("| " + " | ".join(cells) + " |")
    lines.append("")
    entries = slopes(rows)
    ok_sizes = [r["images"] for r in rows if r["status"] == "ok"]
    if len(set(ok_sizes)) >= 2:
        lines.append("Log-log slopes (least squares over n = %s; bar: "
                     "%g):" % (", ".join(str(n) for n in sorted(ok_sizes)),
                               SLOPE_BAR))
        lines.append("")
        lines.append(slope_table(entries))
    else:
        lines.append("Log-log slopes: need successful runs at two sizes "
                     "at least.")
        lines.append("")
    return "\n".join(lines)


def slope_table(entries):
    lines = ["| stage | time slope | memory slope | time at n = %s "
             "| peak memory at n = %s | above n^%g |" % (
                 entries[0].get("images_at_max", "?") if entries else "?",
                 entries[0].get("images_at_max", "?") if entries else "?",
                 SLOPE_BAR),
             "|---|---|---|---|---|---|"]
    for e in entries:
        name = "total / whole process" if e["name"] == "total" else e["name"]
        flag = "**%s**" % " and ".join(e["flags"]) if e["flags"] else "no"
        share = e.get("share_at_max")
        if ("time" in e["flags"] and share is not None and
                share < NEGLIGIBLE_SHARE and e["name"] != "total"):
            flag += " (time negligible: %.1f%% of the total)" % (100 * share)
        time_cell = bm.fmt(e.get("time_at_max"), 2, " s")
        if share is not None and e["name"] != "total":
            time_cell += " (%.1f%%)" % (100 * share)
        lines.append("| %s | %s | %s | %s | %s | %s |" % (
            name, fmt_slope(e["time_slope"]), fmt_slope(e["memory_slope"]),
            time_cell, bm.fmt(e.get("memory_at_max"), 0, " MB"), flag))
    return "\n".join(lines) + "\n"


def all_slopes(records, layouts):
    return {layout: slopes(layout_rows(records, layout))
            for layout in layout_order(records, layouts)}


def verdict_line(slope_map):
    """One line: whether any slope is above the bar."""
    above = ["%s %s (%s)" % (LAYOUT_LABELS.get(layout, layout), e["name"],
                             " and ".join(e["flags"]))
             for layout, entries in slope_map.items() for e in entries
             if e["flags"]]
    checked = any(e["time_slope"] is not None
                  for entries in slope_map.values() for e in entries)
    if not checked:
        return "Slopes above %g: not checked (fewer than two sizes)." % (
            SLOPE_BAR)
    if not above:
        return "Slopes above %g: none." % SLOPE_BAR
    return "Slopes above %g: %s." % (SLOPE_BAR, "; ".join(above))


def markdown_report(records, meta):
    """Provenance, then the tables of every layout, then the notes."""
    lines = bm.provenance_lines(meta) + [setup_line(meta), ""]
    several_seeds = len(meta["seeds"]) > 1
    for layout in layout_order(records, meta.get("layouts")):
        lines.append(layout_tables(records, layout, several_seeds))
    lines.append(verdict_line(all_slopes(records, meta.get("layouts"))))
    lines.append("")
    kept = ["%s %d (seed %d)" % (LAYOUT_LABELS.get(r["layout"], r["layout"]),
                                 r["images"], r["seed"])
            for r in records if r.get("resumed")]
    if kept:
        lines.append("Kept from an earlier invocation with the same colmap "
                     "binary (--resume): %s." % ", ".join(kept))
        lines.append("")
    lines.append(
        "Stage times: the mapper's `Stage <name>: <s> s` lines; other: the "
        "wall time outside the stages (start-up, writing the models); "
        "total: wall time of the mapper process. Peak memory: resident set "
        "size; whole process: its own ru_maxrss (os.wait4; or the largest "
        "sample if higher); per stage: the "
        "largest VmRSS sampled every %g s while the stage ran (or the "
        "process's high-water mark when it rose within the stage), \"–\" for "
        "a stage shorter than the interval; other: the samples between and "
        "after the stages. Registered: ground-truth images "
        "in the model. AUC: pairwise, the larger of the relative-rotation "
        "and translation-direction errors, a pair with an unregistered "
        "image counting as a failure, in percent. Median rot. error: median "
        "relative-rotation error over the pairs of registered images "
        "(`model_evaluator`'s rot_err_median_deg; needs no alignment). "
        "Slopes: least-squares fit of log(value) on log(images); a stage "
        "whose time at the largest size is below %g%% of the total is "
        "marked negligible. Scene generation and evaluation are not part "
        "of the mapper's figures." % (meta["sample_interval_s"],
                                       100 * NEGLIGIBLE_SHARE))
    return "\n".join(lines) + "\n"


# --------------------------------------------------------------------------
# Plots
# --------------------------------------------------------------------------

def plot_series(rows):
    """(names, data lines) of one layout's plot data: per successful size,
    images, then every stage's and OTHER's time, the total, every stage's and
    OTHER's peak memory and the whole process's ("?" where missing)."""
    ok, names = ok_rows_and_stage_names(rows)
    names.append(OTHER)

    def cell(value):
        return "%.6g" % value if value is not None and value > 0 else "?"

    data = []
    for r in ok:
        values = ([r["images"]] + [r["time"].get(n) for n in names] +
                  [r["total_s"]] + [r["memory"].get(n) for n in names] +
                  [r["peak_rss_mb"]])
        data.append(" ".join([str(r["images"])] +
                             [cell(v) for v in values[1:]]))
    return names, data


def plot_script(panels, png, what, sizes, pngcairo=True):
    """gnuplot script of one log-log figure with one panel per layout.
    panels: [(title, data path, stage names, anchor (images, value) of the
    n^SLOPE_BAR reference or None)]; what: "time" or "memory"."""
    lines = [
        "set terminal pngcairo size %d,720 noenhanced font ',10'" % (
            900 * max(1, len(panels))) if pngcairo else
        "set terminal png size %d,720" % (900 * max(1, len(panels))),
        "set output '%s'" % png,
        "set datafile missing '?'",
        "set logscale xy",
        "set grid xtics ytics mxtics mytics",
        "set xlabel 'images'",
        "set ylabel '%s'" % ("wall time (s)" if what == "time"
                             else "peak resident memory (MB)"),
        "set key outside right top vertical font ',9'",
        "set xtics (%s)" % ", ".join("'%d' %d" % (n, n) for n in sizes),
        # A margin of a quarter of a size step around the sizes (gnuplot
        # would extend a log axis to whole decades).
        "set xrange [%g:%g]" % (min(sizes or [1]) / 1.25,
                                max(sizes or [1]) * 1.25),
        "set multiplot layout 1,%d title '%s against images (log-log)'" % (
            max(1, len(panels)), "Wall time per stage" if what == "time"
            else "Peak memory per stage"),
    ]
    for title, data_path, names, anchor in panels:
        count = len(names)
        start = 2 if what == "time" else 3 + count
        plots = []
        for k, name in enumerate(names):
            # OTHER dotted in dark grey, apart from the stages' colours.
            style = ("dt 3 lc rgb '#555555'" if name == OTHER else
                     "lc rgb '%s'" % bm.STAGE_COLORS[k % len(bm.STAGE_COLORS)])
            plots.append("'%s' using 1:%d with linespoints lw 2 pt 7 ps 0.6 "
                         "%s title '%s'" % (data_path, start + k, style,
                                            name))
        plots.append("'%s' using 1:%d with linespoints lw 3 pt 5 ps 0.8 "
                     "lc rgb 'black' title '%s'" % (
                         data_path, start + count,
                         "total" if what == "time" else "whole process"))
        if anchor:
            n0, v0 = anchor
            plots.append("%.10g * x**%g with lines dt 2 lw 2 lc rgb "
                         "'#888888' title 'n^%g'" % (v0 / n0 ** SLOPE_BAR,
                                                      SLOPE_BAR, SLOPE_BAR))
        lines.append("set title '%s'" % title)
        lines.append("plot " + ", \\\n     ".join(plots))
    lines.append("unset multiplot")
    return "\n".join(lines) + "\n"


def write_plots(records, layouts, output_dir):
    """time_vs_images.png and memory_vs_images.png; the written paths."""
    gnuplot = shutil.which("gnuplot")
    if not gnuplot:
        log("gnuplot not found: no plots (apt-get install gnuplot-nox)")
        return []
    panels = {"time": [], "memory": []}
    sizes = set()
    for layout in layout_order(records, layouts):
        rows = layout_rows(records, layout)
        names, data = plot_series(rows)
        if not data:
            continue
        ok = [r for r in rows if r and r["status"] == "ok"]
        sizes.update(r["images"] for r in ok)
        data_path = os.path.join(output_dir, "scale_%s.dat" % layout)
        with open(data_path, "w") as f:
            f.write("# images, time (s) of: %s, total; peak memory (MB) "
                    "of: %s, whole process\n" % (", ".join(names),
                                                  ", ".join(names)))
            f.write("\n".join(data) + "\n")
        smallest = ok[0]
        title = layout_title(layout).replace("`", "")
        panels["time"].append((title, data_path, names,
                               (smallest["images"], smallest["total_s"])
                               if smallest["total_s"] else None))
        panels["memory"].append((title, data_path, names,
                                 (smallest["images"],
                                  smallest["peak_rss_mb"])
                                 if smallest["peak_rss_mb"] else None))
    if not panels["time"]:
        log("no successful run: no plots")
        return []
    pngcairo = bm.has_pngcairo(gnuplot)
    written = []
    for what, name in zip(("time", "memory"), PLOT_FILES):
        png = os.path.join(output_dir, name)
        if os.path.exists(png):
            os.remove(png)
        script = plot_script(panels[what], png, what, sorted(sizes),
                             pngcairo)
        with open(os.path.join(output_dir, name[:-4] + ".gp"), "w") as f:
            f.write(script)
        if bm.run_gnuplot(gnuplot, script, png):
            written.append(png)
    return written


# --------------------------------------------------------------------------
# README
# --------------------------------------------------------------------------

def read_text(path):
    with open(path, errors="replace") as f:
        return f.read()


def update_readme(readme_path, report, plots):
    """Replaces the README's scale section (README_BEGIN ... README_END)
    with the report (provenance first, then the plots, copied to
    docs/benchmark/ beside the README, then the tables). Without the
    section, a "## Scale benchmark" section is inserted before the heading
    of the benchmark section (benchmark.README_BEGIN), or appended."""
    readme_dir = os.path.dirname(os.path.abspath(readme_path))
    provenance, _, tables = report.partition("\n\n")
    section = [README_BEGIN, "", provenance, ""]
    titles = {"time_vs_images.png": "Wall time per stage against images",
              "memory_vs_images.png": "Peak memory per stage against images"}
    for plot in plots:
        name = os.path.basename(plot)
        target = os.path.join(readme_dir, README_PLOT_DIR,
                              README_PLOT_PREFIX + name)
        os.makedirs(os.path.dirname(target), exist_ok=True)
        shutil.copyfile(plot, target)
        section += ["![%s](%s)" % (titles.get(name, name),
                                   os.path.relpath(target, readme_dir)), ""]
    section += [tables.rstrip(), "", README_END]
    block = "\n".join(section)
    text = read_text(readme_path) if os.path.exists(readme_path) else ""
    if README_BEGIN in text and README_END in text:
        head, rest = text.split(README_BEGIN, 1)
        _, tail = rest.split(README_END, 1)
        text = head + block + tail
    elif bm.README_BEGIN in text:
        head, tail = text.split(bm.README_BEGIN, 1)
        # Before the benchmark section's heading, if it has one.
        head_lines = head.rstrip("\n").split("\n")
        if head_lines and head_lines[-1].startswith("#"):
            heading = head_lines.pop()
            head = "\n".join(head_lines).rstrip("\n") + "\n\n"
            tail = heading + "\n\n" + bm.README_BEGIN + tail
        else:
            tail = bm.README_BEGIN + tail
        text = head + README_HEADING + "\n\n" + block + "\n\n" + tail
    else:
        text = (text.rstrip("\n") + "\n\n" + README_HEADING + "\n\n" + block
                + "\n")
    with open(readme_path, "w") as f:
        f.write(text)


# --------------------------------------------------------------------------
# Self-test
# --------------------------------------------------------------------------

def self_test():
    """Checks of the slopes, the stage tracking and memory attribution, the
    tables, the plot scripts and the README update on made-up input, and of
    measure_process on small Python children; no colmap."""
    checks = [0]

    def expect(condition, what):
        checks[0] += 1
        if not condition:
            raise AssertionError("self-test failed: " + what)

    # Slopes.
    sizes = [1000, 2000, 5000, 10000]
    expect(abs(fit_slope([(n, 3e-4 * n ** 1.5) for n in sizes]) - 1.5)
           < 1e-9, "slope of n^1.5")
    expect(abs(fit_slope([(n, 7.0) for n in sizes])) < 1e-12,
           "constant: slope 0")
    expect(abs(fit_slope([(1000, 1.0), (2000, None), (4000, 4.0),
                          (8000, 0.0)]) - 1.0) < 1e-9,
           "None and 0 are skipped")
    expect(fit_slope([(1000, 1.0), (1000, 2.0)]) is None and
           fit_slope([]) is None, "one size: no slope")
    # Least squares, not the end points: (1,1), (2,4), (4,4) in log2.
    slope = fit_slope([(2, 2.0), (4, 16.0), (16, 16.0)])
    expect(abs(slope - 6.0 / 7.0) < 1e-9, "least squares: %r" % slope)

    # The stage tracker on a log written in pieces.
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "log.txt")
        tracker = StageTracker(path)
        expect(tracker.poll() == (STARTUP, False), "no log yet")
        with open(path, "w") as f:
            f.write("I1201 12:00:00.1 global_mapper.cc:28] Stage Database "
                    "...\nI1201 12:00:00.2 x.cc:1] Reading\nI1201 Stage "
                    "Rotation aver")
        expect(tracker.poll() == ("database", True), "a begin line")
        with open(path, "a") as f:
            f.write("aging ...\n")
        expect(tracker.poll() == ("rotation_averaging", True),
               "a line completed by the next write")
        expect(tracker.poll() == ("rotation_averaging", False),
               "nothing new")
        with open(path, "a") as f:
            f.write("I1201 global_mapper.cc:38] Stage Rotation averaging: "
                    "1.250 s (images=5)\n")
        expect(tracker.poll() == (None, True), "an end line")
        with open(path, "a") as f:
            f.write("I1201 Stage Tracks ...\nI1201 Stage Tracks: 0.500 s "
                    "(tracks=3)\nI1201 Stage Global positioning: 2 s\n"
                    "I1201 Stage Bundle adjustment ...\n")
        expect(tracker.poll() == ("bundle_adjustment", True),
               "several lines at once")
        # The same log through benchmark.parse_stages.
        expect(bm.parse_stages(path) == [["rotation_averaging", 1.25],
                                         ["tracks", 0.5],
                                         ["global_positioning", 2.0]],
               "parse_stages: %r" % bm.parse_stages(path))

    # Memory per stage.
    peaks, counts = stage_memory([
        (STARTUP, False, 5.0, 5.0),
        (None, True, 10.0, 10.0),
        ("database", True, 50.0, 60.0),
        ("database", False, 40.0, 80.0),   # peak 80 inside the stage
        ("tracks", True, 30.0, 95.0),      # rise across a stage line
        ("tracks", False, 35.0, 95.0),
        (None, True, 20.0, 95.0),
        (None, True, 25.0, 99.0),          # a stage line in between
    ])
    expect(peaks == {STARTUP: 5.0, OTHER: 25.0, "database": 80.0,
                     "tracks": 35.0}, "peaks per stage: %r" % peaks)
    expect(counts == {STARTUP: 1, OTHER: 3, "database": 2, "tracks": 2},
           "counts")

    # Commands and keys.
    expect(generator_options("grid", 1000, 3) ==
           ["--layout", "grid", "--num_images", "1000", "--verification",
            "ground_truth", "--wrong_match_ratio", "0.3",
            "--prior_focal_length", "0", "--pixel_noise_px", "1",
            "--random_seed", "3"], "generator options")
    expect(command_key(["/b/colmap", "global_mapper", "--database_path",
                        "/x/db", "--output_path", "/y", "--image_path",
                        "/z", "--GlobalMapper.random_seed", "0"]) ==
           ["global_mapper", "--GlobalMapper.random_seed", "0"],
           "command key")

    # Tables and slopes on made-up runs: time ~ n^1 except rotation
    # averaging ~ n^1.5; memory ~ n^0.5.
    def record(layout, n, seed=0, status="ok"):
        stages = [["database", 1e-3 * n], ["rotation_averaging",
                                           1e-5 * n ** 1.5],
                  ["camera_clustering", 1e-7 * n ** 1.4]]
        r = {"layout": layout, "label": LAYOUT_LABELS[layout], "images": n,
             "seed": seed, "status": status,
             "scene": {"wall_s": 0.01 * n, "peak_rss_mb": 0.1 * n}}
        if status != "ok":
            # Stopped in the second stage.
            r.update(stages=stages[:1], wall_time_s=60.0, peak_rss_mb=250.0,
                     stage_peak_rss_mb={"database": 200.0,
                                        "rotation_averaging": 250.0},
                     unfinished_stage="rotation_averaging")
            return r
        r.update(stages=stages, wall_time_s=sum(s for _, s in stages) + 0.5,
                 peak_rss_mb=3 * n ** 0.5,
                 stage_peak_rss_mb={"database": 2 * n ** 0.5,
                                    "rotation_averaging": 3 * n ** 0.5,
                                    OTHER: 1.0 * n ** 0.5},
                 evaluation={"images": n, "registered": n, "auc@1": 50.0,
                             "auc@3": 80.0, "auc@5": 90.0,
                             "rot_err_median_deg": 0.0123},
                 evaluation_s=1.0)
        return r

    records = [record(layout, n) for n in sizes
               for layout in ("grid", "forward")]
    records[-1] = record("forward", 10000, status="timeout after 60 s")
    meta = {"command": "python3 scripts/benchmark_scale.py --sizes 1000",
            "cwd": "/work/main", "date": "today", "seeds": [0],
            "layouts": ["grid", "forward"], "num_threads": -1,
            "mapper_args": [], "sample_interval_s": 0.2,
            "machine": {"cpu": "Test CPU", "cores": 2, "memory_gib": 23.5,
                        "kernel": "Linux 6.1.0"},
            "colmap": {"path": "/r/build/bin/colmap", "build_type": "Release",
                       "source": "/r", "commit": "abc1234"}}
    entries = {e["name"]: e for e in slopes(layout_rows(records, "grid"))}
    expect(abs(entries["rotation_averaging"]["time_slope"] - 1.5) < 1e-9 and
           entries["rotation_averaging"]["flags"] == ["time"] and
           abs(entries["database"]["time_slope"] - 1.0) < 1e-9 and
           entries["database"]["flags"] == [] and
           abs(entries["total"]["memory_slope"] - 0.5) < 1e-9 and
           entries["camera_clustering"]["memory_slope"] is None,
           "slopes: %r" % entries)
    report = markdown_report(records, meta)
    expect(report.startswith("Command: `python3 scripts/benchmark_scale.py "
                             "--sizes 1000` (in `/work/main`).\n"),
           "provenance first:\n" + report[:200])
    expect("### survey (`grid` layout)" in report and
           "### street (`forward` layout)" in report and
           report.index("### survey") < report.index("### street"),
           "one section per layout, in order")
    # Every row of a table has as many cells as its header.
    widths = {}
    header = None
    for line in report.split("\n"):
        if not line.startswith("|"):
            header = None
            continue
        if header is None:
            header = line.count("|")
        widths.setdefault(header, []).append(line.count("|"))
    expect(all(all(c == h for c in counts) for h, counts in widths.items()),
           "rows as wide as their header")
    expect("| 10000 | 10.00 | – | – | – | 60.00 | 250 MB | **timeout "
           "after 60 s in rotation_averaging** | – | – | – | – |" in report
           and "| 10000 | 200 | 250 | – | – | 250 | 100.0 s, 1000 MB | – |"
           in report, "a timed-out run:\n" + report)
    expect("| rotation_averaging | 1.50 | 0.50 |" in report and
           "**time**" in report, "the slope table flags 1.5")
    expect("| camera_clustering | 1.40 | – |" in report and
           "time negligible" in report, "a negligible stage is marked")
    expect("Log-log slopes (least squares over n = 1000, 2000, 5000; "
           in report, "the street's fit leaves out the timed-out size")
    expect("| 1000 | 1.00 | 0.32 | 0.00 | 0.50 | 1.82 | 95 MB | 1000/1000 "
           "| 50.0 | 80.0 | 90.0 | 0.012° |" in report,
           "a time row:\n" + report)
    expect("| 1000 | 63 | 95 | – | 32 | 95 | 10.0 s, 100 MB | 1.0 s |"
           in report, "a memory row:\n" + report)
    expect("Kept from an earlier" not in report and
           "(--resume): survey 1000 (seed 0)." in markdown_report(
               [dict(records[0], resumed=True)] + records[1:], meta),
           "resumed runs are named")
    expect("Slopes above 1.2: survey rotation_averaging (time); survey "
           "camera_clustering (time); street rotation_averaging (time); "
           "street camera_clustering (time)." in report,
           "the verdict line")
    two_seeds = records + [dict(record("grid", 1000, seed=1),
                                wall_time_s=10.0)]
    row = summarize(two_seeds, "grid", 1000)
    expect(row["runs"] == 2 and
           row["total_s"] == (records[0]["wall_time_s"] + 10.0) / 2,
           "median over seeds")
    failed_seed = records + [record("grid", 1000, seed=1,
                                    status="killed by SIGKILL")]
    expect("1000/1000 (seed 1: killed by SIGKILL in rotation_averaging)"
           in markdown_report(failed_seed, dict(meta, seeds=[0, 1])),
           "a failed seed is named")

    # Plot scripts.
    names, data = plot_series(layout_rows(records, "forward"))
    expect(names == ["database", "rotation_averaging", "camera_clustering",
                     OTHER] and len(data) == 3 and
           data[0].split() == ["1000", "1", "0.316228", "0.00158489", "0.5",
                               "1.81781", "63.2456", "94.8683", "?",
                               "31.6228", "94.8683"],
           "plot data: %r %r" % (names, data[:1]))
    script = plot_script([("survey", "/o/a.dat", names, (1000, 2.0)),
                          ("street", "/o/b.dat", names, None)],
                         "/o/time.png", "time", sizes)
    expect("set logscale xy" in script and "set output '/o/time.png'"
           in script and "set multiplot layout 1,2" in script and
           script.count("'/o/a.dat' using 1:") == 5 and
           "'/o/a.dat' using 1:6 with linespoints lw 3" in script and
           script.count("x**1.2") == 1 and
           "set xtics ('1000' 1000, '2000' 2000, '5000' 5000, '10000' 10000)"
           in script, "time plot script:\n" + script)
    script = plot_script([("survey", "/o/a.dat", names, (1000, 2.0))],
                         "/o/m.png", "memory", sizes)
    expect("'/o/a.dat' using 1:7 with" in script and
           "'/o/a.dat' using 1:11 with linespoints lw 3" in script and
           "title 'whole process'" in script, "memory plot script:\n" +
           script)

    # The README section: inserted before the benchmark section, then
    # replaced.
    with tempfile.TemporaryDirectory() as tmp:
        readme = os.path.join(tmp, "README.md")
        with open(readme, "w") as f:
            f.write("# t\n\n## Evaluation\n\ntext\n\n## Benchmark\n\n%s\n"
                    "old\n%s\n" % (bm.README_BEGIN, bm.README_END))
        plot = os.path.join(tmp, "time_vs_images.png")
        with open(plot, "wb") as f:
            f.write(b"png")
        update_readme(readme, report, [plot])
        text = read_text(readme)
        expect(text.index(README_HEADING) > text.index("## Evaluation") and
               text.index(README_END) < text.index("## Benchmark\n\n" +
                                                   bm.README_BEGIN) and
               "![Wall time per stage against images](docs/benchmark/"
               "scale_time_vs_images.png)" in text and
               os.path.isfile(os.path.join(tmp, "docs", "benchmark",
                                           "scale_time_vs_images.png")),
               "README insertion:\n" + text)
        update_readme(readme, report.replace("today", "tomorrow"), [])
        text2 = read_text(readme)
        expect(text2.count(README_BEGIN) == 1 and "tomorrow" in text2 and
               "today" not in text2 and "old" in text2 and
               text2.count("## Benchmark") == 1, "README replacement")
        plain = os.path.join(tmp, "PLAIN.md")
        with open(plain, "w") as f:
            f.write("# p\n")
        update_readme(plain, report, [])
        expect(read_text(plain).startswith("# p\n\n## Scale benchmark\n\n"
                                             + README_BEGIN),
               "README without a benchmark section")

    # measure_process on small children: the own peak of each child (a
    # 300 MB child first must not raise the next one's), stages, a
    # timeout and a killed child.
    child = ("import sys, time\n"
             "print('Stage Big ...', flush=True)\n"
             "block = bytearray(int(sys.argv[1]) * 1024 * 1024)\n"
             "for k in range(0, len(block), 4096): block[k] = 1\n"
             "time.sleep(float(sys.argv[2]))\n"
             "print('Stage Big: 0.1 s (x=1)', flush=True)\n"
             "del block\n"
             "sys.exit(int(sys.argv[3]))\n")
    with tempfile.TemporaryDirectory() as tmp:
        log_path = os.path.join(tmp, "log.txt")
        # From a file: the log's first line is the command.
        child_path = os.path.join(tmp, "child.py")
        with open(child_path, "w") as f:
            f.write(child)
        big = measure_process([sys.executable, child_path, "300", "0.3",
                               "0"], log_path, None, 0.05)
        small = measure_process([sys.executable, child_path, "20", "0.5",
                                 "3"], log_path, None, 0.05)
        expect(big["peak_rss_mb"] >= 300 and big["exit_code"] == 0 and
               process_status(big, 1) == "ok", "big child: %r" % big)
        expect(small["peak_rss_mb"] < 150 and small["exit_code"] == 3 and
               process_status(small, 1) == "failed: exit 3",
               "the small child's own peak, not the big one's: %r" % small)
        expect(small["stage_peak_rss_mb"].get("big", 0) >= 20 and
               small["stage_rss_samples"].get("big", 0) >= 1,
               "memory sampled in the stage: %r" % small)
        expect(bm.parse_stages(log_path) == [["big", 0.1]] and
               read_text(log_path).startswith("$ "),
               "the log holds the command and the output")
        slow = measure_process([sys.executable, child_path, "1", "30", "0"],
                               log_path, 0.5, 0.05)
        expect(slow["timed_out"] and process_status(slow, 1) ==
               "timeout after 1 s" and slow["wall_s"] < 20,
               "timeout: %r" % slow)
        STOP.set()
        try:
            stopped = measure_process([sys.executable, child_path, "1", "30",
                                       "0"], log_path, None, 0.05)
        finally:
            STOP.clear()
        expect(stopped["interrupted"] and process_status(stopped, 1) ==
               "interrupted" and stopped["wall_s"] < 20,
               "a stop request: %r" % stopped)
        quick = measure_process([sys.executable, "-c", "pass"], log_path,
                                None, 5.0)
        expect(quick["exit_code"] == 0 and quick["wall_s"] < 4.0,
               "the end is not rounded up to the 5 s sample: %r" % quick)
        killed = measure_process([sys.executable, "-c",
                                  "import os, signal; "
                                  "os.kill(os.getpid(), signal.SIGKILL)"],
                                 log_path, None, 0.05)
        expect(process_status(killed, 1) == "killed by SIGKILL (out of "
               "memory?)", "a killed child: %r" % killed)
    print("self-test: %d checks passed" % checks[0])


# --------------------------------------------------------------------------
# Main
# --------------------------------------------------------------------------

def parse_int_list(text):
    try:
        values = [int(s) for s in text.split(",") if s.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError("not a list of integers: %r" % text)
    if not values or len(set(values)) != len(values) or min(values) < 0:
        raise argparse.ArgumentTypeError(
            "need distinct non-negative integers: %r" % text)
    return values


def parse_layouts(text):
    layouts = [s.strip() for s in text.split(",") if s.strip()]
    unknown = [x for x in layouts if x not in LAYOUT_LABELS]
    if not layouts or unknown or len(set(layouts)) != len(layouts):
        raise argparse.ArgumentTypeError(
            "need distinct layouts among %s: %r" % (
                ", ".join(sorted(LAYOUT_LABELS)), text))
    return layouts


def load_previous(path):
    try:
        with open(path) as f:
            return json.load(f).get("runs") or []
    except (OSError, ValueError, AttributeError):
        return []


def write_reports(args, meta, records, final):
    """results.json always; results.md, plots and README when final."""
    results_path = os.path.join(args.output_dir, "results.json")
    slope_map = all_slopes(records, args.layouts)
    with open(results_path, "w") as f:
        json.dump({"meta": meta, "runs": records,
                   "slopes": slope_map}, f, indent=2)
    if not final:
        return
    report = markdown_report(records, meta)
    md_path = os.path.join(args.output_dir, "results.md")
    with open(md_path, "w") as f:
        f.write("# Scale benchmark of `global_mapper`\n\n" + report)
    plots = write_plots(records, args.layouts, args.output_dir)
    log("")
    log(report)
    log("Wrote %s" % ", ".join([results_path, md_path] + plots))
    if args.readme:
        update_readme(args.readme, report, plots)
        log("Updated %s" % args.readme)
    log("Reproduce with: %s (in %s)" % (meta["command"], meta["cwd"]))


def main():
    parser = argparse.ArgumentParser(
        description=__doc__.split("\n\n")[0],
        formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--sizes", type=parse_int_list,
                        default=DEFAULT_SIZES, metavar="N,N,...",
                        help="numbers of images (default: %s)" % ",".join(
                            str(n) for n in DEFAULT_SIZES))
    parser.add_argument("--layouts", type=parse_layouts,
                        default=DEFAULT_LAYOUTS, metavar="L,L,...",
                        help="generator layouts: grid (survey), forward "
                        "(street), ring (default: %(default)s)")
    parser.add_argument("--seeds", type=parse_int_list, default=[0],
                        metavar="S,S,...", help="one scene and one run per "
                        "seed (the generator's --random_seed and "
                        "--GlobalMapper.random_seed); the tables show "
                        "medians over the seeds (default: 0)")
    parser.add_argument("--colmap", default=bm.DEFAULT_COLMAP,
                        help="our colmap binary; make_synthetic_scene is "
                        "taken from the same folder (default: %(default)s)")
    parser.add_argument("--output_dir", default=DEFAULT_OUTPUT,
                        help="runs, reports and plots; scenes are cached in "
                        "its scenes/ (default: %(default)s)")
    parser.add_argument("--num_threads", type=int, default=-1,
                        help="threads of the generator and of the mapper "
                        "(--GlobalMapper.num_threads; -1: all cores; "
                        "default: %(default)s)")
    parser.add_argument("--timeout_s", type=int, default=DEFAULT_TIMEOUT_S,
                        help="seconds before a generator or mapper run is "
                        "stopped and recorded as timed out; 0: never "
                        "(default: %(default)s)")
    parser.add_argument("--sample_interval_s", type=float,
                        default=DEFAULT_SAMPLE_INTERVAL_S,
                        help="interval of the memory samples (default: "
                        "%(default)s)")
    parser.add_argument("--mapper_args", "--extra", default="",
                        metavar="'ARGS'", help="more options of the mapper, "
                        "one shell-quoted string, e.g. "
                        "--mapper_args='--GlobalMapper.skip_retriangulation "
                        "1'")
    parser.add_argument("--resume", action="store_true",
                        help="keep the successful runs of <output_dir>/"
                        "results.json that ran the same mapper command with "
                        "the same colmap binary; run the others")
    parser.add_argument("--readme", metavar="README.md",
                        help="also put the report and the plots into this "
                        "README's scale section")
    parser.add_argument("--self_test", action="store_true",
                        help="check the script's logic on made-up input, "
                        "then exit")
    args = parser.parse_args()
    if args.self_test:
        self_test()
        return
    command, cwd = bm.format_command(sys.argv, os.getcwd())
    log("$ " + command)
    args.colmap = os.path.abspath(args.colmap)
    args.output_dir = os.path.abspath(args.output_dir)
    args.mapper_args = shlex.split(args.mapper_args)
    if args.sample_interval_s <= 0:
        sys.exit("error: --sample_interval_s must be positive")
    if not os.access(args.colmap, os.X_OK):
        sys.exit("error: %s is not an executable (build the colmap target "
                 "first or pass --colmap)" % args.colmap)
    args.colmap_sha256 = bm.file_sha256(args.colmap)
    os.makedirs(args.output_dir, exist_ok=True)

    meta = {
        "date": datetime.datetime.now().strftime("%Y-%m-%d %H:%M"),
        "command": command, "cwd": cwd, "argv": sys.argv,
        "machine": bm.machine_info(),
        "colmap": dict(bm.binary_info(args.colmap, REPO_DIR),
                       sha256=args.colmap_sha256),
        "sizes": args.sizes, "layouts": args.layouts, "seeds": args.seeds,
        "num_threads": args.num_threads, "mapper_args": args.mapper_args,
        "timeout_s": args.timeout_s,
        "sample_interval_s": args.sample_interval_s,
        "generator_options": GENERATOR_OPTIONS,
    }
    for line in bm.provenance_lines(meta) + [setup_line(meta)]:
        log(line)

    previous = load_previous(os.path.join(args.output_dir, "results.json")) \
        if args.resume else []
    schedule = [(n, layout, seed) for n in sorted(args.sizes)
                for layout in args.layouts for seed in args.seeds]
    records = []
    interrupted = False
    signal.signal(signal.SIGINT, request_stop)
    signal.signal(signal.SIGTERM, request_stop)
    try:
        for index, (n, layout, seed) in enumerate(schedule, 1):
            title = "[%d/%d] %s, %d images, seed %d" % (
                index, len(schedule), layout_title(layout).replace("`", ""),
                n, seed)
            key = command_key(mapper_command(args, "", "", "", seed))
            kept = next((r for r in previous
                         if r.get("layout") == layout and
                         r.get("images") == n and r.get("seed") == seed and
                         r.get("status") == "ok" and
                         r.get("evaluation") and
                         r.get("command_key") == key and
                         r.get("colmap_sha256") == args.colmap_sha256 and
                         os.path.isdir(r.get("work") or "")), None)
            if kept:
                log(title + ": kept from the earlier results.json (--resume)")
                records.append(dict(kept, resumed=True))
                continue
            log(title + " ...")
            scene = make_scene(args, layout, n, seed)
            if scene["status"] != "ok":
                records.append({"layout": layout,
                                "label": LAYOUT_LABELS.get(layout, layout),
                                "images": n, "seed": seed, "scene": scene,
                                "status": "scene " + scene["status"]})
            else:
                record = run_mapper(args, scene, layout, n, seed)
                records.append(record)
                for line in run_summary_lines(record):
                    log(line)
            write_reports(args, meta, records, final=False)
            if STOP.is_set():
                interrupted = True
                break
    except KeyboardInterrupt:  # Only before the handlers are installed.
        interrupted = True
    if interrupted:
        done = len([r for r in records if r["status"] != "interrupted"
                    and r["status"] != "scene interrupted"])
        log("interrupted: %d of %d runs done; the reports cover them (run "
            "again with --resume to finish)" % (done, len(schedule)))
        meta["interrupted"] = True
    write_reports(args, meta, records, final=True)
    if interrupted:
        sys.exit(130)


if __name__ == "__main__":
    main()
