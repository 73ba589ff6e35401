"""The benchmark scripts' package. scripts/benchmark.py (our `colmap
global_mapper` beside COLMAP's stock `mapper` on datasets) and
scripts/benchmark_scale.py (our global mapper on synthetic scenes of growing
size) are its entry points: they parse the options and call side_by_side or
scale.

Shared by both:
  run         processes: wall time, the process's own peak memory, memory
              per stage of the mapper's log
  parse       the mapper's and the generator's log lines, the datasets'
              reference tables
  models      model_analyzer, model_evaluator, a model's image names
  provenance  command, commit, build type, binaries, machine
  scenes      the stamps of cached synthetic scenes
  stats       medians, log-log slopes
  tables      number formats, Markdown rows, the README's sections
  plots       gnuplot
  cli         argument types, --self_test

scripts/benchmark.py:
  datasets      dataset folders, camera setups, synthetic scenes
  mappers       the mappers and one run of one of them
  summary       medians over seeds and repeats
  bars          the acceptance bars of issue 10
  report        the Markdown report and the README section
  report_plots  the runtime and AUC plots
  side_by_side  the whole benchmark

scripts/benchmark_scale.py:
  scale_runs     scene generation and mapper runs
  scale_summary  per-size summaries and the log-log slopes
  scale_report   the Markdown report and the README section
  scale_plots    the log-log plots
  scale          the whole benchmark

The tests of a module are in <module>_test.py beside it (unittest, run by
ctest; all at once: python3 -m unittest discover -s scripts -p '*_test.py').
Only the Python standard library is used; gnuplot draws the plots.
"""

import os

# The repository: this package is scripts/glomap_bench/ in it.
REPO_DIR = os.path.dirname(os.path.dirname(os.path.dirname(
    os.path.abspath(__file__))))
DEFAULT_COLMAP = os.path.join(REPO_DIR, "build", "bin", "colmap")
