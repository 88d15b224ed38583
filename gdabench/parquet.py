"""Reading a parquet table safely: the one reader of the run's tables, and of a plugin's (e.g. ``gda``'s prior)."""

from __future__ import annotations

from pathlib import Path
from typing import Sequence

import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq


def read_parquet(path: Path, columns: Sequence[str] | None = None) -> pd.DataFrame:
    """A parquet file read with one open and one read, into Arrow's own memory.

    One read of one file: pyarrow given a path may stat it and open it apart, and a writer's rename in
    between hands it the new file's bytes with the old file's size.  Arrow's file and buffer rather than a
    Python file object (or ``pandas.read_parquet``, which opens one): Arrow's threads then hold no Python
    object, whose release in a finalising interpreter aborted about one process in 75 at exit ("terminate
    called without an active exception"; ``benchmarks/research/exit_aborts.py``).
    """
    with pa.OSFile(str(path)) as file:
        data = file.read_buffer()
    return pq.read_table(data, columns=None if columns is None else list(columns)).to_pandas()
