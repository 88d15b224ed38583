"""Workers: the harness's one worker layer, for trials and evaluations alike.

A worker holds one *server* object, built in the worker by ``make(tell)`` (a picklable callable), and
runs ``server.method(*args)`` for each :meth:`Workers.call` without the caller waiting; the answer
comes back through :meth:`Workers.wait`, with any notes the server ``tell``\\ s while a call runs.  A
failing call is an answer (``ok`` False, one line), a worker that dies is one too (``died``), so the
caller decides what each costs.  Trials run in workers whose server is a trial host
(:mod:`gdabench.running.hosts`); evaluations in workers whose server is an :class:`~.pool.Evaluator`,
supervised by :class:`~.pool.WorkerPool` (timeouts, replacing the dead).

Where a worker is: :class:`InProcess` (this process: a call runs at once), :class:`LocalProcesses`
(spawned processes, one pipe each, that die with the driver) or :class:`~.ray.RayActors`.
"""

from __future__ import annotations

import abc
import multiprocessing
import os
import signal
import threading
import time
from dataclasses import dataclass
from multiprocessing.connection import Connection, wait
from typing import Any, Callable, Protocol, Sequence

from .. import spawning
from ..errors import GdabenchError, one_line

#: a note sent from inside a running call (local processes only: elsewhere ``make`` is given None)
Tell = Callable[[Any], None]


class Server(Protocol):
    """What a worker holds: any object whose methods the driver calls; ``close`` when the worker stops."""

    def close(self) -> None: ...


#: builds a worker's server, in the worker
Make = Callable[[Tell | None], Server]


@dataclass(frozen=True)
class Answer:
    """What came back from a worker: a call's value or a note (``ok``), or why it failed (``died``: the worker is
    gone)."""

    worker: Any
    ok: bool
    value: Any
    died: bool = False


class WorkerGone(Exception):
    """A call could not be handed to a worker because the worker is no longer there."""


def answer(server: Any, method: str, args: Sequence[Any]) -> tuple[bool, Any]:
    """``server.method(*args)``, its failure turned into one line."""
    try:
        return True, getattr(server, method)(*args)
    except GdabenchError as exc:
        return False, str(exc)
    except Exception as exc:  # noqa: BLE001 - a call's failure is the caller's to judge, reported in one line
        return False, one_line(exc)


class Workers(abc.ABC):
    """Places to run a server's calls without waiting for them; a context manager."""

    @abc.abstractmethod
    def start(self) -> Any:
        """A new worker; it builds its server before it answers its first call."""

    @abc.abstractmethod
    def call(self, worker: Any, method: str, *args: Any) -> None:
        """Start ``server.method(*args)`` on ``worker``; raise :class:`WorkerGone` if it is not there any more."""

    @abc.abstractmethod
    def wait(self, workers: Sequence[Any], timeout: float | None = None) -> list[Answer]:
        """Block up to ``timeout`` s (None: until one of ``workers`` answers); every answer that is in."""

    @abc.abstractmethod
    def kill(self, worker: Any) -> None:
        """Stop a worker now, whatever it is doing."""

    def close(self, workers: Sequence[Any]) -> None:
        """Stop idle workers (default: kill them)."""
        for worker in workers:
            self.kill(worker)

    def __enter__(self) -> Workers:
        return self

    def __exit__(self, *exc: object) -> None:  # noqa: B027 - nothing to release unless a subclass says so
        pass


# -- in this process --------------------------------------------------------------------------------
class InProcess(Workers):
    """One server in the calling process: a call runs at once, and ``wait`` hands over its answer."""

    def __init__(self, server: Server):
        self.server = server
        self._answers: list[Answer] = []

    def start(self) -> Server:
        return self.server

    def call(self, worker: Server, method: str, *args: Any) -> None:
        self._answers.append(Answer(worker, *answer(worker, method, args)))

    def wait(self, workers: Sequence[Any], timeout: float | None = None) -> list[Answer]:
        answers, self._answers = self._answers, []
        return answers

    def kill(self, worker: Server) -> None:
        worker.close()


