"""The paper's PSMG experiments, rerun on demand with every tracker and today's peers.

An experiment is a list of cases (one per value of the swept parameter), each a PSMG spec and
the speed limit handed to every tracker. A run draws one data set per case from a seed that
depends only on the experiment, the case and the run number, tracks it with every tracker and
scores the result against the truth; the same options therefore give the same files. Under the
"given" protocol (the paper's) every tracker is handed the true links of frames 0 and 1; under
"self" each initialises itself (:data:`PROTOCOLS`, :func:`run_task`).
"""

from __future__ import annotations

import math
import time
import zlib
from dataclasses import dataclass, field, replace
from typing import Callable

import numpy as np

from seedtrack.data.psmg import PSMGSpec, generate_psmg
from seedtrack.tracking.goa import GOAConfig
from seedtrack.tracking.linking import link_goa
from seedtrack.tracking.metrics import score_tracks
from seedtrack.tracking.motion import CombinedModel, IndividualModel
from seedtrack.tracking.rs import rangarajan_shah
from seedtrack.tracking.tracks import Tracks
from seedtrack.tracking.trackers import TRACKERS

from .peers import GIVEN_PEERS, PEERS, PeerFailure, peers_available

# PSMG settings the sources leave open, chosen so that our IPAN reproduces Chetverikov and
# Verestoy's published merits (see the ipan-table experiment and the README): initial speed
# spread, speed step and direction step, in pixels/frame and degrees.
SPEED_SIGMA = 0.5
SPEED_STEP_SIGMA = 0.3
ANGLE_STEP_SIGMA = 7.0
# Occlusion probability of the "with occlusion" rows of the IPAN table (single-frame). The
# sources give none (Chetverikov's applet allows 0 to 0.3). At 0.03 our IPAN (100 runs) loses
# 1.8 to 3.5 points of merit to occlusion at speed 3 and 4.6 to 6.2 at speed 12, against the
# published 0.25 to 1.2 and 3.0 to 7.9: a higher value would widen the low-speed gap.
TABLE_OCCLUSION = 0.03
# The base scene of Veenman's sweeps: Chetverikov's 20 frames in 200 x 200, speed 5, 50 points.
BASE = PSMGSpec(
    trajectories=50,
    frames=20,
    size=200.0,
    mean_speed=5.0,
    speed_sigma=SPEED_SIGMA,
    speed_step_sigma=SPEED_STEP_SIGMA,
    angle_step_sigma=ANGLE_STEP_SIGMA,
)
# Scenes for the tests: few frames and points, so that every experiment runs in seconds.
TINY = replace(BASE, trajectories=8, frames=6, size=80.0)
# Points are matched to the truth within this distance, pixels; trackers report measured
# positions exactly, so any positive tolerance below the point spacing gives the same scores.
TOLERANCE = 0.5
# Standard errors in a two-sided 95% normal interval.
Z_95 = 1.96

# Published strict trajectory merits (%) of IPAN, self-initialising, PSMG without entry/exit,
# 20 frames, 200 x 200, 100 trials (Chetverikov and Verestoy; ALGORITHMS.md section 12).
PUBLISHED_IPAN = {
    (3.0, 20, True): 95.35, (3.0, 40, True): 92.07, (3.0, 60, True): 89.98,
    (12.0, 20, True): 82.70, (12.0, 40, True): 67.55, (12.0, 60, True): 54.56,
    (3.0, 20, False): 95.60, (3.0, 40, False): 92.92, (3.0, 60, False): 91.20,
    (12.0, 20, False): 85.70, (12.0, 40, False): 74.02, (12.0, 60, False): 62.45,
}  # fmt: skip

# How the trackers start (``seedtrack experiment --protocol``): "given", the paper's (its section 6),
# hands every tracker the true correspondences of frames 0 and 1; "self" lets each initialise itself.
PROTOCOLS = ("self", "given")

Runner = Callable[[list[np.ndarray], float, "np.ndarray | None"], Tracks]


