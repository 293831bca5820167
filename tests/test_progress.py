"""Progress bars leave nothing behind in a worker process that is stopped abruptly."""

import subprocess
import sys

_WORKER_STOPPED_ABRUPTLY = """
import multiprocessing, os

def worker():
    from seedtrack.progress import progress_bar
    progress_bar(3, "frames")
    os._exit(0)  # as a batch worker stopped by Ctrl-C, its finalizers not run

if __name__ == "__main__":
    process = multiprocessing.get_context("spawn").Process(target=worker)
    process.start()
    process.join()
"""


def test_a_bar_in_a_worker_stopped_abruptly_leaks_no_semaphore(tmp_path):
    script = tmp_path / "worker.py"
    script.write_text(_WORKER_STOPPED_ABRUPTLY)
    result = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, timeout=120)
    assert result.returncode == 0 and result.stderr == "", result.stderr
