"""Writing a report or an export as a whole: readers see the old version or the new one, never a mix.

The new version is written into a staging folder next to ``out`` and renamed into place.  Writers of the
same ``out`` take turns on a lock file next to it, so whatever a killed writer left (staging folders,
temporary files) belongs to no live writer and is removed by the next one.  The lock file goes when its
writer is done (a kill leaves it, empty, and the next writer takes it and removes it).
"""

from __future__ import annotations

import contextlib
import os
import shutil
import tempfile
from pathlib import Path
from typing import Iterator

from filelock import FileLock

try:
    import fcntl
except ImportError:  # pragma: no cover - Windows, where filelock removes its file itself
    fcntl = None  # type: ignore[assignment]

from .. import faults
from ..errors import GdabenchError
from ..results import check_out_dir, write_error


def _lock(out: Path) -> Path:
    return out.parent / f".{out.name}.lock"


def _remove_leftovers(out: Path) -> None:
    """What killed writers of ``out`` left: staging folders and atomic writes' temporary files."""
    for left in [*out.parent.glob(f".{out.name}.gdabench-*"), *out.parent.glob(f".{out.name}.*.tmp")]:
        if left.is_dir():
            shutil.rmtree(left, ignore_errors=True)
        else:
            left.unlink(missing_ok=True)


@contextlib.contextmanager
def _exclusive(path: Path) -> Iterator[None]:
    """Hold the lock file ``path`` and remove it when done.

    filelock keeps its file on Unix, as a writer waiting on the old file could otherwise lock a removed
    file while a newcomer locks a new one.  Here the holder removes the file only while holding it, and
    whoever locks it checks that the path still names the file it locked, trying again if not.
    """
    if fcntl is None:  # pragma: no cover
        with FileLock(path):
            yield
        return
    while True:
        fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX)
            current = os.stat(path)
        except FileNotFoundError:
            current = None
        except BaseException:  # Ctrl-C while waiting
            os.close(fd)
            raise
        if current is not None and os.path.samestat(current, os.fstat(fd)):
            break
        os.close(fd)  # the file its last holder removed: take the one the path names now
    try:
        yield
    finally:
        path.unlink(missing_ok=True)
        os.close(fd)


@contextlib.contextmanager
def writing(out: Path) -> Iterator[None]:
    """Hold ``out``'s writers' lock and clear what killed writers left; write errors become one line."""
    check_out_dir(out.parent)
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
        with _exclusive(_lock(out)):
            _remove_leftovers(out)
            yield
    except GdabenchError:
        raise
    except OSError as exc:
        raise write_error(exc, out) from None


@contextlib.contextmanager
def staged_folder(out: Path, *, whole: bool, last: str = "") -> Iterator[Path]:
    """A folder to fill with the new content of the folder ``out``, moved into place once it is complete.

    ``whole``: the new folder replaces ``out`` (a folder the harness owns); otherwise its files are moved
    into an existing ``out`` one by one, ``last`` at the end (a folder the user chose may hold other files).
    """
    with writing(out):
        staging = Path(tempfile.mkdtemp(dir=out.parent, prefix=f".{out.name}.gdabench-"))
        try:
            yield staging
            faults.point("output-staged")
            os.chmod(staging, 0o755)  # mkdtemp makes a private folder; results are meant to be shared
            if not out.exists():
                staging.rename(out)
            elif whole:
                old = staging.with_name(f"{staging.name}-old")  # a leftover too, if a kill comes now
                out.rename(old)
                staging.rename(out)
                shutil.rmtree(old, ignore_errors=True)
            else:
                for file in sorted(staging.iterdir(), key=lambda f: (f.name == last, f.name)):
                    file.replace(out / file.name)
        finally:
            shutil.rmtree(staging, ignore_errors=True)