@dataclass(frozen=True)
class Case:
    """One value of the swept parameter: the data to draw and the speed limit to give.

    Attributes
    ----------
    x : float
        The swept value, as plotted.
    settings : dict of str to float
        What distinguishes this case, as written to the CSV (one column each).
    spec : PSMGSpec
        The data, apart from the random seed.
    speed_limit : float
        d_max / v_max / search range handed to every tracker, pixels/frame.
    """

    x: float
    settings: dict
    spec: PSMGSpec
    speed_limit: float


@dataclass(frozen=True)
class Experiment:
    """A sweep: its cases, the trackers it compares and what it measures.

    Attributes
    ----------
    name, title, x_label : str
    cases : callable
        ``cases(tiny) -> list[Case]``; tiny cases run in seconds.
    trackers : tuple of str
        Names from :data:`RUNNERS`; the peers are added when installed.
    measure : {"track_error", "seconds", "merit"}
        What the plot shows.
    with_peers : bool
    """

    name: str
    title: str
    x_label: str
    cases: Callable[[bool], list[Case]]
    trackers: tuple[str, ...]
    measure: str = "track_error"
    with_peers: bool = True


def _default(frames: list[np.ndarray], speed_limit: float, given: np.ndarray | None) -> Tracks:
    """seedtrack with no options: ``seedtrack track`` (the open GOA-updown, the motion measured),
    or given the first links ``seedtrack track --algorithm goa --first-links``."""
    if given is None:
        return TRACKERS["goa-updown"].run(frames, speed_limit, 0)
    return link_goa(frames, "goa", GOAConfig(d_max=speed_limit), first_links=given)[0]


# The published scheme (Veenman et al. 2001): IM2 + CM1, first links by nearest-neighbour
# assignment, a down pass that starts only from the up pass's links, one track per first-frame
# point, the motion model as given (no measuring pass).
PUBLISHED = GOAConfig(initialisation="im1", restart_lost=False)


def _published(config: GOAConfig = PUBLISHED) -> Runner:
    """The published scheme with ``config``'s models: GOA-updown as published, or under the given
    protocol the paper's GOA forward pass from the given first links."""

    def run(frames: list[np.ndarray], speed_limit: float, given: np.ndarray | None) -> Tracks:
        limited = replace(config, d_max=speed_limit)
        if given is not None:
            return link_goa(frames, "goa", limited, motion="smooth", first_links=given)[0]
        return link_goa(frames, "goa-updown-fixed", limited, None, motion="smooth")[0]

    return run


def _with_given_links(frames: list[np.ndarray], given: np.ndarray, tracks: Tracks) -> Tracks:
    """``tracks`` of ``frames[1:]`` (first frame 1) with each frame-0 point joined to the track
    of its given frame-1 partner (or a track of its own)."""
    rows = tracks.to_rows()
    measured = (rows["frame"] == 1) & (rows["interpolated"] == 0)
    where = {(float(x), float(y)): i for i, (x, y) in enumerate(frames[1])}
    owner = np.full(frames[1].shape[0], -1, np.int64)
    for track, x, y in zip(rows["track_id"][measured], rows["x"][measured], rows["y"][measured]):
        owner[where[(float(x), float(y))]] = track
    fresh = int(rows["track_id"].max(initial=-1)) + 1 + np.arange(frames[0].shape[0])
    ids = fresh.copy()
    linked = given[(given[:, 0] >= 0) & (given[:, 1] >= 0)]
    joined = owner[linked[:, 1]]
    ids[linked[:, 0]] = np.where(joined >= 0, joined, fresh[linked[:, 0]])
    return Tracks.from_rows(
        np.concatenate((ids, rows["track_id"])),
        np.concatenate((np.zeros(frames[0].shape[0], np.int64), rows["frame"])),
        np.concatenate((frames[0][:, 0], rows["x"])),
        np.concatenate((frames[0][:, 1], rows["y"])),
        np.concatenate((np.zeros(frames[0].shape[0], np.int64), rows["interpolated"])),
    )


