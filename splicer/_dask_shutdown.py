"""A quiet shutdown for the local Dask cluster of ``splice-batch`` (private).

When a ``LocalCluster`` closes, the scheduler may close a worker's connection while that
worker, already closing, has a heartbeat in flight.  distributed then logs "Failed to
communicate with scheduler during heartbeat." at ERROR level with two chained tracebacks
(dask/distributed#7192 and #9032; seen here about once in 30 closes on a loaded 2-core machine),
after every pair has finished and been written.  A user reads that as a crash.

:class:`QuietShutdown` is a worker plugin that drops exactly that record, and only while its
worker is closing: a heartbeat failure on a running worker is still printed.  (With threads
instead of processes the workers share one logger, so one closing worker hides the others' record
too; ``splice-batch`` starts processes.)  It is registered
on the clusters ``splice-batch`` starts itself, never on a user's scheduler.
"""
from __future__ import annotations

import logging
import weakref

from distributed import WorkerPlugin
from distributed.core import Status

__all__ = ["QuietShutdown", "ClosingHeartbeatFilter"]

HEARTBEAT_FAILED = "Failed to communicate with scheduler during heartbeat"
_CLOSING = frozenset({Status.closing, Status.closing_gracefully, Status.closed})


class ClosingHeartbeatFilter(logging.Filter):
    """Drop the heartbeat-failure record while ``worker`` is closing; pass every other record.

    >>> class Worker:
    ...     status = Status.running
    >>> w = Worker()
    >>> f = ClosingHeartbeatFilter(w)
    >>> rec = logging.LogRecord("distributed.worker", logging.ERROR, __file__, 1,
    ...                         HEARTBEAT_FAILED + ".", None, None)
    >>> f.filter(rec)                       # a running worker's failure is shown
    True
    >>> w.status = Status.closing
    >>> f.filter(rec)                       # a closing worker's is not
    False
    >>> other = logging.LogRecord("distributed.worker", logging.ERROR, __file__, 1, "x", None, None)
    >>> f.filter(other)
    True
    """

    def __init__(self, worker):
        super().__init__()
        self._worker = weakref.ref(worker)

    def filter(self, record: logging.LogRecord) -> bool:
        if not str(record.msg).startswith(HEARTBEAT_FAILED):
            return True
        w = self._worker()
        return w is None or w.status not in _CLOSING


class QuietShutdown(WorkerPlugin):
    """Worker plugin: installs :class:`ClosingHeartbeatFilter` on ``distributed.worker``."""

    name = "splicer-quiet-shutdown"
    idempotent = True

    def setup(self, worker):
        # no teardown that removes it: a closing worker tears its plugins down before it stops
        # its heartbeat, and the failure comes after; the filter holds the worker weakly and
        # passes everything once the worker is gone
        logging.getLogger("distributed.worker").addFilter(ClosingHeartbeatFilter(worker))
