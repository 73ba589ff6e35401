"""The Markdown report of scripts/benchmark.py: provenance, the main table
(per dataset and mapper, medians and spreads over seeds and repeats), the
per-stage table of our global mapper, and the README's benchmark section."""

import os

from glomap_bench import mappers, models, parse, provenance, summary, tables

# Pose AUC thresholds in degrees (upstream's benchmark reports 0.5/1/5/10).
AUC_THRESHOLDS = ["0.5", "1", "3", "5", "10"]
# The README section that --readme replaces.
README_BEGIN = "<!-- benchmark:begin -->"
README_END = "<!-- benchmark:end -->"
README_HEADING = "## Benchmark"
# What the table's notes say about the figures.
FIGURES_NOTE = (
    "AUC: pairwise, the larger of relative-rotation and "
    "translation-direction error per image pair, a pair with an "
    "unregistered image counting as a failure, in percent. "
    "Position error: mean camera-centre distance to ground truth "
    "after a robust similarity alignment, in ground-truth units. "
    "Cameras beyond: registered cameras farther than that "
    "fraction of the scene size (largest distance between two "
    "ground-truth cameras) from ground truth after the "
    "alignment. Re-placed/left out: images the global mapper's "
    "pose verification moved or deregistered.")
SEVERAL_RUNS_NOTE = (
    "Several runs (seeds `--GlobalMapper.random_seed` of "
    "ours, and repeats): a row shows the median over its "
    "runs of the wall time and of every figure, with the "
    "range (min–max) in parentheses for wall time and "
    "AUC@3°, ranges for registered, cameras beyond and "
    "re-placed/left out, and the largest peak memory; every "
    "run is in results.json.")


def runs_lines(meta):
    """The lines after the provenance: the camera setup, and how many runs
    of which mapper ran in which order."""
    lines = []
    if meta.get("camera_setup"):
        lines.append("Cameras: %s." % meta["camera_setup"])
    repeats = meta.get("repeats") or {}
    if repeats:
        names = {"global": "ours", "incremental": "stock",
                 "reference": "reference"}
        order = [names[m] for m in meta.get("mappers")
                 or mappers.MAPPER_ORDER]
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


def header_lines(meta):
    """The lines that head the report: command, source and binaries,
    machine, cameras, runs."""
    return provenance.provenance_lines(meta) + runs_lines(meta)


def beyond_label(records):
    """The cameras-beyond column's title, with the evaluator's fraction."""
    fractions = [r["evaluation"]["cameras_beyond_fraction"] for r in records
                 if (r.get("evaluation") or {}).get("cameras_beyond_fraction")
                 is not None]
    return "cameras beyond %g%%" % (100 * (fractions[0] if fractions
                                           else models.BEYOND_FRACTION))


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


def evaluation_values(runs, key):
    """The evaluation's `key` of each run (None where missing)."""
    return [(x.get("evaluation") or {}).get(key) for x in runs]


def registered_cell(r, runs, ok_runs):
    """The main table's "registered" cell of a summary row."""
    ev = r.get("evaluation") or {}
    if r["status"] != "ok":
        registered = r["status"]
    elif ev:
        registered = "%s/%d" % (tables.fmt_span(
            evaluation_values(ok_runs, "registered")), ev["images"])
    else:
        registered = tables.fmt_span([x.get("registered") for x in ok_runs])
    failed = ["%s: %s" % (summary.run_label(x), x["status"])
              for x in runs if x["status"] != "ok"]
    if failed and r["status"] == "ok":
        registered += " (%s)" % "; ".join(failed)
    return registered


