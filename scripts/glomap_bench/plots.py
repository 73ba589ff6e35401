"""Drawing with gnuplot: finding it, its PNG terminal, quoting, running a
script."""

import os
import shutil
import subprocess

from glomap_bench import run

# Line and bar colours of the global mapper's stages.
STAGE_COLORS = ["#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd",
                "#8c564b", "#e377c2", "#bcbd22", "#17becf", "#393b79",
                "#637939", "#843c39"]


def find_gnuplot():
    """The gnuplot executable; None (with a message) without one."""
    gnuplot = shutil.which("gnuplot")
    if not gnuplot:
        run.log("gnuplot not found: no plots (apt-get install gnuplot-nox)")
    return gnuplot


def gnuplot_label(text):
    """text as a double-quoted gnuplot string (double quotes made
    single)."""
    return '"' + text.replace('"', "'") + '"'


def has_pngcairo(gnuplot):
    """Whether gnuplot has the pngcairo terminal."""
    code, text = run.capture([gnuplot, "-e", "set terminal"])
    return "pngcairo" in text


def run_gnuplot(gnuplot, script, png):
    """Runs the script; whether it wrote png (a message if not)."""
    result = subprocess.run([gnuplot], input=script, text=True,
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT)
    if result.returncode != 0 or not os.path.exists(png):
        run.log("gnuplot failed for %s: %s" % (png, result.stdout.strip()))
        return False
    return True
