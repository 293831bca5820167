"""ISBI 2012 particle-tracking challenge XML: ``root/TrackContestISBI2012/particle/detection``.

Each ``particle`` is one track and each ``detection`` one point with attributes ``t`` (0-based
frame), ``x``, ``y`` (pixels) and ``z`` (ignored; written as 0). The format has no track ids:
particles are numbered 0, 1, 2... in file order on reading, and written in order of our track
ids, so ids other than 0, 1, 2... are renumbered by a round trip.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET

import numpy as np

from ..errors import DataError
from .rows import Rows
from .xmltree import number, parse_xml, write_xml


def read(path) -> Rows:
    """Rows of an ISBI challenge file; the track id is the particle's position in the file."""
    root = parse_xml(path)
    contest = root.find("TrackContestISBI2012")
    if contest is None:
        raise DataError(path, f"line {root.line}: not an ISBI challenge file (expected <root><TrackContestISBI2012>, found <{root.tag}>)")
    rows = []
    for track_id, particle in enumerate(p for p in contest.children if p.tag == "particle"):
        for detection in particle.iter("detection"):
            rows.append((track_id, number(path, detection, "t", whole=True), number(path, detection, "x"), number(path, detection, "y"), detection.line))
    table = np.array(rows, dtype=float).reshape(-1, 5)
    return Rows(table[:, 0].astype(np.int64), table[:, 1].astype(np.int64), table[:, 2], table[:, 3], table[:, 4].astype(np.int64))


def write(path, rows: dict[str, np.ndarray]) -> None:
    """Write tracks as ISBI challenge XML, one particle per track in id order, atomically."""
    root = ET.Element("root")
    contest = ET.SubElement(root, "TrackContestISBI2012")
    for track_id in np.unique(rows["track_id"]):
        members = np.flatnonzero(rows["track_id"] == track_id)
        particle = ET.SubElement(contest, "particle")
        for i in members[np.argsort(rows["frame"][members])]:
            ET.SubElement(particle, "detection", t=str(rows["frame"][i]), x=f"{rows['x'][i]:.4f}", y=f"{rows['y'][i]:.4f}", z="0")
    write_xml(path, root)
