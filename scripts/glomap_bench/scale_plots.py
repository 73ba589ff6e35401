"""The plots of scripts/benchmark_scale.py (gnuplot, log-log, one panel per
layout, one line per stage, the total / whole process in black and a grey
n^1.2 reference line): time_vs_images.png and memory_vs_images.png."""

import os

from glomap_bench import parse, plots, run, scale_report, scale_summary
from glomap_bench.scale_summary import SLOPE_BAR

PLOT_FILES = ["time_vs_images.png", "memory_vs_images.png"]


def plot_series(rows):
    """(names, data lines) of one layout's plot data: per successful size,
    images, then every stage's and OTHER's time, the total, every stage's and
    OTHER's peak memory and the whole process's ("?" where missing)."""
    ok, names = scale_summary.ok_rows_and_stage_names(rows)
    names.append(parse.OTHER)

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


def plot_header(panels, png, what, sizes, pngcairo):
    """The lines of plot_script() before the panels."""
    width = 900 * max(1, len(panels))
    return [
        "set terminal pngcairo size %d,720 noenhanced font ',10'" % width
        if pngcairo else "set terminal png size %d,720" % width,
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


def panel_plots(data_path, names, anchor, what):
    """The plot clauses of one panel: a line per stage, the total (or whole
    process), and the n^SLOPE_BAR reference through anchor (or none)."""
    count = len(names)
    start = 2 if what == "time" else 3 + count
    clauses = []
    for k, name in enumerate(names):
        # OTHER dotted in dark grey, apart from the stages' colours.
        style = ("dt 3 lc rgb '#555555'" if name == parse.OTHER else
                 "lc rgb '%s'" % plots.STAGE_COLORS[
                     k % len(plots.STAGE_COLORS)])
        clauses.append("'%s' using 1:%d with linespoints lw 2 pt 7 ps 0.6 "
                       "%s title '%s'" % (data_path, start + k, style, name))
    clauses.append("'%s' using 1:%d with linespoints lw 3 pt 5 ps 0.8 "
                   "lc rgb 'black' title '%s'" % (
                       data_path, start + count,
                       "total" if what == "time" else "whole process"))
    if anchor:
        n0, v0 = anchor
        clauses.append("%.10g * x**%g with lines dt 2 lw 2 lc rgb "
                       "'#888888' title 'n^%g'" % (v0 / n0 ** SLOPE_BAR,
                                                    SLOPE_BAR, SLOPE_BAR))
    return clauses


def plot_script(panels, png, what, sizes, pngcairo=True):
    """gnuplot script of one log-log figure with one panel per layout.
    panels: [(title, data path, stage names, anchor (images, value) of the
    n^SLOPE_BAR reference or None)]; what: "time" or "memory"."""
    lines = plot_header(panels, png, what, sizes, pngcairo)
    for title, data_path, names, anchor in panels:
        lines.append("set title '%s'" % title)
        lines.append("plot " + ", \\\n     ".join(
            panel_plots(data_path, names, anchor, what)))
    lines.append("unset multiplot")
    return "\n".join(lines) + "\n"


def write_data(records, layouts, output_dir):
    """Writes scale_<layout>.dat of every layout with a successful run;
    returns ({"time": panels, "memory": panels} for plot_script(), the
    successful sizes)."""
    panels = {"time": [], "memory": []}
    sizes = set()
    for layout in scale_summary.layout_order(records, layouts):
        rows = scale_summary.layout_rows(records, layout)
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
        title = scale_report.layout_title(layout).replace("`", "")
        panels["time"].append((title, data_path, names,
                               (smallest["images"], smallest["total_s"])
                               if smallest["total_s"] else None))
        panels["memory"].append((title, data_path, names,
                                 (smallest["images"],
                                  smallest["peak_rss_mb"])
                                 if smallest["peak_rss_mb"] else None))
    return panels, sorted(sizes)


def write_plots(records, layouts, output_dir):
    """time_vs_images.png and memory_vs_images.png; the written paths."""
    gnuplot = plots.find_gnuplot()
    if not gnuplot:
        return []
    panels, sizes = write_data(records, layouts, output_dir)
    if not panels["time"]:
        run.log("no successful run: no plots")
        return []
    pngcairo = plots.has_pngcairo(gnuplot)
    written = []
    for what, name in zip(("time", "memory"), PLOT_FILES):
        png = os.path.join(output_dir, name)
        if os.path.exists(png):
            os.remove(png)
        script = plot_script(panels[what], png, what, sizes, pngcairo)
        with open(os.path.join(output_dir, name[:-4] + ".gp"), "w") as f:
            f.write(script)
        if plots.run_gnuplot(gnuplot, script, png):
            written.append(png)
    return written
