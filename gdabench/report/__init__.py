"""Reports of a run directory: statistics, plots, body images, diversity, HTML and markdown.

Everything is computed from the tidy tables alone (``evaluations.parquet`` + ``run.json``), so a
report can be rebuilt at any time, also for a run that is still in progress.  The entry point is
:func:`gdabench.report.build.write_report` (kept out of this module on purpose: importing
:mod:`gdabench.report.stats` from the core summary must not pull in matplotlib).
"""
