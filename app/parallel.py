"""Work over the frames of a clip on both cores (or more), with results in the order of the frames.

Frames are independent for detection and for drawing, so each is one task for a thread
(:func:`threaded_map`): OpenCV's calls and numpy's operations on whole frames let go of Python's
lock, and PyAV's decoder does too, so threads of one process share the cores without pickling
frames or starting processes (which on a 300-frame clip cost more than detecting its frames).
The x264 encoder has a process of its own (:class:`VideoEncoder`), so that it never waits for
drawing's turn at the lock, started early enough that starting it overlaps other work. At most
a few frames per worker are in flight, so memory does not grow with the clip.
"""

from __future__ import annotations

import collections
import contextlib
import multiprocessing
import os
import queue
import signal
import threading
from concurrent.futures import Executor, ThreadPoolExecutor
from typing import Callable, Iterable, Iterator, TypeVar

import numpy as np

from seedtrack.data.video import write_video

from .processes import can_start_processes, default_workers, process_context

Item = TypeVar("Item")
Result = TypeVar("Result")

# Frames queued per worker beyond the one it is on: enough to hide the hand-over, few enough
# that frames in flight stay a few megabytes.
_QUEUED_PER_WORKER = 2


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


def threaded_map(function: Callable[[Item], Result], items: Iterable[Item], workers: int) -> Iterator[Result]:
    """``function(item)`` for each item, in the items' order, computed by ``workers`` threads.

    For work that lets go of Python's lock for most of its time, as detection does (OpenCV's
    calls on whole frames): nothing is pickled and no process started, which on a 300-frame clip
    cost more than detecting its frames. Results are the same whatever ``workers`` is as long as
    ``function`` depends only on its item and may be called from several threads at once.

    Parameters
    ----------
    function : callable
    items : iterable
        Consumed a few items per thread ahead of the results.
    workers : int
        Threads, >= 1; with one, everything runs in the calling thread.

    Yields
    ------
    The results, in order. An exception raised by ``function`` is raised here, at its item.

    Example
    -------
    >>> list(threaded_map(abs, [-3, 1, -2], workers=2))
    [3, 1, 2]
    """
    if workers <= 1:
        yield from map(function, items)
        return
    with ThreadPoolExecutor(workers, thread_name_prefix="worker") as pool:
        yield from _in_order(pool, function, items, workers)


def _in_order(pool: Executor, function: Callable[[Item], Result], items: Iterable[Item], workers: int) -> Iterator[Result]:
    """Results of ``function`` on ``items`` submitted to ``pool``, in order, with a few items per
    worker in flight; those not started yet are cancelled if the results are left unread."""
    pending: collections.deque = collections.deque()
    try:
        for item in items:
            pending.append(pool.submit(function, item))
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


class VideoEncoder:
    """:func:`seedtrack.data.video.write_video` started before its frames are ready: with
    ``workers`` > 1 the encoder's process starts at once, so that starting it (and the fork
    server, the first time) overlaps whatever this process does before :meth:`write`.

    The encoder's settings (one x264 thread among them) do not change with ``workers``: the
    file is the same, byte for byte, either way. Leaving the block without having written
    stops the encoder, and no file is left behind.

    Parameters
    ----------
    path : path-like
        Output MP4, written atomically.
    fps : float
        Frames per second.
    workers : int
        1: encode in this process, in :meth:`write`; more: in a process of its own.
    preset : str
        x264 preset (:func:`~seedtrack.data.video.write_video`).
    crf : int
        x264 constant rate factor, 0 to 51.

    Example
    -------
    >>> import numpy as np, tempfile, pathlib
    >>> folder = pathlib.Path(tempfile.mkdtemp())
    >>> with VideoEncoder(folder / "grey.mp4", 25.0, workers=1) as encoder:
    ...     encoder.write([np.full((32, 32), 128, np.uint8)] * 3)
    3
    """

    def __init__(self, path, fps: float, workers: int, preset: str = "veryfast", crf: int = 16) -> None:
        self.path, self.fps, self.preset, self.crf = path, fps, preset, crf
        self._encoder = self._ours = None
        if workers > 1 and can_start_processes():
            self._ours, theirs = multiprocessing.Pipe()
            self._encoder = process_context().Process(target=_encode_received, args=(theirs, os.fspath(path), fps, preset, crf), daemon=True)
            with _ctrl_c_held():
                self._encoder.start()
            theirs.close()

    def __enter__(self) -> "VideoEncoder":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def close(self) -> None:
        """Stop the encoder's process (an encoder still waiting for frames gives up and removes
        its temporary file)."""
        if self._encoder is not None:
            self._ours.close()
            self._encoder.join()
            self._encoder = None

    def write(self, frames: Iterable[np.ndarray], progress=None) -> int:
        """Encode ``frames`` into :attr:`path` (once per encoder).

        Parameters
        ----------
        frames : iterable of ndarray of uint8
            (H, W, 3) BGR or (H, W) gray frames, all the same size, consumed one at a time.
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
        """
        if self._encoder is None:
            return write_video(self.path, frames, self.fps, crf=self.crf, progress=progress, preset=self.preset)
        ours = self._ours
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
            raise RuntimeError(f"the video encoder for {self.path} stopped (exit status {self._encoder.exitcode})") from None
        finally:
            # Closing our end first tells an encoder still waiting for frames to give up and
            # remove its temporary file.
            self.close()
        if outcome == "failed":
            raise value
        return value


def _encode_received(connection, path: str, fps: float, preset: str, crf: int) -> None:
    """Encoder process: write the frames that arrive on ``connection``, answer with the count
    or the error."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the parent's to handle

    def received():
        while (header := connection.recv()) is not None:
            shape, dtype = header
            yield np.frombuffer(connection.recv_bytes(), dtype=dtype).reshape(shape)

    try:
        answer = ("done", write_video(path, received(), fps, crf=crf, preset=preset))
    except EOFError:
        return  # the parent gave up; write_video has removed its temporary file
    except Exception as error:
        answer = ("failed", error)
    try:
        connection.send(answer)
    except (BrokenPipeError, ConnectionResetError):
        pass
