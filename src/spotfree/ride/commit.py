"""Group commit: one writer thread runs every write pending in one transaction, and each write's caller hears of
it only after the COMMIT that holds it.

A write is a function of the open cursor. The writer takes the first write that is waiting, then every other one
queued by then (at most ``max_group``), and runs them between one ``BEGIN`` and one ``COMMIT``, each inside its own
``SAVEPOINT``: a write that raises is rolled back to its savepoint alone (it changes nothing) and its caller gets
the exception; the others commit. While a commit waits on the disk (an fsync, milliseconds), the next writes queue
up, so under load one fsync carries many writes: ``k`` writes cost one transaction instead of ``k``.

Writes of one kind may also be run together: consecutive writes submitted with the same ``together`` function
are handed to it in one call (inside one savepoint), so that ``k`` of them cost a few statements instead of ``k``
times a few. It returns one ``(ok, value)`` per write, a refused write changing nothing; if it raises, its
savepoint is rolled back and each of those writes is run alone as above, which names the one at fault.

Durability is that of the connection: a future resolves after ``COMMIT`` has returned, so with SQLite
``synchronous=FULL`` (or PostgreSQL's ``synchronous_commit=on``) a resolved write is on disk. A failed ``COMMIT``
fails every write of its group.
"""

from __future__ import annotations

import itertools
import queue
import threading
from collections.abc import Callable, Iterator
from concurrent.futures import Future
from contextlib import AbstractContextManager
from typing import Any

MAX_GROUP = 1000
"""Writes in one transaction at most."""


class GroupCommit:
    """The writer thread of one connection (see the module docstring).

    Parameters
    ----------
    transaction : callable
        Opens a transaction: a context manager that yields a cursor, commits on a normal exit and rolls back when
        the block raises.
    max_group : int
        Writes in one transaction at most.
    """

    def __init__(self, transaction: Callable[[], AbstractContextManager], max_group: int = MAX_GROUP):
        self._transaction = transaction
        self.max_group = max_group
        self._queue: queue.SimpleQueue = queue.SimpleQueue()
        self._thread: threading.Thread | None = None
        self._start = threading.Lock()
        self.groups = 0
        """Transactions committed (for benchmarks: writes per transaction = writes / groups)."""

    def submit(self, write: Callable[[Any], Any],
               together: Callable[[Any, list], list[tuple[bool, Any]]] | None = None) -> Future:
        """Queue ``write(cursor)``; the future holds its return value once the transaction holding it has
        committed, or its exception (the write then changed nothing). ``together(cursor, writes)``, when given,
        runs this write with the consecutive writes that share it (see the module docstring)."""
        future: Future = Future()
        if self._thread is None:
            with self._start:
                if self._thread is None:
                    self._thread = threading.Thread(target=self._run, name="spotfree-commit", daemon=True)
                    self._thread.start()
        self._queue.put((write, together, future))
        return future

    def close(self) -> None:
        """Commit what is queued, then stop the thread."""
        with self._start:
            if self._thread is not None:
                self._queue.put(None)
                self._thread.join()
                self._thread = None

    def _pending(self) -> Iterator[tuple[Callable, Callable | None, Future] | None]:
        yield self._queue.get()
        for _ in range(self.max_group - 1):
            try:
                yield self._queue.get_nowait()
            except queue.Empty:
                return

    def _run(self) -> None:
        while True:
            group = list(self._pending())
            stop = None in group
            group = [item for item in group if item is not None]
            if group:
                self._commit(group)
            if stop:
                return

    def _commit(self, group: list[tuple[Callable, Callable | None, Future]]) -> None:
        outcomes: list[tuple[bool, Any]] = []
        try:
            with self._transaction() as cursor:
                for together, run in itertools.groupby(group, key=lambda item: item[1]):
                    writes = [write for write, _, _ in run]
                    if together is None:
                        outcomes += [_alone(cursor, write) for write in writes]
                    else:
                        outcomes += _together(cursor, together, writes)
        except BaseException as exc:
            for _, _, future in group:
                future.set_exception(exc)
            return
        self.groups += 1
        for (_, _, future), (ok, value) in zip(group, outcomes):
            if ok:
                future.set_result(value)
            else:
                future.set_exception(value)


def _alone(cursor, write: Callable) -> tuple[bool, Any]:
    """``write(cursor)`` in its own savepoint, rolled back if it raises."""
    cursor.execute("SAVEPOINT write")
    try:
        outcome = True, write(cursor)
    except BaseException as exc:  # the caller gets it; the others go on
        cursor.execute("ROLLBACK TO SAVEPOINT write")
        outcome = False, exc
    cursor.execute("RELEASE SAVEPOINT write")
    return outcome


def _together(cursor, together: Callable, writes: list[Callable]) -> list[tuple[bool, Any]]:
    """``together(cursor, writes)`` in one savepoint; each write alone if it raises."""
    cursor.execute("SAVEPOINT together")
    try:
        outcomes = together(cursor, writes)
    except Exception:
        cursor.execute("ROLLBACK TO SAVEPOINT together")
        outcomes = None
    cursor.execute("RELEASE SAVEPOINT together")
    if outcomes is None:
        return [_alone(cursor, write) for write in writes]
    if len(outcomes) != len(writes):
        raise RuntimeError(f"{together!r} gave {len(outcomes)} outcomes for {len(writes)} writes")
    return outcomes
