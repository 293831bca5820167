"""``seedtrack batch INPUT... --out DIR``: ``run`` on many clips, on a Dask cluster."""

from __future__ import annotations

import argparse
import contextlib
import logging
import signal
import sys
from pathlib import Path

from tqdm import tqdm

from ..batch import ClipResult, RunOptions, clip_names, run_batch
from ..errors import UsageError
from ..outputs import refuse_replacing_inputs
from ..parallel import default_workers
from ..progress import progress_bar
from ..wording import CLIP_INPUT_HELP, counted
from .detect import add_detection_options, detection_settings
from .run import workers_count
from .tracker_options import add_tracker_options, tracking_settings


# How long to keep trying to reach a scheduler named by --scheduler.
CONNECT_TIMEOUT = "10s"


def add_parser(subparsers) -> None:
    parser = subparsers.add_parser(
        "batch",
        description="Run each INPUT as `seedtrack run` does, into DIR/<clip name>/ (the same files, byte for byte), "
        "spread over the workers of a Dask cluster: a local one started here unless --scheduler names a running one. "
        "DIR/batch.csv lists input, status (done, failed, skipped), frames, tracks, seconds and the error of a failure. "
        "A clip that fails does not stop the others (exit status 1 if any failed); a rerun skips the clips already done "
        "with the same options.",
    )
    parser.add_argument("inputs", type=Path, nargs="+", metavar="INPUT", help=f"clips, each a {CLIP_INPUT_HELP}")
    parser.add_argument("--out", type=Path, required=True, metavar="DIR", help="output folder (created if missing)")
    parser.add_argument(
        "--workers",
        type=int,
        default=None,
        metavar="N",
        help=f"worker processes of the local cluster, one clip each at a time (default: the cores, here {default_workers()})",
    )
    parser.add_argument(
        "--scheduler",
        default=None,
        metavar="ADDRESS",
        help="a running Dask scheduler, e.g. tcp://10.0.0.5:8786 (as `dask scheduler` prints); its workers must "
        "have seedtrack installed and see INPUT and DIR under the same paths",
    )
    add_detection_options(parser)
    add_tracker_options(parser)
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    options = RunOptions(detection_settings(args), tracking_settings(args))
    if args.scheduler is not None and args.workers is not None:
        raise UsageError("--workers sizes the local cluster; with --scheduler the cluster's own workers run the clips")
    clip_names(args.inputs)  # refuse clashing names before starting a cluster
    refuse_replacing_inputs(args.inputs, [args.out / "batch.csv"])
    with _client(args.scheduler, workers_count(args)) as client, progress_bar(len(args.inputs), "clips", unit="clip") as bar:

        def show(result: ClipResult) -> None:
            if result.status == "failed":
                tqdm.write(f"seedtrack batch: {result.error}", file=sys.stderr)
            elif result.status == "done":
                done = f"{result.input}: {counted(result.frames, 'frame')}, {counted(result.tracks, 'track')} in {result.seconds:.1f} s"
                tqdm.write(f"{done}; {result.said}" if result.said else done, file=sys.stdout)
            bar.update(1)

        results = run_batch(client, args.inputs, args.out, options, on_result=show)
    counts = {status: sum(result.status == status for result in results) for status in ("done", "skipped", "failed")}
    print(
        f"{counted(len(results), 'clip')}: {counts['done']} done, {counts['skipped']} skipped (done before), "
        f"{counts['failed']} failed; wrote {args.out / 'batch.csv'}"
    )
    return 1 if counts["failed"] else 0


@contextlib.contextmanager
def _client(scheduler: str | None, workers: int):
    """A Dask client of the scheduler at ``scheduler``, or of a local cluster of ``workers``
    single-threaded processes listening on the loopback interface only."""
    try:
        from distributed import Client, LocalCluster
    except ImportError:
        raise UsageError("batch needs Dask's distributed scheduler: pip install 'seedtrack[batch]'") from None

    if scheduler is not None:
        try:
            client = Client(scheduler, timeout=CONNECT_TIMEOUT)
        except (OSError, TimeoutError, ValueError) as error:
            raise UsageError(f"--scheduler {scheduler}: cannot reach a Dask scheduler there ({error})") from None
        with client:
            yield client
        return
    # Workers started while Ctrl-C is ignored keep ignoring it, so that it reaches this process
    # alone, which stops them in order instead of each printing its own traceback.
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        cluster = LocalCluster(
            n_workers=workers,
            threads_per_worker=1,
            processes=True,
            host="127.0.0.1",
            # Its status page too on a free port of the loopback interface: the default, 8787
            # on every interface, is taken by a second batch and open to the network.
            dashboard_address="127.0.0.1:0",
            silence_logs=logging.ERROR,
        )
    finally:
        signal.signal(signal.SIGINT, previous)
    with cluster, Client(cluster) as client:
        yield client