# -- local processes ---------------------------------------------------------------------------------
def exit_when_orphaned(parent: int) -> None:
    while True:
        time.sleep(1.0)
        if os.getppid() != parent:
            os._exit(0)  # the driver is gone (killed): nobody will read our results


def _serve(conn: Connection, make: Make, parent: int, label: str) -> None:
    """A worker process: build the server, then answer the driver's calls until it says stop or goes away.

    Ctrl-C is ignored (the driver decides what an interrupt means), and the worker exits by itself when
    the driver dies, even in the middle of a hung call.
    """
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    threading.Thread(target=exit_when_orphaned, args=(parent,), daemon=True).start()
    server = make(lambda note: conn.send((True, note)))
    while True:
        try:
            message = conn.recv()
        except (EOFError, OSError):  # the driver is gone
            break
        if message is None:
            break
        method, args = message
        ok, value = answer(server, method, args)
        try:
            conn.send((ok, value))
        except OSError:  # the driver is gone
            break
        except Exception as exc:  # noqa: BLE001 - e.g. an info value that does not pickle
            conn.send((False, f"the {label}'s answer could not be sent to the driver: {one_line(exc)}"))
    server.close()


def death_message(exitcode: int | None, label: str = "worker") -> str:
    if exitcode is not None and exitcode < 0:
        try:
            return f"{label} process died (killed by {signal.Signals(-exitcode).name})"
        except ValueError:
            pass
    return f"{label} process died (exit code {exitcode})"


@dataclass(eq=False)
class _Process:
    process: multiprocessing.process.BaseProcess
    conn: Connection


class LocalProcesses(Workers):
    """Workers as spawned local processes (spawn is safe with torch and threads), one pipe each.

    ``label`` names them in messages ("worker process died ..."); ``daemon`` workers cannot start
    processes of their own; ``close`` gives idle workers ``grace`` seconds to finish.
    """

    def __init__(self, make: Make, *, label: str, name: str, daemon: bool, grace: float):
        self.make, self.label, self.name, self.daemon, self.grace = make, label, name, daemon, grace
        self._ctx = multiprocessing.get_context("spawn")

    def start(self) -> _Process:
        driver_end, worker_end = self._ctx.Pipe()
        process = spawning.process(
            self._ctx, _serve, (worker_end, self.make, os.getpid(), self.label), daemon=self.daemon, name=self.name
        )
        spawning.start(process)
        worker_end.close()
        return _Process(process, driver_end)

    def call(self, worker: _Process, method: str, *args: Any) -> None:
        try:
            worker.conn.send((method, args))  # pickles first: a call that does not pickle writes nothing
        except (BrokenPipeError, ConnectionError, EOFError) as exc:
            raise WorkerGone from exc

    def wait(self, workers: Sequence[_Process], timeout: float | None = None) -> list[Answer]:
        by_handle: dict[Any, _Process] = {}
        for worker in workers:
            by_handle[worker.conn] = by_handle[worker.process.sentinel] = worker
        answers = []
        for worker in dict.fromkeys(by_handle[r] for r in wait(list(by_handle), timeout)):  # conn before sentinel
            if worker.conn.poll():
                try:
                    ok, value = worker.conn.recv()
                except (EOFError, OSError):
                    pass
                except Exception as exc:  # noqa: BLE001 - an answer the driver cannot unpickle
                    message = f"the {self.label}'s answer could not be read: {one_line(exc)}"
                    answers.append(Answer(worker, False, message))
                    continue
                else:
                    answers.append(Answer(worker, ok, value))
                    continue
            worker.process.join(5)
            answers.append(Answer(worker, False, death_message(worker.process.exitcode, self.label), died=True))
        return answers

    def kill(self, worker: _Process) -> None:
        if worker.process.is_alive():
            worker.process.kill()
        worker.process.join(5)
        worker.conn.close()

    def close(self, workers: Sequence[_Process]) -> None:
        """Ask idle workers to finish (their servers close), then make sure they did."""
        for worker in workers:
            try:
                worker.conn.send(None)
            except (OSError, ValueError):
                pass
        deadline = time.monotonic() + self.grace
        for worker in workers:
            worker.process.join(max(0.0, deadline - time.monotonic()))
            self.kill(worker)
