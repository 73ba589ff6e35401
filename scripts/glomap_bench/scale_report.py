"""The Markdown report of scripts/benchmark_scale.py: provenance and setup,
per layout a time table, a memory table and the slopes, the verdict on the
slopes, the notes; and the README's scale section."""

import os
import shlex

from glomap_bench import parse, provenance, report, tables
from glomap_bench import scale_runs, scale_summary
from glomap_bench.scale_summary import SLOPE_BAR

# A stage whose time at the largest size is below this share of the total is
# marked negligible next to its flag (its slope is mostly timer noise).
NEGLIGIBLE_SHARE = 0.01
README_BEGIN = "<!-- scale-benchmark:begin -->"
README_END = "<!-- scale-benchmark:end -->"
README_HEADING = "## Scale benchmark"
# Prefix of the plots' names when --readme copies them beside the README.
README_PLOT_PREFIX = "scale_"
PLOT_TITLES = {
    "time_vs_images.png": "Wall time per stage against images",
    "memory_vs_images.png": "Peak memory per stage against images"}


def layout_title(layout):
    """"survey (`grid` layout)"."""
    return "%s (`%s` layout)" % (scale_runs.LAYOUT_LABELS.get(layout, layout),
                                 layout)


def setup_line(meta):
    """How the scenes were made and the mapper run."""
    return ("Scenes: `make_synthetic_scene --layout L --num_images N %s "
            "--random_seed S` (seeds %s; unknown focal length, 1 px noise, "
            "30%% wrong matches); mapper: `colmap global_mapper "
            "--GlobalMapper.random_seed S --GlobalMapper.num_threads %d%s`, "
            "once per scene, from a fresh output folder; peak memory "
            "sampled every %g s per stage." % (
                " ".join(scale_runs.GENERATOR_OPTIONS),
                ",".join(str(s) for s in meta["seeds"]),
                meta["num_threads"],
                "".join(" " + shlex.quote(a) for a in meta["mapper_args"]),
                meta["sample_interval_s"]))


def registered_cell(r):
    """The time table's "registered" cell of a row: registered/images (and
    the failed seeds), or the status of a row without a successful run."""
    if r["status"] != "ok":
        return "**%s**" % r["status_text"]
    registered = ("–" if r["registered"] is None else
                  "%g/%s" % (r["registered"], r["gt_images"] or r["images"]))
    if r["failed"]:
        registered += " (%s)" % "; ".join(r["failed"])
    return registered


def time_table(rows, names, note):
    """The lines of a layout's time table (names: the stage columns)."""
    lines = ["Wall time per stage (s)%s, total, peak memory of the "
             "mapper process and accuracy against ground truth (a run "
             "that did not finish: what it measured until it "
             "stopped):" % note, ""]
    lines += tables.header_rows(
        ["images"] + names + [parse.OTHER, "total", "peak memory",
                              "registered"] +
        ["AUC@%s°" % t for t in scale_summary.AUC_THRESHOLDS] +
        ["median rot. error"])
    for r in rows:
        cells = [str(r["images"])]
        cells += [tables.fmt(r["time"].get(n), 2) for n in names]
        cells += [tables.fmt(r["time"].get(parse.OTHER), 2),
                  tables.fmt(r["total_s"], 2),
                  tables.fmt(r["peak_rss_mb"], 0, " MB"), registered_cell(r)]
        cells += [tables.fmt(r["auc@" + t])
                  for t in scale_summary.AUC_THRESHOLDS]
        cells.append(tables.fmt_deg(r["rot_err_median_deg"]) + "°"
                     if r["rot_err_median_deg"] is not None else "–")
        lines.append(tables.table_row(cells))
    return lines + [""]


