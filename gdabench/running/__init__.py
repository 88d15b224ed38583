"""Running an experiment: from a resolved plan to a finished run directory.

* :mod:`.runner`: the run directory's one writer, which runs the plan's trials and records them;
* :mod:`.trial`: one designer on one environment with one seed, generation by generation;
* :mod:`.hosts`: where trials run (a trial host, as the server of a worker of :mod:`gdabench.execution.workers`:
  this process, local worker processes, Ray actors);
* :mod:`.pipeline`: how a trial's generation is evaluated (strategy, replay, cache, executor: one object);
* :mod:`.cores`: the run's spare cores, lent to trials' designers;
* :mod:`.outcomes`: the run's record of finished evaluations, for resuming mid-generation;
* :mod:`.events`, :mod:`.progress`: what a run tells listeners, plugins and the progress display.

It runs a :class:`~gdabench.experiment.plan.Plan` (the experiment resolved once, :mod:`gdabench.experiment`)
and writes the run's summary with :mod:`gdabench.stats`; it never imports :mod:`gdabench.report`.

Layering: this package may import :mod:`gdabench.execution` (evaluating bodies), never the other way
round (``tests/test_imports.py`` checks).  So what both sides use lives in ``execution``: its
:mod:`~gdabench.execution.options` (the ``Execution`` options and the executor they choose) and
:mod:`~gdabench.execution.workers` (the one worker layer: trials and evaluations run in its workers).

Importing this package imports none of its modules; import the module you need.
"""