def main_table_row(r):
    """The main table's row of a summary (summary.summarize_runs)."""
    runs = r.get("runs") or [r]
    ok_runs = [x for x in runs if x["status"] == "ok"] or runs
    several = len(runs) > 1
    mapper = (mappers.MAPPER_LABELS.get(r["mapper"], r["mapper"]) +
              summary.runs_note(runs))
    ev = r.get("evaluation") or {}
    wall = tables.fmt(r.get("wall_time_s"), 1, " s")
    auc3 = tables.fmt(ev.get("auc@3"))
    if several:
        wall += " (%s)" % tables.fmt_range([x.get("wall_time_s")
                                            for x in ok_runs])
        if ev.get("auc@3") is not None:
            auc3 += " (%s)" % tables.fmt_range(
                evaluation_values(ok_runs, "auc@3"))
    beyond = "–"
    if any(v is not None for v in evaluation_values(ok_runs,
                                                    "cameras_beyond")):
        beyond = tables.fmt_span(evaluation_values(ok_runs,
                                                   "cameras_beyond"))
    moved = "–"
    if r["mapper"] == "global" and any(
            x.get("replaced_images") is not None for x in ok_runs):
        moved = "%s/%s" % (
            tables.fmt_span([x.get("replaced_images") for x in ok_runs]),
            tables.fmt_span([x.get("left_out_images") for x in ok_runs]))
    cells = [r["dataset"], r.get("camera_setup") or "–", mapper, wall,
             tables.fmt(r.get("peak_rss_mb"), 0, " MB"),
             registered_cell(r, runs, ok_runs)]
    cells += [auc3 if t == "3" else tables.fmt(ev.get("auc@" + t))
              for t in AUC_THRESHOLDS]
    cells += [tables.fmt_error(ev.get("pos_err_mean")), beyond, moved,
              tables.fmt(r.get("mean_reproj_error_px"), 3, " px"),
              tables.fmt(r.get("mean_track_length"), 2)]
    return tables.table_row(cells)


def stage_table(rows, several_runs):
    """The lines of the per-stage time table of our global mapper (none
    without stage times)."""
    stage_names = parse.stage_order(rows)
    if not stage_names:
        return []
    lines = ["", "Per-stage time of our `global_mapper` (s%s):" % (
        ", median over the runs" if several_runs else ""), ""]
    lines += [tables.table_row(["dataset"] + stage_names +
                               ["other", "total"]),
              "|---|" + "---|" * (len(stage_names) + 2)]
    for r in rows:
        if r["mapper"] != "global" or not r.get("stages"):
            continue
        times = parse.stage_times(r)
        other = max(0.0, r["wall_time_s"] - sum(times.values()))
        cells = [r["dataset"]] + [tables.fmt(times.get(s), 2)
                                  for s in stage_names]
        cells += [tables.fmt(other, 2), tables.fmt(r["wall_time_s"], 2)]
        lines.append(tables.table_row(cells))
    return lines


def markdown_tables(records, meta):
    """The provenance, the main table and the per-stage table of all runs
    (records: every run, one per seed and repeat for ours)."""
    rows = summary.summary_records(records)
    several_runs = any(len(r.get("runs", [])) > 1 for r in rows)
    lines = header_lines(meta) + [""]
    lines += main_table_header(records)
    lines += [main_table_row(r) for r in rows]
    lines += stage_table(rows, several_runs)
    lines += ["", FIGURES_NOTE]
    missing = [t for t in AUC_THRESHOLDS
               if not any((r.get("evaluation") or {}).get("auc@" + t)
                          is not None for r in rows)]
    if missing and any(r.get("evaluation") for r in rows):
        lines.append("AUC@%s°: not reported by this `model_evaluator` "
                     "(it has no `%s`)." % ("°, AUC@".join(missing),
                                            models.POSE_THRESHOLDS_OPTION))
    if several_runs:
        lines.append(SEVERAL_RUNS_NOTE)
    return "\n".join(lines) + "\n"


def update_readme(readme_path, table, plot_path):
    """Replaces the README section between README_BEGIN and README_END (or
    appends one) with the tables (headed by their provenance: the command
    that made them, commit, binaries, machine) and one plot (None: none),
    copied beside the README, after the provenance."""
    plots = []
    if plot_path:
        plots.append((plot_path, "Pairwise AUC per dataset",
                      os.path.basename(plot_path)))
    tables.update_readme_section(readme_path, table, plots,
                                 (README_BEGIN, README_END), README_HEADING)
