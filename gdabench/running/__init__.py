"""Running an experiment: from a resolved plan to a finished run directory.

* :mod:`.plan`: the experiment resolved once (plugin names to specs, trials to :mod:`.trial_spec` recipes);
* :mod:`.runner`: the run directory's one writer, which runs the plan's trials and records them;
* :mod:`.trial`: one designer on one environment with one seed, generation by generation;
* :mod:`.hosts`: where trials run (this process, local worker processes, Ray actors);
* :mod:`.cores`: the run's spare cores, lent to trials' designers;
* :mod:`.outcomes`: the run's record of finished evaluations, for resuming mid-generation;
* :mod:`.events`, :mod:`.progress`: what a run tells listeners, plugins and the progress display;
* :mod:`.faults`: named points where the reliability tests kill a run (the run directory's writes in
  :mod:`gdabench.results` and the report's staging reach them too).

Layering: this package may import :mod:`gdabench.execution` (evaluating bodies), never the other way
round (``tests/test_imports.py`` checks).  So what both sides use lives in ``execution``: its
:mod:`~gdabench.execution.options` (the ``Execution`` options and the executor they choose) and
:mod:`~gdabench.execution.spawning` (how worker processes start, which the evaluation pool needs too).

Importing this package imports none of its modules, so a lower module (:mod:`gdabench.results`) can use
:mod:`.faults` without loading the runner; import the module you need.
"""