def _linker(run: Callable[[list[np.ndarray], float, int], Tracks]) -> Runner:
    """A tracker that takes no first links: under the given protocol it links frames 1 onwards
    and the given links join frame 0 on (exactly the given protocol for a linker that decides
    each frame pair alone, as nn and trackpy without memory do)."""

    def runner(frames: list[np.ndarray], speed_limit: float, given: np.ndarray | None) -> Tracks:
        if given is None:
            return run(frames, speed_limit, 0)
        return _with_given_links(frames, given, run(frames[1:], speed_limit, 1))

    return runner


def _peer(name: str) -> Runner:
    """A peer; under the given protocol with the first links when it can take them."""
    spliced = _linker(PEERS[name])

    def run(frames: list[np.ndarray], speed_limit: float, given: np.ndarray | None) -> Tracks:
        if given is not None and name in GIVEN_PEERS:
            return GIVEN_PEERS[name](frames, speed_limit, given)
        return spliced(frames, speed_limit, given)

    return run


def _rs(frames: list[np.ndarray], speed_limit: float, given: np.ndarray | None) -> Tracks:
    return rangarajan_shah(frames, speed_limit, initial=given)


RUNNERS: dict[str, Runner] = {
    "default": _default,
    "published": _published(),
    **{name: _linker(TRACKERS[name].run) for name in ("nn", "ss", "ipan")},
    "rs": _rs,
    "goa im1": _published(replace(PUBLISHED, individual=IndividualModel("im1"))),
    "goa im2": _published(),
    "goa im3": _published(replace(PUBLISHED, individual=IndividualModel("im3"))),
    "goa im2 cm1 z=2": _published(replace(PUBLISHED, combined=CombinedModel("cm1", z=2.0))),
    "goa im2 cm2 w=0.5": _published(replace(PUBLISHED, combined=CombinedModel("cm2", w1=0.5, w2=0.5))),
    "goa im2 cm2 w=0.1": _published(replace(PUBLISHED, combined=CombinedModel("cm2", w1=0.1, w2=0.1))),
    "goa im2 cm2-margin w=0.5": _published(replace(PUBLISHED, combined=CombinedModel("cm2-margin", w1=0.5, w2=0.5))),
    "goa im2 cm2-margin w=0.1": _published(replace(PUBLISHED, combined=CombinedModel("cm2-margin", w1=0.1, w2=0.1))),
    **{name: _peer(name) for name in PEERS},
}
OURS = ("default", "published", "nn", "ss", "rs", "ipan")
# The peers the sweeps run, and the largest scene (points) each runs on: Stone Soup's trackers
# are 30 to 1000 times slower than the others (its MFA took 6 s on 10 points, 13 s on 25, 41 s
# on 50 and 348 s on 100 on the shared 2-core machine; tests/benchmarks/bench_stonesoup_mfa.py).
SWEEP_PEERS = {"trackpy": None, "trackpy-adaptive": None, "trackpy-predict": None, "laptrack": None,
               "stonesoup": 25, "stonesoup-mfa": 10}


def _base(tiny: bool) -> PSMGSpec:
    return TINY if tiny else BASE


def _sweep(field_name: str, full: tuple, tiny: tuple, speed_factor: float = 2.0, **fixed) -> Callable[[bool], list[Case]]:
    """Cases that vary one PSMG field; the speed limit is ``speed_factor`` times the mean speed."""

    def cases(is_tiny: bool) -> list[Case]:
        out = []
        for value in tiny if is_tiny else full:
            spec = replace(_base(is_tiny), **fixed, **{field_name: value})
            out.append(Case(float(value), {field_name: value}, spec, speed_factor * spec.mean_speed))
        return out

    return cases


def _same_density(spec: PSMGSpec, size: float) -> PSMGSpec:
    """The spec in a square of side ``size`` with as many points as keep its density."""
    return replace(spec, size=size, trajectories=max(1, round(spec.trajectories * (size / spec.size) ** 2)))


