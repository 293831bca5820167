"""Progress bars for loops over frames, shown on a terminal and silent in logs."""

from __future__ import annotations

import threading

from tqdm import tqdm

# tqdm's default lock includes a multiprocessing semaphore, registered with the resource tracker
# that a batch's worker processes share with the command. A worker stopped without running its
# finalizers (Ctrl-C stops the cluster) left it behind, and the tracker printed a "leaked
# semaphore" warning beside the command's one line. Bars are only ever drawn by one process,
# so a thread lock is all they need.
tqdm.set_lock(threading.RLock())


def progress_bar(total: int | None, description: str, unit: str = "frame") -> tqdm:
    """A tqdm bar on standard error; hidden when standard error is not a terminal."""
    return tqdm(total=total, desc=description, unit=unit, disable=None, leave=False, dynamic_ncols=True)
