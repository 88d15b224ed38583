"""Bodies from another run to train generation 0's model on (the ``prior`` option)."""

from __future__ import annotations

from pathlib import Path

from ...body import Body, as_body
from ...errors import ConfigError, GdabenchError


def load_prior(source: str, top: int, shape: tuple[int, int]) -> list[Body]:
    """The ``top`` best distinct bodies of another run (run directory or evaluations.parquet),
    or the bodies listed one per line in a text file."""
    path = Path(source)
    if path.is_dir():
        path = path / "evaluations.parquet"
    if not path.exists():
        raise ConfigError(
            f"gda: prior {source!r} not found (give a run directory, its evaluations.parquet, or a text file of bodies)"
        )
    try:
        if path.suffix == ".parquet":
            from ...sdk import read_parquet

            rows = read_parquet(path, columns=["body", "reward", "status"])
            rows = rows[rows["status"] == "ok"].sort_values("reward", ascending=False, kind="stable")
            texts = list(dict.fromkeys(rows["body"]))
        else:
            texts = [
                line.split()[0] for line in path.read_text().splitlines() if line.strip() and not line.startswith("#")
            ]
    except GdabenchError:
        raise
    except Exception as exc:  # noqa: BLE001 - any unreadable file is one line for the user
        raise ConfigError(f"gda: cannot read prior {source!r}: {type(exc).__name__}: {exc}") from None
    bodies = [as_body(t) for t in texts]
    bodies = [b for b in bodies if b.shape == tuple(shape) and b.is_valid()][:top]
    if not bodies:
        raise ConfigError(f"gda: prior {source!r} holds no valid {shape[0]}x{shape[1]} body")
    return bodies
