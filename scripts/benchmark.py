#!/usr/bin/env python3
"""Side-by-side benchmark of our `colmap global_mapper` and COLMAP's stock
incremental `mapper`.

For every dataset folder (a `database.db`, optionally an `images/` folder and a
ground-truth model in `gt/`), both mappers run one after the other, each on its
own copy of the database. Recorded per run: wall time (and, for the global
mapper, the time of each stage from its log lines `Stage <name>: <seconds> s`),
peak memory, registered images, mean reprojection error and mean track length
(`colmap model_analyzer`), and the ground-truth metrics (`colmap
model_evaluator`: pairwise pose AUC at 1/3/5/10 degrees, camera position
errors).

Writes to --output_dir: results.json, results.md (Markdown tables),
runtime_per_stage.png and auc_per_dataset.png (gnuplot). With --readme, also
replaces the benchmark section of the README and copies the AUC plot next to
it.

Regenerate the README's figures with:
    python3 scripts/benchmark.py --readme README.md

Only the Python standard library is used (gnuplot draws the plots).
"""

import argparse
import datetime
import json
import os
import platform
import re
import shutil
import subprocess
import sys
import time

REPO_DIR = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DEFAULT_COLMAP = os.path.join(REPO_DIR, "build", "bin", "colmap")
DEFAULT_OUTPUT = os.path.join(REPO_DIR, "build", "benchmark")
DEFAULT_DATASETS = os.path.join(os.path.dirname(REPO_DIR), "shared", "datasets")
AUC_THRESHOLDS = ["1", "3", "5", "10"]
MAPPERS = {
    "global": "global_mapper",
    "incremental": "mapper",
}
# Bar colours of the global mapper's stages in the runtime plot.
STAGE_COLORS = ["#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd",
                "#8c564b", "#e377c2", "#bcbd22", "#17becf", "#393b79",
                "#637939", "#843c39"]
# The README section that --readme replaces.
README_BEGIN = "<!-- benchmark:begin -->"
README_END = "<!-- benchmark:end -->"

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
                   position_thresholds):
    command = [colmap, "model_evaluator", "--input_path", model_path,
               "--gt_path", gt_path, "--json_path", json_path]
    if position_thresholds:
        command += ["--position_thresholds", position_thresholds]
    code, text = capture(command)
    if code != 0 or not os.path.exists(json_path):
        return None, text.strip().splitlines()[-1:] or ["no output"]
    with open(json_path) as f:
        return json.load(f), None


def parse_stages(log_path):
    stages = []
    with open(log_path, errors="replace") as f:
        for line in f:
            match = STAGE_RE.search(line)
            if match:
                name = match.group(1).strip().replace(" ", "_").lower()
                stages.append([name, float(match.group(2))])
    return stages


def last_lines(path, count=3):
    with open(path, errors="replace") as f:
        lines = [line.rstrip() for line in f if line.strip()]
    return lines[-count:]


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


def make_synthetic(args, num_images):
    tool = os.path.join(os.path.dirname(os.path.abspath(args.colmap)),
                        "make_synthetic_scene")
    path = os.path.join(args.output_dir, "scenes", "synthetic_%d" % num_images)
    if os.path.isfile(os.path.join(path, "database.db")):
        return path
    os.makedirs(path, exist_ok=True)
    if not os.path.exists(tool):
        log("synthetic scene: %s not found, skipped" % tool)
        return None
    command = [tool, "--output_path", path, "--num_images", str(num_images)]
    if num_images > 300:
        # Large scenes: an aerial survey with ground-truth verification (the
        # generator's COLMAP verification would dominate the run).
        command += ["--layout", "grid", "--verification", "ground_truth",
                    "--wrong_match_ratio", "0.3", "--prior_focal_length", "0"]
    code, text = capture(command)
    if code != 0 or not os.path.isfile(os.path.join(path, "database.db")):
        log("synthetic scene: %s failed: %s" %
            (tool, (text.strip().splitlines() or ["no output"])[-1]))
        return None
    return path


