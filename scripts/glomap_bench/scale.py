"""scripts/benchmark_scale.py's whole run: per size, layout and seed a scene
and a mapper run (or the run kept from an earlier results.json with
--resume), results.json after every run, and at the end (also after Ctrl-C)
the report, the plots and the README section."""

import datetime
import json
import os
import shlex
import signal
import sys

from glomap_bench import (REPO_DIR, mappers, provenance, run, scale_plots,
                          scale_report, scale_runs, scale_summary)

DEFAULT_OUTPUT = os.path.join(REPO_DIR, "build", "benchmark_scale")
DEFAULT_SIZES = [1000, 2000, 5000, 10000]
# A guard against a hung run, not a budget: the 10,000-image runs may take
# hours on a small machine.
DEFAULT_TIMEOUT_S = 43200


def load_previous(path):
    """The runs of an earlier results.json; [] without one."""
    try:
        with open(path) as f:
            return json.load(f).get("runs") or []
    except (OSError, ValueError, AttributeError):
        return []


def kept_run(args, previous, layout, num_images, seed, mapper="global"):
    """The run of `previous` that --resume keeps for this layout, size,
    seed and mapper ("global": ours, "reference"): successful, evaluated,
    the same mapper command with the same binary, its folder still there;
    None if there is none."""
    if mapper == "reference":
        key = scale_runs.command_key(
            scale_runs.reference_command(args, "", "", "", seed))
        sha256 = args.reference_colmap_sha256
    else:
        key = scale_runs.command_key(
            scale_runs.mapper_command(args, "", "", "", seed))
        sha256 = args.colmap_sha256
    return next((r for r in previous
                 if r.get("mapper", "global") == mapper and
                 r.get("layout") == layout and
                 r.get("images") == num_images and r.get("seed") == seed and
                 r.get("status") == "ok" and r.get("evaluation") and
                 r.get("command_key") == key and
                 r.get("colmap_sha256") == sha256 and
                 os.path.isdir(r.get("work") or "")), None)


def kept_elsewhere(args, previous, schedule):
    """The runs of `previous` that --resume keeps although this invocation
    does not schedule them (other sizes, layouts or seeds, measured by an
    earlier invocation with the same mapper command and binary), so that
    results.json and the reports keep them; each marked resumed."""
    scheduled = {(layout, n, seed) for n, layout, seed in schedule}
    kept, seen = [], set()
    for r in previous:
        key = (r.get("layout"), r.get("images"), r.get("seed"),
               r.get("mapper", "global"))
        if key in seen or key[:3] in scheduled:
            continue
        seen.add(key)
        if key[3] == "reference" and not args.reference_colmap:
            continue
        run_ = kept_run(args, previous, *key)
        if run_:
            kept.append(dict(run_, resumed=True))
    return kept


def write_reports(args, meta, records, final):
    """results.json always; results.md, plots and README when final. The
    tables, slopes and plots are ours; the reference's runs (with
    --reference_colmap) are compared in a table of their own."""
    results_path = os.path.join(args.output_dir, "results.json")
    ours = [r for r in records if r.get("mapper", "global") != "reference"]
    slope_map = scale_summary.all_slopes(ours, args.layouts)
    with open(results_path, "w") as f:
        json.dump({"meta": meta, "runs": records,
                   "slopes": slope_map}, f, indent=2)
    if not final:
        return
    report = scale_report.markdown_report(records, meta)
    md_path = os.path.join(args.output_dir, "results.md")
    with open(md_path, "w") as f:
        f.write("# Scale benchmark of `global_mapper`\n\n" + report)
    plots = scale_plots.write_plots(ours, args.layouts, args.output_dir)
    run.log("")
    run.log(report)
    run.log("Wrote %s" % ", ".join([results_path, md_path] + plots))
    if args.readme:
        scale_report.update_readme(args.readme, report, plots)
        run.log("Updated %s" % args.readme)
    run.log("Reproduce with: %s (in %s)" % (meta["command"], meta["cwd"]))


def prepare(args):
    """Checks and completes the options (absolute paths, the mapper's extra
    options as a list, the colmap binary's sha256); exits if they do not
    hold."""
    args.colmap = os.path.abspath(args.colmap)
    args.output_dir = os.path.abspath(args.output_dir)
    args.mapper_args = shlex.split(args.mapper_args)
    if args.sample_interval_s <= 0:
        sys.exit("error: --sample_interval_s must be positive")
    if not os.access(args.colmap, os.X_OK):
        sys.exit("error: %s is not an executable (build the colmap target "
                 "first or pass --colmap)" % args.colmap)
    args.colmap_sha256 = provenance.file_sha256(args.colmap)
    args.reference_colmap_sha256 = None
    if args.reference_colmap:
        args.reference_colmap = os.path.abspath(args.reference_colmap)
        mappers.check_reference(args.reference_colmap)
        args.reference_colmap_sha256 = provenance.file_sha256(
            args.reference_colmap)
    os.makedirs(args.output_dir, exist_ok=True)


