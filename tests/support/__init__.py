"""Helpers the tests share (imported as ``support.<module>``; ``tests/`` is on the path under pytest).

* ``processes``: running the ``gdabench`` command in a subprocess, and reading what it wrote;
* ``listeners``: run listeners that kill a run at a chosen event (for the resume tests);
* ``stat_tables``: small synthetic result tables for the statistics and report tests;
* ``scripts``: loading a ``benchmarks/`` script as a module;
* ``gda_reference``: the thesis's reference U-Net, which ``gda``'s model is checked against;
* ``quality_cases``: the quality-regression cases, and the script that regenerates their expectations;
* ``slow_tests``: the script that remakes ``tests/slow_tests.txt`` from a ``--durations=0`` report.
"""