def run_one(args, dataset, mapper, index, total):
    name = os.path.basename(dataset)
    command_name = MAPPERS[mapper]
    work = os.path.join(args.output_dir, "runs", name, mapper)
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
              "status": "ok"}
    log("[%d/%d] %s: %s ..." % (index, total, name, command_name))
    command = [args.colmap, command_name, "--database_path", database,
               "--image_path", image_path, "--output_path", output_path]
    code, wall_s, peak_mb, timed_out = run_measured(command, log_path,
                                                    args.timeout)
    record.update({"wall_time_s": round(wall_s, 3), "peak_rss_mb":
                   round(peak_mb, 1) if peak_mb is not None else None,
                   "exit_code": code, "log": log_path})
    if mapper == "global":
        record["stages"] = parse_stages(log_path)

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
                args.position_thresholds)
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
    elif analysis:
        summary += ", %d registered" % analysis["registered"]
    log("[%d/%d] %s: %s %s" % (index, total, name, command_name, summary))
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


def markdown_tables(records, meta):
    lines = []
    lines.append("| dataset | mapper | wall time | peak memory | registered "
                 "| AUC@1° | AUC@3° | AUC@5° | AUC@10° | mean position error "
                 "| mean reproj. error | mean track length |")
    lines.append("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for r in records:
        mapper = "ours `global_mapper`" if r["mapper"] == "global" else \
            "COLMAP 3.8 `mapper`"
        ev = r.get("evaluation") or {}
        if r["status"] != "ok":
            registered = r["status"]
        elif ev:
            registered = "%d/%d" % (ev["registered"], ev["images"])
        else:
            registered = str(r.get("registered", "–"))
        cells = [r["dataset"], mapper, fmt(r.get("wall_time_s"), 1, " s"),
                 fmt(r.get("peak_rss_mb"), 0, " MB"), registered]
        cells += [fmt(ev.get("auc@" + t)) for t in AUC_THRESHOLDS]
        cells += [fmt_error(ev.get("pos_err_mean")),
                  fmt(r.get("mean_reproj_error_px"), 3, " px"),
                  fmt(r.get("mean_track_length"), 2)]
        lines.append("| " + " | ".join(cells) + " |")

    stage_names = stage_order(records)
    if stage_names:
        lines.append("")
        lines.append("Per-stage time of `global_mapper` (s):")
        lines.append("")
        lines.append("| dataset | " + " | ".join(stage_names) +
                     " | other | total |")
        lines.append("|---|" + "---|" * (len(stage_names) + 2))
        for r in records:
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
                 "after a robust similarity alignment, in ground-truth units.")
    lines.append("Machine: %s, %s CPUs; %s." % (
        meta["machine"], meta["cpus"], meta["date"]))
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
    gnuplot = shutil.which("gnuplot")
    if not gnuplot:
        log("gnuplot not found: no plots (apt-get install gnuplot-nox)")
        return []
    written = []
    stage_names = stage_order(records)
    columns = stage_names + ["other", "COLMAP 3.8 mapper (total)"]

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
            label = r["dataset"] + (" (global)" if r["status"] == "ok"
                                    else " (global, failed)")
        else:
            values[-1] = r["wall_time_s"]
            label = r["dataset"] + (" (incr.)" if r["status"] == "ok"
                                    else " (incr., failed)")
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
                 for k in range(len(columns) - 1)] + ["#999999"]),
            "plot for [col=2:%d] '%s' using col:xtic(1) title columnheader "
            "lc rgb word(colors, col - 1)" % (len(columns) + 1, data_path),
        ])
        if run_gnuplot(gnuplot, script, png):
            written.append(png)

    # AUC: per dataset, ours and the stock mapper, one panel per threshold.
    datasets = []
    for r in records:
        if r.get("evaluation") is not None and r["dataset"] not in datasets:
            datasets.append(r["dataset"])
    if datasets:
        data_path = os.path.join(output_dir, "auc_per_dataset.dat")
        with open(data_path, "w") as f:
            # No header line: gnuplot would count it as the first cluster.
            for name in datasets:
                values = []
                for t in AUC_THRESHOLDS:
                    for mapper in ("global", "incremental"):
                        ev = next((r.get("evaluation") for r in records
                                   if r["dataset"] == name
                                   and r["mapper"] == mapper), None) or {}
                        value = ev.get("auc@" + t)
                        values.append("%.3f" % value if value is not None
                                      else "0")
                f.write(gnuplot_label(name) + " " + " ".join(values) + "\n")
        png = os.path.join(output_dir, "auc_per_dataset.png")
        panels = []
        for k, t in enumerate(AUC_THRESHOLDS):
            panels.append("\n".join([
                "set title 'Pairwise pose AUC @ %s deg (%%)'" % t,
                "plot '%s' using %d:xtic(1) title 'ours (global)', "
                "'' using %d title 'COLMAP 3.8 incremental'"
                % (data_path, 2 + 2 * k, 3 + 2 * k),
            ]))
        script = "\n".join([
            "set terminal pngcairo size 1200,900 noenhanced" if
            has_pngcairo(gnuplot) else "set terminal png size 1200,900",
            "set output '%s'" % png,
            "set style data histograms",
            "set style histogram clustered gap 1",
            "set style fill solid 0.85 border -1",
            "set yrange [0:100]",
            "set grid ytics",
            "set key below",
            "set xrange [-0.5:%f]" % (len(datasets) - 0.5),
            "set xtics rotate by -25 left",
            "set multiplot layout 2,2",
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


def update_readme(readme_path, table, plot_path, command):
    """Replaces the README section between README_BEGIN and README_END (or
    appends one) with the table and one plot, copied beside the README."""
    readme_dir = os.path.dirname(os.path.abspath(readme_path))
    section = [README_BEGIN, "",
               "Regenerate with `%s` (on this machine; the table below is "
               "the latest run)." % command, ""]
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
    parser.add_argument("--output_dir", default=DEFAULT_OUTPUT,
                        help="where runs and reports go (default: "
                        "%(default)s)")
    parser.add_argument("--synthetic", type=int, action="append", default=[],
                        metavar="N", help="also a synthetic scene of N images "
                        "(make_synthetic_scene); may repeat")
    parser.add_argument("--skip_incremental", action="store_true",
                        help="run only our global mapper")
    parser.add_argument("--skip_global", action="store_true",
                        help="run only the stock incremental mapper")
    parser.add_argument("--position_thresholds", default="0.01,0.05,0.1",
                        help="distance thresholds of the position AUC, in "
                        "ground-truth units (default: %(default)s)")
    parser.add_argument("--timeout", type=int, default=3600,
                        help="seconds before a run is stopped (default: "
                        "%(default)s)")
    parser.add_argument("--readme", metavar="README.md",
                        help="also put the table and the AUC plot into this "
                        "README's benchmark section")
    args = parser.parse_args()
    args.colmap = os.path.abspath(args.colmap)
    args.output_dir = os.path.abspath(args.output_dir)

    if not os.access(args.colmap, os.X_OK):
        sys.exit("error: %s is not an executable (build colmap_exe first or "
                 "pass --colmap)" % args.colmap)
    datasets = find_datasets(args.datasets or [DEFAULT_DATASETS])
    os.makedirs(args.output_dir, exist_ok=True)
    for num_images in args.synthetic:
        path = make_synthetic(args, num_images)
        if path:
            datasets.append(path)
    if not datasets:
        sys.exit("error: no dataset folder with a database.db found")
    mappers = [m for m in ("global", "incremental")
               if not (m == "global" and args.skip_global)
               and not (m == "incremental" and args.skip_incremental)]

    meta = {
        "date": datetime.datetime.now().strftime("%Y-%m-%d %H:%M"),
        "machine": platform.processor() or platform.machine(),
        "cpus": os.cpu_count(),
        "colmap": args.colmap,
    }
    try:
        with open("/proc/cpuinfo") as f:
            match = re.search(r"model name\s*:\s*(.+)", f.read())
            if match:
                meta["machine"] = match.group(1).strip()
    except OSError:
        pass

    records = []
    total = len(datasets) * len(mappers)
    index = 0
    for dataset in datasets:
        for mapper in mappers:
            index += 1
            records.append(run_one(args, dataset, mapper, index, total))
            # Written after every run so that an interrupted benchmark keeps
            # what it measured.
            with open(os.path.join(args.output_dir, "results.json"), "w") as f:
                json.dump({"meta": meta, "runs": records}, f, indent=2)

    table = markdown_tables(records, meta)
    with open(os.path.join(args.output_dir, "results.md"), "w") as f:
        f.write("# Benchmark: global_mapper vs. incremental mapper\n\n")
        f.write(table)
    plots = write_plots(records, args.output_dir)
    log("")
    log(table)
    log("Wrote %s" % ", ".join(
        [os.path.join(args.output_dir, "results.json"),
         os.path.join(args.output_dir, "results.md")] + plots))
    if args.readme:
        auc_plot = next((p for p in plots if "auc" in p), None)
        update_readme(args.readme, table, auc_plot,
                      "python3 scripts/benchmark.py --readme README.md")
        log("Updated %s" % args.readme)


if __name__ == "__main__":
    main()
