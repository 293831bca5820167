"""Work over the frames of a clip on several cores, with results in the order of the frames.

Frames are independent for detection and for drawing, so each is one task; what every task needs
(detector options, the track layers) goes to each worker once, when it starts. Workers are
processes rather than threads: PyAV's decoder and encoder hold Python's global lock, so threads
beside them wait (encoding 150 frames took 8.6 s instead of 2.0 s beside one busy Python thread).
At most a few frames per worker are in flight, so memory does not grow with the clip.
"""

from __future__ import annotations

import collections
import contextlib
import multiprocessing
import os
import queue
import signal
import threading
from concurrent.futures import ProcessPoolExecutor
from typing import Callable, Iterable, Iterator, TypeVar

import numpy as np

from seedtrack.allocation import set_malloc_options
from seedtrack.data.video import write_video

Item = TypeVar("Item")
Result = TypeVar("Result")

# Frames queued per worker beyond the one it is on: enough to hide the hand-over, few enough
# that frames in flight stay a few megabytes.
_QUEUED_PER_WORKER = 2
# Workers are started by a fork server: a clean process (no decoder or OpenCV threads copied
# half-way through their work, as fork would) that has imported these once, so that each
# worker starts in milliseconds instead of importing numpy, OpenCV and PyAV again.
# Where glibc maps allocations from the system (and unmaps them when freed), and the free memory
# its heap keeps, both fixed at this many bytes in a worker. Left to glibc, a worker mapped and
# unmapped its frame-sized temporaries on every frame, and detection there took twice the CPU
# time it takes in the main process.
_HEAP_REUSE_BYTES = 32 * 1024 * 1024
# The first leaves Ctrl-C to the command: a terminal's Ctrl-C reaches every process of its group,
# and the fork server took it while importing the others (seconds on a loaded machine), printing
# a traceback of its own beside the command's one line.
_PRELOAD = ["seedtrack.ctrl_c_ignored", "seedtrack.parallel", "seedtrack.drawing", "seedtrack.detection.blobs", "seedtrack.detection.spots", "seedtrack.data.video"]


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


@contextlib.contextmanager
def _ctrl_c_held() -> Iterator[None]:
    # A submit may start a worker; Ctrl-C half-way through handing it its start-up data made
    # this process exit while the worker was still reading it, and the worker printed a traceback
    # (its pool's semaphore already gone). Held here, Ctrl-C is raised once the worker has it,
    # in place of any error the block met meanwhile (a fork server that Ctrl-C stopped).
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    caught = []
    previous = signal.signal(signal.SIGINT, lambda *_: caught.append(True))
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)
        if caught and callable(previous):
            previous(signal.SIGINT, None)


def ordered_map(function: Callable[[Item], Result], items: Iterable[Item], workers: int) -> Iterator[Result]:
    """``function(item)`` for each item, in the items' order, computed by ``workers`` processes.

    With one worker (or where no process can be started) everything runs here, one item at a
    time, so the results are the same whatever ``workers`` is as long as ``function`` depends
    only on its item.

    Parameters
    ----------
    function : callable
        Picklable (a module-level function or a ``functools.partial`` of one); sent to each
        worker once.
    items : iterable
        Consumed a few items per worker ahead of the results; each is pickled to a worker.
    workers : int
        Processes, >= 1.

    Yields
    ------
    The results, in order. An exception raised by ``function`` is raised here, at its item.

    Example
    -------
    >>> list(ordered_map(abs, [-3, 1, -2], workers=1))
    [3, 1, 2]
    """
    if workers <= 1 or not can_start_processes():
        yield from map(function, items)
        return
    with ProcessPoolExecutor(workers, mp_context=process_context(), initializer=_install, initargs=(function,)) as pool:
        pending: collections.deque = collections.deque()
        try:
            for item in items:
                with _ctrl_c_held():
                    pending.append(pool.submit(_apply, item))
                if len(pending) > workers * (1 + _QUEUED_PER_WORKER):
                    yield pending.popleft().result()
            while pending:
                yield pending.popleft().result()
        finally:
            for future in pending:
                future.cancel()


