"""Cores and worker processes, without numpy or the rest: :mod:`seedtrack.cli` may start the fork
server before the command's own imports, so that the server's imports run beside them.

:mod:`seedtrack.parallel` starts the worker processes from here.
"""

from __future__ import annotations

import multiprocessing
import multiprocessing.forkserver
import os

# Worker processes are started by a fork server: a clean process (no decoder or OpenCV threads
# copied half-way through their work, as fork would) that has imported the encoder once.
# The first preload leaves Ctrl-C to the command: a terminal's Ctrl-C reaches every process of its
# group, and the fork server took it while importing the others (seconds on a loaded machine),
# printing a traceback of its own beside the command's one line.
_PRELOAD = ["seedtrack.ctrl_c_ignored", "seedtrack.parallel"]


def default_workers() -> int:
    """The number of cores this process may run on (its CPU affinity), at least 1.

    Example
    -------
    >>> default_workers() >= 1
    True
    """
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # macOS and Windows have no affinity call
        return max(1, os.cpu_count() or 1)


# More workers than this per core only queue for the cores, and each holds frames and a
# process's memory: 1,000 started 1,000 processes and leaked their semaphores.
WORKERS_PER_CORE = 4


def check_worker_count(option: str, count: int) -> int:
    """``count`` workers asked for with ``option``, if this machine can run them.

    Raises
    ------
    UsageError
        Below 1, or above :data:`WORKERS_PER_CORE` times the machine's cores.

    Example
    -------
    >>> check_worker_count("--workers", 2)
    2
    """
    from .errors import UsageError

    most = WORKERS_PER_CORE * (os.cpu_count() or 1)
    if count < 1:
        raise UsageError(f"{option} must be a whole number >= 1, got {count}")
    if count > most:
        raise UsageError(f"{option} {count} is more than this machine can run: at most {most} ({WORKERS_PER_CORE} per core, {os.cpu_count() or 1} cores)")
    return count


def can_start_processes() -> bool:
    """Whether this process may start worker processes (a daemonic one, such as a Dask
    worker's, may not).

    Example
    -------
    >>> can_start_processes()
    True
    """
    return not multiprocessing.current_process().daemon


def process_context() -> multiprocessing.context.BaseContext:
    """The multiprocessing context workers are started from (a fork server where there is one)."""
    if "forkserver" not in multiprocessing.get_all_start_methods():
        return multiprocessing.get_context("spawn")
    context = multiprocessing.get_context("forkserver")
    context.set_forkserver_preload(_PRELOAD)
    return context


def start_fork_server() -> None:
    """Start the fork server now, if there is one and this process may start workers; it imports
    its preloads (about half a second of one core) while this process goes on.

    Example
    -------
    >>> start_fork_server()
    """
    if can_start_processes() and process_context().get_start_method() == "forkserver":
        multiprocessing.forkserver.ensure_running()
