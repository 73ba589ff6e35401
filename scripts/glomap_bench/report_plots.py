"""The plots of scripts/benchmark.py (gnuplot): wall time per run, ours
split by stage (runtime_per_stage.png), and the pairwise AUC per dataset and
mapper, one panel per threshold (auc_per_dataset.png)."""

import os

from glomap_bench import mappers, parse, plots, report

# The mappers' names in the AUC plot's key.
AUC_TITLES = {"global": "ours (global)",
              "incremental": "COLMAP 3.8 incremental",
              "reference": "reference global_mapper"}


def runtime_rows(records, stage_names, columns):
    """[label, seconds per column] of every timed row: our stages (and
    "other"), or the stock mapper's or the reference's total."""
    rows = []
    for r in records:
        if r.get("wall_time_s") is None:
            continue
        values = [0.0] * len(columns)
        if r["mapper"] == "global":
            times = parse.stage_times(r)
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
    return rows


def runtime_plot(gnuplot, records, output_dir):
    """runtime_per_stage.png: one stacked bar per run (stages of ours, total
    of the others); its path, or None if not drawn."""
    stage_names = parse.stage_order(records)
    has_reference = any(r["mapper"] == "reference" for r in records)
    totals = ["COLMAP 3.8 mapper (total)"] + (
        ["reference global_mapper (total)"] if has_reference else [])
    columns = stage_names + ["other"] + totals
    rows = runtime_rows(records, stage_names, columns)
    if not rows:
        return None
    data_path = os.path.join(output_dir, "runtime_per_stage.dat")
    with open(data_path, "w") as f:
        f.write("run " + " ".join(plots.gnuplot_label(c) for c in columns) +
                "\n")
        for row in rows:
            f.write(plots.gnuplot_label(row[0]) + " " +
                    " ".join("%.4f" % v for v in row[1:]) + "\n")
    png = os.path.join(output_dir, "runtime_per_stage.png")
    script = "\n".join([
        "set terminal pngcairo size 1200,700 noenhanced" if
        plots.has_pngcairo(gnuplot) else "set terminal png size 1200,700",
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
            [plots.STAGE_COLORS[k % len(plots.STAGE_COLORS)]
             for k in range(len(columns) - len(totals))] +
            ["#999999", "#555555"][:len(totals)]),
        "plot for [col=2:%d] '%s' using col:xtic(1) title columnheader "
        "lc rgb word(colors, col - 1)" % (len(columns) + 1, data_path),
    ])
    return png if plots.run_gnuplot(gnuplot, script, png) else None


def auc_data(records, datasets, thresholds, mapper_names):
    """The AUC plot's data lines: per dataset, its label, then per
    threshold every mapper's AUC ("0" where missing)."""
    lines = []
    for name in datasets:
        values = []
        for t in thresholds:
            for mapper in mapper_names:
                ev = next((r.get("evaluation") for r in records
                           if r["dataset"] == name
                           and r["mapper"] == mapper), None) or {}
                value = ev.get("auc@" + t)
                values.append("%.3f" % value if value is not None else "0")
        lines.append(plots.gnuplot_label(name) + " " + " ".join(values))
    return lines


def auc_plot(gnuplot, records, output_dir):
    """auc_per_dataset.png: per dataset, ours, the stock mapper and the
    reference, one panel per threshold that some row has; its path, or None
    if not drawn."""
    datasets = []
    for r in records:
        if r.get("evaluation") is not None and r["dataset"] not in datasets:
            datasets.append(r["dataset"])
    thresholds = [t for t in report.AUC_THRESHOLDS
                  if any((r.get("evaluation") or {}).get("auc@" + t)
                         is not None for r in records)]
    mapper_names = [m for m in mappers.MAPPER_ORDER
                    if any(r["mapper"] == m for r in records)]
    if not datasets or not thresholds:
        return None
    data_path = os.path.join(output_dir, "auc_per_dataset.dat")
    with open(data_path, "w") as f:
        # No header line: gnuplot would count it as the first cluster.
        for line in auc_data(records, datasets, thresholds, mapper_names):
            f.write(line + "\n")
    png = os.path.join(output_dir, "auc_per_dataset.png")
    panels = []
    for k, t in enumerate(thresholds):
        first = 2 + len(mapper_names) * k
        lines = ["'%s' using %d:xtic(1) title '%s'" % (
            data_path, first, AUC_TITLES[mapper_names[0]])]
        lines += ["'' using %d title '%s'" % (first + j, AUC_TITLES[m])
                  for j, m in enumerate(mapper_names) if j > 0]
        panels.append("\n".join([
            "set title 'Pairwise pose AUC @ %s deg (%%)'" % t,
            "plot " + ", ".join(lines),
        ]))
    columns = 2 if len(thresholds) <= 4 else 3
    rows = (len(thresholds) + columns - 1) // columns
    script = "\n".join([
        "set terminal pngcairo size %d,900 noenhanced" % (600 * columns)
        if plots.has_pngcairo(gnuplot) else
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
    return png if plots.run_gnuplot(gnuplot, script, png) else None


def write_plots(records, output_dir):
    """Both plots of records (the main table's rows,
    summary.summary_records); the paths written."""
    gnuplot = plots.find_gnuplot()
    if not gnuplot:
        return []
    written = [runtime_plot(gnuplot, records, output_dir),
               auc_plot(gnuplot, records, output_dir)]
    return [png for png in written if png]
