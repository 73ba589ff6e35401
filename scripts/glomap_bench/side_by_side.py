"""scripts/benchmark.py's whole run: check the binaries, gather the inputs,
run every mapper on every input as scheduled, judge the bars, write the
reports (results.json after every run), plots and README section."""

import datetime
import json
import os
import sys

from glomap_bench import (REPO_DIR, bars, datasets, mappers, models,
                          provenance, report, report_plots, run, summary)

DEFAULT_OUTPUT = os.path.join(REPO_DIR, "build", "benchmark")


def check_binaries(args):
    """Makes the binaries' paths absolute and exits unless they run; sets
    args.pose_thresholds (None: the evaluator has no --pose_thresholds)."""
    args.colmap = os.path.abspath(args.colmap)
    args.output_dir = os.path.abspath(args.output_dir)
    if not os.access(args.colmap, os.X_OK):
        sys.exit("error: %s is not an executable (build colmap_exe first or "
                 "pass --colmap)" % args.colmap)
    if args.reference_colmap:
        args.reference_colmap = os.path.abspath(args.reference_colmap)
        mappers.check_reference(args.reference_colmap)
    args.pose_thresholds = models.evaluator_pose_thresholds(
        args.colmap, report.AUC_THRESHOLDS)
    if args.pose_thresholds is None:
        run.log("note: %s model_evaluator has no %s; AUC@0.5 stays empty" % (
            args.colmap, models.POSE_THRESHOLDS_OPTION))


def gather_inputs(args):
    """(the input folders, those of them that are synthetic scenes): the
    datasets, the synthetic scenes, each rewritten to --camera_setup. With a
    rewritten setup, every input becomes stock-relative."""
    inputs = datasets.find_datasets(args.datasets or
                                    [datasets.DEFAULT_DATASETS])
    os.makedirs(args.output_dir, exist_ok=True)
    synthetic = []
    for num_images in args.synthetic:
        path = datasets.make_synthetic(args, num_images)
        if path:
            inputs.append(path)
            synthetic.append(path)
    if not inputs:
        sys.exit("error: no dataset folder with a database.db found")
    if args.camera_setup != "database":
        rewritten = [datasets.camera_setup_dataset(args, d) for d in inputs]
        synthetic = [r for d, r in zip(inputs, rewritten) if d in synthetic]
        inputs = rewritten
        # The READMEs' reference figures are for the databases as they are.
        args.stock_relative += [os.path.basename(d) for d in inputs]
    return inputs, synthetic


def mapper_kinds(args):
    """The mappers to run (mappers.MAPPERS keys); exits if none."""
    kinds = []
    if not args.skip_global:
        kinds.append("global")
    if not args.skip_incremental:
        kinds.append("incremental")
    if args.reference_colmap:
        kinds.append("reference")
    if not kinds:
        sys.exit("error: no mapper to run")
    return kinds


def repeats_of(args, dataset, synthetic):
    """The runs per mapper on an input: --repeats, or the default of
    datasets or of synthetic scenes."""
    if args.repeats is not None:
        return args.repeats
    return (mappers.DEFAULT_SYNTHETIC_REPEATS if dataset in synthetic
            else mappers.DEFAULT_REPEATS)


def make_meta(args, command, cwd, inputs, synthetic, kinds):
    """results.json's "meta": provenance and the run's settings."""
    repeats = {}
    if any(d not in synthetic for d in inputs):
        repeats["datasets"] = repeats_of(
            args, next(d for d in inputs if d not in synthetic), synthetic)
    if synthetic:
        repeats["synthetic scenes"] = repeats_of(args, synthetic[0],
                                                 synthetic)
    meta = {
        "date": datetime.datetime.now().strftime("%Y-%m-%d %H:%M"),
        "command": command,
        "cwd": cwd,
        "argv": sys.argv,
        "machine": provenance.machine_info(),
        "colmap": provenance.binary_info(args.colmap, REPO_DIR),
        "seeds": args.seeds,
        "repeats": repeats,
        "mappers": kinds,
        "pose_auc_thresholds": args.pose_thresholds or "1,3,5,10",
        "camera_setup": datasets.camera_setup_label(args.camera_setup,
                                                    args.camera_model,
                                                    args.exif_error),
    }
    if args.reference_colmap:
        meta["reference_colmap"] = provenance.binary_info(
            args.reference_colmap)
    return meta


def write_json(path, content):
    with open(path, "w") as f:
        json.dump(content, f, indent=2)


def run_all(args, meta, inputs, synthetic, kinds, results_path):
    """Every scheduled run; the records. results.json is written after every
    run so that an interrupted benchmark keeps what it measured."""
    schedules = [(dataset, mappers.run_schedule(
        kinds, args.seeds, repeats_of(args, dataset, synthetic)))
        for dataset in inputs]
    records = []
    total = sum(len(schedule) for _, schedule in schedules)
    index = 0
    for dataset, schedule in schedules:
        for mapper, seed, repeat in schedule:
            index += 1
            records.append(mappers.run_one(
                args, dataset, mapper, seed, index, total, repeat,
                repeats_of(args, dataset, synthetic)))
            write_json(results_path, {"meta": meta, "runs": records})
    return records


def write_reports(args, meta, records, inputs, results_path):
    """The bars, results.json, results.md, the plots and the README
    section; prints the tables and the bars' verdict."""
    bar_rows = bars.compute_bars(args.colmap, records, inputs,
                                 args.stock_relative)
    met, met_line = bars.all_bars_met(bar_rows)
    table = report.markdown_tables(records, meta)
    if bar_rows:
        table += "\n" + bars.bars_table(bar_rows,
                                        report.beyond_label(records))
    write_json(results_path, {"meta": meta, "runs": records,
                              "bars": bar_rows, "all_bars_met": met})
    md_path = os.path.join(args.output_dir, "results.md")
    with open(md_path, "w") as f:
        f.write("# Benchmark: global_mapper vs. incremental mapper\n\n")
        f.write(table)
    plot_paths = report_plots.write_plots(summary.summary_records(records),
                                          args.output_dir)
    run.log("")
    run.log(table)
    run.log("Wrote %s" % ", ".join([results_path, md_path] + plot_paths))
    if args.readme:
        auc_plot = next((p for p in plot_paths if "auc" in p), None)
        report.update_readme(args.readme, table, auc_plot)
        run.log("Updated %s" % args.readme)
    if bar_rows:
        run.log(met_line)


def run_benchmark(args):
    """The benchmark of the parsed options of scripts/benchmark.py."""
    command, cwd = provenance.format_command(sys.argv, os.getcwd())
    run.log("$ " + command)
    check_binaries(args)
    inputs, synthetic = gather_inputs(args)
    kinds = mapper_kinds(args)
    meta = make_meta(args, command, cwd, inputs, synthetic, kinds)
    for line in report.header_lines(meta):
        run.log(line)
    results_path = os.path.join(args.output_dir, "results.json")
    records = run_all(args, meta, inputs, synthetic, kinds, results_path)
    write_reports(args, meta, records, inputs, results_path)
