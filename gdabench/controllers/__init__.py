"""Built-in controllers (registered through the ``gdabench_controllers`` hook)."""

from __future__ import annotations

from ..hookspecs import hookimpl
from ..specs import ControllerSpec


@hookimpl
def gdabench_controllers() -> list[ControllerSpec]:
    return []