def make_meta(args, command, cwd):
    """results.json's "meta": provenance and the run's settings."""
    return {
        "date": datetime.datetime.now().strftime("%Y-%m-%d %H:%M"),
        "command": command, "cwd": cwd, "argv": sys.argv,
        "machine": provenance.machine_info(),
        "colmap": dict(provenance.binary_info(args.colmap, REPO_DIR),
                       sha256=args.colmap_sha256),
        "sizes": args.sizes, "layouts": args.layouts, "seeds": args.seeds,
        "num_threads": args.num_threads, "mapper_args": args.mapper_args,
        "timeout_s": args.timeout_s,
        "sample_interval_s": args.sample_interval_s,
        "generator_options": scale_runs.GENERATOR_OPTIONS,
    } | ({"reference_colmap": dict(
        provenance.binary_info(args.reference_colmap, None),
        sha256=args.reference_colmap_sha256)} if args.reference_colmap
        else {})


def run_scene(args, layout, num_images, seed, previous=()):
    """The scene and the mapper runs of one layout, size and seed: ours,
    then (with --reference_colmap) the reference's, each unless --resume
    keeps it from `previous`; their records (a failed scene's record has
    no mapper figures)."""
    scene = scale_runs.make_scene(args, layout, num_images, seed)
    if scene["status"] != "ok":
        return [{"layout": layout,
                 "label": scale_runs.LAYOUT_LABELS.get(layout, layout),
                 "images": num_images, "seed": seed, "scene": scene,
                 "status": "scene " + scene["status"]}]
    records = []
    for mapper in ["global"] + (["reference"] if args.reference_colmap
                                else []):
        kept = kept_run(args, previous, layout, num_images, seed, mapper)
        if kept:
            run.log("  %s: kept from the earlier results.json (--resume)" %
                    ("reference" if mapper == "reference" else "mapper"))
            records.append(dict(kept, resumed=True))
            continue
        if run.STOP.is_set():
            break
        run_one = (scale_runs.run_reference if mapper == "reference"
                   else scale_runs.run_mapper)
        record = run_one(args, scene, layout, num_images, seed)
        for line in scale_runs.run_summary_lines(record):
            run.log(line)
        records.append(record)
    return records


def run_all(args, meta, schedule, previous, records=()):
    """Runs the schedule [(size, layout, seed)] after `records` (runs kept
    from elsewhere); (all records, whether it was interrupted).
    results.json is written after every run."""
    records = list(records)
    interrupted = False
    signal.signal(signal.SIGINT, run.request_stop)
    signal.signal(signal.SIGTERM, run.request_stop)
    try:
        for index, (n, layout, seed) in enumerate(schedule, 1):
            title = "[%d/%d] %s, %d images, seed %d" % (
                index, len(schedule),
                scale_report.layout_title(layout).replace("`", ""), n, seed)
            kept = kept_run(args, previous, layout, n, seed)
            if kept and not args.reference_colmap:
                run.log(title + ": kept from the earlier results.json "
                        "(--resume)")
                records.append(dict(kept, resumed=True))
                continue
            run.log(title + " ...")
            records += run_scene(args, layout, n, seed, previous)
            write_reports(args, meta, records, final=False)
            if run.STOP.is_set():
                interrupted = True
                break
    except KeyboardInterrupt:  # Only before the handlers are installed.
        interrupted = True
    return records, interrupted


def run_scale(args):
    """The benchmark of the parsed options of scripts/benchmark_scale.py;
    exits with 130 after Ctrl-C (the reports cover what was measured)."""
    command, cwd = provenance.format_command(sys.argv, os.getcwd())
    run.log("$ " + command)
    prepare(args)
    meta = make_meta(args, command, cwd)
    for line in (provenance.provenance_lines(meta) +
                 [scale_report.setup_line(meta)]):
        run.log(line)
    previous = load_previous(os.path.join(args.output_dir, "results.json")) \
        if args.resume else []
    schedule = [(n, layout, seed) for n in sorted(args.sizes)
                for layout in args.layouts for seed in args.seeds]
    others = kept_elsewhere(args, previous, schedule)
    if others:
        run.log("Kept from the earlier results.json besides this schedule "
                "(--resume): %s" % ", ".join(
                    "%s %d (seed %d)%s" % (
                        r["layout"], r["images"], r["seed"],
                        ", reference" if r.get("mapper") == "reference"
                        else "") for r in others))
        args.sizes = sorted(set(args.sizes) | {r["images"] for r in others})
        args.layouts = args.layouts + sorted(
            {r["layout"] for r in others} - set(args.layouts))
        args.seeds = sorted(set(args.seeds) | {r["seed"] for r in others})
        meta.update(sizes=args.sizes, layouts=args.layouts, seeds=args.seeds)
    records, interrupted = run_all(args, meta, schedule, previous, others)
    if interrupted:
        done = len([r for r in records[len(others):]
                    if r["status"] != "interrupted"
                    and r["status"] != "scene interrupted"])
        run.log("interrupted: %d of %d runs done; the reports cover them "
                "(run again with --resume to finish)" % (done,
                                                         len(schedule)))
        meta["interrupted"] = True
    write_reports(args, meta, records, final=True)
    if interrupted:
        sys.exit(130)