@contextlib.contextmanager
def read_ahead(items: Iterable[Item], depth: int = 4) -> Iterator[Iterator[Item]]:
    """The items, taken from ``items`` by a thread of their own up to ``depth`` ahead, in order.

    For a frame source: the next frames decode while this thread detects in the last one, as
    far as decoder and detector let go of Python's lock (OpenCV's calls and numpy's operations on
    whole frames do). Leaving the block stops the thread and waits
    for it, so the source may be closed right after; an exception raised while taking an item is
    raised here, at that item.

    Example
    -------
    >>> with read_ahead(range(3)) as numbers:
    ...     list(numbers)
    [0, 1, 2]
    """
    ready: queue.Queue = queue.Queue(depth)
    stop = threading.Event()
    done = object()

    def hand(entry) -> bool:
        while not stop.is_set():
            try:
                ready.put(entry, timeout=0.1)
                return True
            except queue.Full:
                pass
        return False

    def take() -> None:
        try:
            for item in items:
                if not hand((True, item)):
                    return
        except BaseException as error:  # handed over to be raised in the consumer's thread
            hand((False, error))
            return
        hand((True, done))

    def taken() -> Iterator[Item]:
        while True:
            ok, item = ready.get()
            if not ok:
                raise item
            if item is done:
                return
            yield item

    reader = threading.Thread(target=take, name="read-ahead", daemon=True)
    reader.start()
    try:
        yield taken()
    finally:
        stop.set()
        reader.join()


def encode_video(path, frames: Iterable[np.ndarray], fps: float, workers: int, progress=None) -> int:
    """:func:`seedtrack.data.video.write_video` of ``frames``, in a process of its own when
    ``workers`` > 1, so that drawing the next frames goes on while x264 encodes.

    The encoder's settings (one x264 thread among them) do not change with ``workers``: the
    file is the same, byte for byte, either way.

    Parameters
    ----------
    path : path-like
        Output MP4, written atomically.
    frames : iterable of ndarray of uint8
        (H, W, 3) BGR or (H, W) gray frames, all the same size, consumed one at a time.
    fps : float
        Frames per second.
    workers : int
        1: encode here; more: encode in a separate process.
    progress : tqdm-like or callable, optional
        Ticked once per frame handed to the encoder.

    Returns
    -------
    int
        Number of frames written.

    Raises
    ------
    ValueError, DataError
        As :func:`~seedtrack.data.video.write_video`; an error of the frames' iterator is
        raised as it is, and no file is left behind.

    Example
    -------
    >>> import numpy as np, tempfile, pathlib
    >>> folder = pathlib.Path(tempfile.mkdtemp())
    >>> encode_video(folder / "grey.mp4", [np.full((32, 32), 128, np.uint8)] * 3, 25.0, workers=1)
    3
    """
    if workers <= 1 or not can_start_processes():
        return write_video(path, frames, fps, progress=progress)
    ours, theirs = multiprocessing.Pipe()
    encoder = process_context().Process(target=_encode_received, args=(theirs, os.fspath(path), fps), daemon=True)
    with _ctrl_c_held():
        encoder.start()
    theirs.close()
    tick = progress.update if hasattr(progress, "update") else progress
    try:
        try:
            for frame in frames:
                frame = np.ascontiguousarray(frame)
                ours.send((frame.shape, frame.dtype.str))
                ours.send_bytes(memoryview(frame).cast("B"))
                if tick is not None:
                    tick(1)
            ours.send(None)
        except (BrokenPipeError, ConnectionResetError):
            pass  # the encoder stopped at a bad frame: its answer says why
        outcome, value = ours.recv()
    except EOFError:
        raise RuntimeError(f"the video encoder for {path} stopped (exit status {encoder.exitcode})") from None
    finally:
        # Closing our end first tells an encoder still waiting for frames to give up and remove
        # its temporary file.
        ours.close()
        encoder.join()
    if outcome == "failed":
        raise value
    return value


def _encode_received(connection, path: str, fps: float) -> None:
    """Encoder process: write the frames that arrive on ``connection``, answer with the count
    or the error."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the parent's to handle

    def received():
        while (header := connection.recv()) is not None:
            shape, dtype = header
            yield np.frombuffer(connection.recv_bytes(), dtype=dtype).reshape(shape)

    try:
        answer = ("done", write_video(path, received(), fps))
    except EOFError:
        return  # the parent gave up; write_video has removed its temporary file
    except Exception as error:
        answer = ("failed", error)
    try:
        connection.send(answer)
    except (BrokenPipeError, ConnectionResetError):
        pass


_FUNCTION: Callable | None = None


def _install(function: Callable) -> None:
    """Worker initialiser: keep the function every task of this pool applies."""
    global _FUNCTION
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the parent's to handle
    _reuse_heap_memory()
    _FUNCTION = function


def _reuse_heap_memory() -> None:
    """Have glibc serve frame-sized allocations of this process from memory it keeps."""
    set_malloc_options(M_MMAP_THRESHOLD=_HEAP_REUSE_BYTES, M_TRIM_THRESHOLD=_HEAP_REUSE_BYTES)


def _apply(item):
    return _FUNCTION(item)
