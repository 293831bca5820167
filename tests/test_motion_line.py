"""The ``motion:`` line: one short line that names what the tracker uses, details with --verbose."""

from __future__ import annotations

import numpy as np
import pytest

from seedtrack.cli import main
from seedtrack.data.csvio import write_table
from seedtrack.data.psmg import PSMGSpec, generate_psmg
from seedtrack.data.walkers import WalkerSpec, generate_walkers
from seedtrack.tracking.goa import GOAConfig
from seedtrack.tracking.motion import IndividualModel
from seedtrack.tracking.persistence import MotionStatistics
from seedtrack.tracking.regime import MotionChoice, MotionFit
from seedtrack.wording import motion_lines


def test_a_first_look_at_random_motion_measured_smooth_is_called_smooth():
    first_look = MotionChoice("im1", 6.0, 0.1, 40, "random motion: steps turn at random (median turning cosine 0.10 over 40 chains)")
    statistics = MotionStatistics(0.9, 0.4, 0.02, (0.0, 0.0), 2.0, 120)
    config = GOAConfig(individual=IndividualModel(name="persistent", statistics=statistics), d_max=12.0)
    fit = MotionFit(first_look, config, (0.5, -0.25), "velocity persistence 0.90 (0 random walk, 1 smooth), noise 0.40 px/frame")
    line, *details = motion_lines(fit, verbose=True)
    assert line == "motion: smooth motion (persistence 0.90, noise 0.40 px/frame, drift (0.50, -0.25) px/frame), speed limit 12.0 px/frame"
    assert "random" not in line and details[0].startswith("  first look") and "persistence 0.90" in details[1]
    assert motion_lines(fit) == [line]


def points_file(path, frames) -> None:
    xy = np.concatenate(frames)
    write_table(path, {"frame": np.repeat(np.arange(len(frames)), [len(f) for f in frames]), "x": xy[:, 0], "y": xy[:, 1]})


@pytest.mark.parametrize(
    "frames, kind",
    [
        (generate_walkers(WalkerSpec(walkers=120, frames=10, size=280.0, drift=(1.0, 0.5), random_seed=5))[0], "random"),
        (generate_psmg(PSMGSpec(trajectories=30, frames=12, random_seed=6))[0], "smooth"),
    ],
    ids=["walkers", "psmg"],
)
def test_track_says_one_short_line_and_the_details_with_verbose(frames, kind, tmp_path, capsys):
    points_file(tmp_path / "points.csv", frames)
    outputs = []
    for verbose in ([], ["--verbose"]):
        assert main(["track", str(tmp_path / "points.csv"), "--out", str(tmp_path / "t.csv"), *verbose]) == 0
        outputs.append(capsys.readouterr().out.splitlines())
    (line, written), (again, *details, written_again) = outputs
    assert line == again and written == written_again
    assert line.startswith(f"motion: {kind} motion (persistence ") and len(line) <= 120
    assert [d.split(":")[0] for d in details] == ["  first look, on unambiguous 3-frame chains", "  measured on a first pass, then tracked with"]