def _velocity_cases(tiny: bool) -> list[Case]:
    # As in the paper, the standard deviations grow with the mean speed and the view grows so
    # that fast points need not run along a diagonal; the point count keeps the density.
    base = _base(tiny)
    out = []
    for speed in (2.0, 4.0) if tiny else (1.0, 2.0, 4.0, 6.0, 8.0, 10.0, 12.0):
        scale = speed / BASE.mean_speed
        size = max(base.size, 1.25 * (base.frames - 1) * speed)
        spec = replace(
            _same_density(base, size),
            mean_speed=speed,
            speed_sigma=base.speed_sigma * scale,
            speed_step_sigma=base.speed_step_sigma * scale,
        )
        out.append(Case(speed, {"mean_speed": speed}, spec, 2.0 * speed))
    return out


def _volume_cases(tiny: bool) -> list[Case]:
    base = _base(tiny)
    out = []
    for count in (8, 16) if tiny else (25, 50, 100, 200, 400):
        spec = _same_density(base, base.size * math.sqrt(count / base.trajectories))
        spec = replace(spec, trajectories=count)
        out.append(Case(float(count), {"trajectories": count}, spec, 2.0 * spec.mean_speed))
    return out


def _dmax_cases(tiny: bool) -> list[Case]:
    base = _base(tiny)
    factors = (1.5, 3.0) if tiny else (1.25, 1.5, 2.0, 3.0, 5.0, 10.0)
    return [Case(f, {"d_max_factor": f}, base, f * base.mean_speed) for f in factors]


def _ipan_table_cases(tiny: bool) -> list[Case]:
    out = []
    for occluded in (False, True):
        for speed in (3.0, 12.0):
            for count in (4, 8) if tiny else (20, 40, 60):
                spec = replace(
                    TINY if tiny else BASE,
                    trajectories=count,
                    mean_speed=speed,
                    occlusion=TABLE_OCCLUSION if occluded else 0.0,
                )
                if tiny:
                    spec = replace(spec, size=max(spec.size, 1.25 * (spec.frames - 1) * speed))
                settings = {"mean_speed": speed, "trajectories": count, "occlusion": spec.occlusion}
                out.append(Case(float(count), settings, spec, 2.0 * speed))
    return out


EXPERIMENTS: dict[str, Experiment] = {
    e.name: e
    for e in (
        Experiment(
            "models",
            "the published GOA-updown (GOA with the first links given) with each motion model",
            "trajectories",
            _sweep("trajectories", (20, 40, 60, 80, 100), (4, 8)),
            ("goa im1", "goa im2", "goa im3", "goa im2 cm1 z=2", "goa im2 cm2 w=0.5", "goa im2 cm2 w=0.1",
             "goa im2 cm2-margin w=0.5", "goa im2 cm2-margin w=0.1"),
            with_peers=False,
        ),
        Experiment("density", "track error vs number of points", "trajectories",
                   _sweep("trajectories", (10, 25, 50, 75, 100), (4, 8)), OURS),
        Experiment("velocity", "track error vs mean speed (same density)", "mean speed, px/frame", _velocity_cases, OURS),
        Experiment("occlusion", "track error vs occlusion probability", "occlusion probability",
                   _sweep("occlusion", (0.05, 0.15, 0.25, 0.35, 0.45), (0.05, 0.25)), OURS),
        Experiment("volume", "run time vs number of points (same density)", "trajectories", _volume_cases, OURS,
                   measure="seconds"),
        Experiment("dmax", "track error vs speed limit", "d_max / mean speed", _dmax_cases, OURS),
        Experiment(
            "ipan-table",
            "strict trajectory merit, % (Chetverikov-Verestoy table)",
            "trajectories",
            _ipan_table_cases,
            ("ipan", "default", "published"),
            measure="merit",
            with_peers=False,
        ),
    )
}


def trackers_of(experiment: Experiment) -> tuple[str, ...]:
    """The experiment's trackers, with the sweeps' peers when they are installed."""
    peers = tuple(name for name in SWEEP_PEERS if name in PEERS)
    return experiment.trackers + (peers if experiment.with_peers and peers_available() else ())


def runs_on(tracker: str, spec: PSMGSpec) -> bool:
    """Whether ``tracker`` runs on scenes of ``spec``'s size (the slow peers stop at a size)."""
    largest = SWEEP_PEERS.get(tracker)
    return largest is None or spec.trajectories <= largest