def memory_table(rows, names, note):
    """The lines of a layout's memory table (names: the stage columns)."""
    lines = ["Peak resident memory per stage (MB)%s, whole mapper "
             "process, and, apart, the scene generation and the "
             "evaluation:" % note, ""]
    lines += tables.header_rows(["images"] + names + [
        parse.OTHER, "whole process", "scene generation", "evaluation"])
    for r in rows:
        cells = [str(r["images"])]
        cells += [tables.fmt(r["memory"].get(n), 0)
                  for n in names + [parse.OTHER]]
        cells.append(tables.fmt(r["peak_rss_mb"], 0))
        cells.append("%s s, %s MB" % (
            tables.fmt(r["generation_s"]),
            tables.fmt(r["generation_peak_rss_mb"], 0))
            if r["generation_s"] is not None else "–")
        cells.append(tables.fmt(r["evaluation_s"], 1, " s"))
        lines.append(tables.table_row(cells))
    return lines + [""]


def slope_table(entries):
    """The slope table of a layout's scale_summary.slopes() entries."""
    at = entries[0].get("images_at_max", "?") if entries else "?"
    lines = ["| stage | time slope | memory slope | time at n = %s "
             "| peak memory at n = %s | above n^%g |" % (at, at, SLOPE_BAR),
             "|---|---|---|---|---|---|"]
    for e in entries:
        name = "total / whole process" if e["name"] == "total" else e["name"]
        flag = "**%s**" % " and ".join(e["flags"]) if e["flags"] else "no"
        share = e.get("share_at_max")
        if ("time" in e["flags"] and share is not None and
                share < NEGLIGIBLE_SHARE and e["name"] != "total"):
            flag += " (time negligible: %.1f%% of the total)" % (100 * share)
        time_cell = tables.fmt(e.get("time_at_max"), 2, " s")
        if share is not None and e["name"] != "total":
            time_cell += " (%.1f%%)" % (100 * share)
        lines.append("| %s | %s | %s | %s | %s | %s |" % (
            name, tables.fmt_slope(e["time_slope"]),
            tables.fmt_slope(e["memory_slope"]), time_cell,
            tables.fmt(e.get("memory_at_max"), 0, " MB"), flag))
    return "\n".join(lines) + "\n"


def layout_tables(records, layout, several_seeds):
    """The time table, the memory table and the slope table of one
    layout."""
    rows = [r for r in scale_summary.layout_rows(records, layout) if r]
    names = []
    for r in rows:
        for name in r["stage_names"]:
            if name not in names:
                names.append(name)
    note = " (median over the seeds)" if several_seeds else ""
    lines = ["### %s" % layout_title(layout), ""]
    lines += time_table(rows, names, note)
    lines += memory_table(rows, names, note)
    ok_sizes = [r["images"] for r in rows if r["status"] == "ok"]
    if len(set(ok_sizes)) >= 2:
        lines.append("Log-log slopes (least squares over n = %s; bar: "
                     "%g):" % (", ".join(str(n) for n in sorted(ok_sizes)),
                               SLOPE_BAR))
        lines.append("")
        lines.append(slope_table(scale_summary.slopes(rows)))
    else:
        lines.append("Log-log slopes: need successful runs at two sizes "
                     "at least.")
        lines.append("")
    return "\n".join(lines)


