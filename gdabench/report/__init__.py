"""Reports of a run directory: statistics, plots, body images, diversity, HTML and markdown.

Everything is computed from the tidy tables alone (``evaluations.parquet`` + ``run.json``), so a
report can be rebuilt at any time, also for a run that is still in progress.  The entry point is
:func:`gdabench.report.build.write_report` (kept out of this module on purpose, so that importing a
module of this package does not pull in matplotlib).  The statistics it shows come from
:mod:`gdabench.stats`, which the runner uses too; this package and :mod:`gdabench.running` never import
each other.
"""