def run_seed(name: str, case_index: int, run: int) -> int:
    """Random seed of one run: stable across processes and Python versions."""
    return zlib.crc32(f"{name}/{case_index}/{run}".encode())


@dataclass(frozen=True)
class Task:
    """One run of one case: everything a worker process needs."""

    experiment: str
    case_index: int
    run: int
    tiny: bool
    trackers: tuple[str, ...] = field(default=())
    protocol: str = "self"


def run_task(task: Task) -> list[dict]:
    """Draw the task's data set, run every tracker on it and score each.

    The data depend on the experiment, case and run only, so both protocols see the same points.
    Under the "given" protocol each tracker gets the true links of frames 0 and 1 (every PSMG
    point is present in both).

    Returns
    -------
    list of dict
        One row per tracker that runs at the case's size: the case's settings, run, seed,
        protocol, tracker, counts, errors, seconds, and ``failed``/``note`` for a tracker that
        gave up.
    """
    experiment = EXPERIMENTS[task.experiment]
    case = experiment.cases(task.tiny)[task.case_index]
    seed = run_seed(task.experiment, task.case_index, task.run)
    frames, truth = generate_psmg(replace(case.spec, random_seed=seed))
    given = truth.measurement[:, :2] if task.protocol == "given" else None
    rows = []
    for tracker in (t for t in task.trackers if runs_on(t, case.spec)):
        row = {**case.settings, "run": task.run, "seed": seed, "protocol": task.protocol, "tracker": tracker}
        start = time.perf_counter()
        try:
            result = RUNNERS[tracker](frames, case.speed_limit, given)
        except PeerFailure as failure:
            rows.append({**row, "true_tracks": truth.n_tracks, "correct_tracks": 0, "track_error": math.nan,
                         "relaxed_error": math.nan, "link_error": math.nan, "seconds": time.perf_counter() - start,
                         "failed": 1, "note": str(failure).splitlines()[0][:120]})
            continue
        seconds = time.perf_counter() - start
        scores = score_tracks(result, truth, TOLERANCE)
        rows.append({**row, "true_tracks": scores.true_tracks, "correct_tracks": scores.correct_tracks,
                     "track_error": scores.track_error, "relaxed_error": scores.relaxed_error,
                     "link_error": scores.link_error, "seconds": seconds, "failed": 0, "note": ""})
    return rows


def ci95(values) -> float:
    """Half-width of the 95% confidence interval of the mean of ``values``.

    Normal approximation: 1.96 standard errors (sample standard deviation over the square
    root of the count), in the values' units; 0 for fewer than two values.
    """
    values = np.asarray(values, dtype=float)
    return float(Z_95 * values.std(ddof=1) / math.sqrt(values.size)) if values.size > 1 else 0.0


def summarise(experiment: Experiment, rows: list[dict], tiny: bool) -> list[dict]:
    """Mean and 95% interval per case and tracker; failed runs are counted, not averaged.

    For ``merit`` experiments the published IPAN merit is added to each case.
    """
    cases = experiment.cases(tiny)
    out = []
    for index, case in enumerate(cases):
        for tracker in dict.fromkeys(r["tracker"] for r in rows):
            mine = [r for r in rows if r["tracker"] == tracker and all(r[k] == v for k, v in case.settings.items())]
            if not mine:
                continue
            ok = [r for r in mine if not r["failed"]]
            entry = {**case.settings, "tracker": tracker, "protocol": mine[0]["protocol"], "runs": len(mine),
                     "failures": len(mine) - len(ok)}
            for column in ("track_error", "relaxed_error", "link_error", "seconds"):
                values = np.array([r[column] for r in ok], float)
                entry[column] = float(values.mean()) if values.size else math.nan
                entry[column + "_ci95"] = ci95(values)
            if experiment.measure == "merit":
                entry["merit"] = 100.0 * (1.0 - entry["track_error"])
                entry["merit_ci95"] = 100.0 * entry["track_error_ci95"]
                key = (case.settings["mean_speed"], case.settings["trajectories"], case.settings["occlusion"] > 0)
                entry["published_ipan"] = PUBLISHED_IPAN.get(key, math.nan)
            out.append(entry)
    return out
