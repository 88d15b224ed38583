"""What became of a proposed body: the ``status`` column of the results table (:data:`gdabench.results.COLUMNS`).

A module of its own, free of pandas and of the execution machinery, so that the reports, the trial and
the evaluation workers share one vocabulary without importing each other.
"""

from __future__ import annotations

OK, INVALID, DUPLICATE, ERROR, TIMEOUT = "ok", "invalid", "duplicate", "error", "timeout"
#: every status, in the order the docs list them
STATUSES = (OK, INVALID, DUPLICATE, ERROR, TIMEOUT)
#: statuses that used an evaluation (and so count against the budget)
COUNTED = (OK, ERROR, TIMEOUT)
