"""Named points where a test can kill this process, to prove a run survives dying there.

``GDABENCH_FAULT=name`` (or ``name:n``, the n-th time the point is reached) makes the process
SIGKILL itself at that point, as a power cut or an out-of-memory kill would.  The points sit
between the writes that finish a generation and a trial; the reliability tests kill a real
``gdabench`` at each of them and check that resuming gives the uninterrupted table.
"""

from __future__ import annotations

import os
import signal

_SPEC = os.environ.get("GDABENCH_FAULT", "")
_NAME, _, _COUNT = _SPEC.partition(":")
_reached = 0

#: the points, in the order a generation and then a trial are finished (``output-staged``, where a report
#: or an export is written but not yet in place, is not one of them)
POINTS = ("rows-written", "checkpoint-written", "trial-merged", "pending-removed", "checkpoint-removed")


def point(name: str) -> None:
    """Die here if the environment asks for it (a no-op otherwise)."""
    global _reached
    if name != _NAME:
        return
    _reached += 1
    if _reached >= int(_COUNT or 1):
        os.kill(os.getpid(), signal.SIGKILL)