def verdict_line(slope_map):
    """One line: whether any slope is above the bar."""
    above = ["%s %s (%s)" % (scale_runs.LAYOUT_LABELS.get(layout, layout),
                             e["name"], " and ".join(e["flags"]))
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


def notes(meta):
    """The paragraph at the end of the report that explains the figures."""
    return (
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


def ratio_cell(ours, reference):
    """ours / reference to two decimals ("–" without both)."""
    if ours is None or not reference:
        return "–"
    return "%.2f" % (ours / reference)


def comparison_table(records):
    """The lines comparing our runs with the reference's (mapper
    "reference", from --reference_colmap) on the same scenes: one row per
    layout, size and seed that has a reference run; [] without any."""
    references = {(r["layout"], r["images"], r["seed"]): r for r in records
                  if r.get("mapper") == "reference"}
    if not references:
        return []
    lines = ["### Ours against the reference `global_mapper`", "",
             "Same scene, same seed and threads, the reference right after "
             "ours on a copy of the database. Ratios: ours / reference "
             "(below 1: ours is faster or smaller).", ""]
    lines += tables.header_rows(
        ["layout", "images", "seed", "time ours", "time reference",
         "time ratio", "peak ours", "peak reference", "memory ratio",
         "AUC@3° ours", "AUC@3° reference", "registered ours",
         "registered reference"])
    ours = {(r["layout"], r["images"], r["seed"]): r for r in records
            if r.get("mapper", "global") != "reference" and "scene" in r}
    for key in sorted(references, key=lambda k: (k[1], k[0], k[2])):
        ref = references[key]
        our = ours.get(key) or {}

        def ok(r, field):
            return r.get(field) if r.get("status") == "ok" else None

        def auc(r):
            return (r.get("evaluation") or {}).get("auc@3")

        def registered(r):
            ev = r.get("evaluation") or {}
            if r.get("status") != "ok":
                return "**%s**" % r.get("status", "not run")
            return "%s/%s" % (ev.get("registered", "–"),
                              ev.get("images", "–"))

        lines.append(tables.table_row([
            scale_runs.LAYOUT_LABELS.get(key[0], key[0]), str(key[1]),
            str(key[2]), tables.fmt(ok(our, "wall_time_s"), 1, " s"),
            tables.fmt(ok(ref, "wall_time_s"), 1, " s"),
            ratio_cell(ok(our, "wall_time_s"), ok(ref, "wall_time_s")),
            tables.fmt(our.get("peak_rss_mb"), 0, " MB"),
            tables.fmt(ref.get("peak_rss_mb"), 0, " MB"),
            ratio_cell(our.get("peak_rss_mb"), ref.get("peak_rss_mb")),
            tables.fmt(auc(our)), tables.fmt(auc(ref)), registered(our),
            registered(ref)]))
    return lines + [""]


def markdown_report(records, meta):
    """Provenance, then the tables of every layout (ours), the comparison
    with the reference (with --reference_colmap), then the notes."""
    comparison = comparison_table(records)
    records = [r for r in records if r.get("mapper", "global") != "reference"]
    lines = provenance.provenance_lines(meta) + [setup_line(meta), ""]
    several_seeds = len(meta["seeds"]) > 1
    for layout in scale_summary.layout_order(records, meta.get("layouts")):
        lines.append(layout_tables(records, layout, several_seeds))
    lines += comparison
    lines.append(verdict_line(scale_summary.all_slopes(
        records, meta.get("layouts"))))
    lines.append("")
    kept = ["%s %d (seed %d)" % (
        scale_runs.LAYOUT_LABELS.get(r["layout"], r["layout"]),
        r["images"], r["seed"]) for r in records if r.get("resumed")]
    if kept:
        lines.append("Kept from an earlier invocation with the same colmap "
                     "binary (--resume): %s." % ", ".join(kept))
        lines.append("")
    lines.append(notes(meta))
    return "\n".join(lines) + "\n"


def update_readme(readme_path, report_text, plot_paths):
    """Replaces the README's scale section (README_BEGIN ... README_END)
    with the report (provenance first, then the plots, copied to
    docs/benchmark/scale_<name> beside the README, then the tables).
    Without the section, a "## Scale benchmark" section is inserted before
    the heading of the benchmark section (report.README_BEGIN), or
    appended."""
    plots = [(path, PLOT_TITLES.get(os.path.basename(path),
                                    os.path.basename(path)),
              README_PLOT_PREFIX + os.path.basename(path))
             for path in plot_paths]
    tables.update_readme_section(readme_path, report_text, plots,
                                 (README_BEGIN, README_END), README_HEADING,
                                 before=report.README_BEGIN)
