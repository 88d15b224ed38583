"""The statistics core: per-run measures, intervals, the run summary, power analysis, re-evaluated scores.

Computed from the tidy tables alone (pandas, numpy, scipy; no plotting), so that both the runner (which
writes ``summary.csv`` when a run ends) and the report (:mod:`gdabench.report`) build on it without
importing each other.

* :mod:`.core`: best-so-far curves, medians with order-statistic intervals, bootstrap settings;
* :mod:`.summary`: the per-designer summary table and the failure counts;
* :mod:`.power`: the exact signed-rank test's power and the seeds a comparison needs;
* :mod:`.reevaluated`: a trial scored by its best bodies' means over further training seeds.
"""
