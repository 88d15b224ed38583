"""The experiment: what a user asks for, resolved once, before anything runs.

* :mod:`.config`: the :class:`~gdabench.Experiment` itself (designers, environments, seeds, budget) and the
  value types it is made of (plugin choices, the primary comparison, re-evaluation);
* :mod:`.file`: experiment files (TOML/YAML) read into those types;
* :mod:`.build`: :func:`~.build.build_run`, the one place an option becomes part of an experiment (the
  command line, :func:`gdabench.compare` and ``--resume`` all go through it), and the warnings on what its
  seeds cannot show;
* :mod:`.plan`: the experiment resolved through the plugin registry into trials;
* :mod:`.trial_spec`: one trial's recipe (designer, environment, seed), which a worker builds its trial from.

The command line, the Python API, :mod:`gdabench.running` and :mod:`gdabench.report` build on this
package; it imports neither of them (``tests/test_imports.py`` checks the floors).  Importing the package
imports none of its modules.
"""
