"""TrackMate XML (Fiji): ``Model/AllSpots/SpotsInFrame/Spot`` and ``Model/AllTracks/Track/Edge``.

A spot carries ``ID``, ``FRAME`` (0-based, as ours) and ``POSITION_X``/``POSITION_Y`` in the
model's ``spatialunits``: pixels, or, for a calibrated image, a length unit (``micron``...) with
the pixel size in ``Settings/ImageData``'s ``pixelwidth`` and ``pixelheight``; positions are read
back into pixels by dividing by them (a calibrated file without them is refused), and
:func:`calibration` gives the file's units. The writer writes pixels and frames, or the
calibrated units it is given. A track is the set of spots its edges
(``SPOT_SOURCE_ID``, ``SPOT_TARGET_ID``) join, under its ``TRACK_ID``. When the file lists
``FilteredTracks``, only those tracks are read, as TrackMate shows them. Spots on no track
(unlinked detections) are not tracks and are skipped, so a track of a single point cannot be
stored in this format: the writer leaves such tracks out. A track that splits or merges (a cell
dividing; TrackMate's own FakeTracks example) is read as its branches: each unbranched run of
spots is a track of its own, the first keeping the TrackMate id and the others numbered after
the file's largest id, with a warning that says how many tracks branched.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET

import numpy as np

from ..calibration import FRAME, PIXEL, Calibration
from ..errors import DataError, warn
from .rows import Rows
from .xmltree import number, parse_xml, write_xml


def read(path) -> Rows:
    """Rows of a TrackMate file: one per spot on a track."""
    root = parse_xml(path)
    model = root.find("Model") if root.tag == "TrackMate" else None
    if model is None:
        raise DataError(path, f"line {root.line}: not a TrackMate file (expected <TrackMate><Model>, found <{root.tag}>)")
    width, height = _pixel_size(path, root, model)
    spots = {}
    for spot in model.iter("Spot"):
        spot_id = int(number(path, spot, "ID", whole=True))
        spots[spot_id] = (int(number(path, spot, "FRAME", whole=True)), number(path, spot, "POSITION_X") / width, number(path, spot, "POSITION_Y") / height, spot.line)
    shown = model.find("FilteredTracks")
    keep = None if shown is None else {int(number(path, t, "TRACK_ID", whole=True)) for t in shown.iter("TrackID")}
    tracks = []
    all_tracks = model.find("AllTracks")
    for track in all_tracks.iter("Track") if all_tracks is not None else ():
        track_id = int(number(path, track, "TRACK_ID", whole=True))
        if keep is not None and track_id not in keep:
            continue
        edges = []
        for edge in track.iter("Edge"):
            ends = [int(number(path, edge, end, whole=True)) for end in ("SPOT_SOURCE_ID", "SPOT_TARGET_ID")]
            for spot_id in ends:
                if spot_id not in spots:
                    raise DataError(path, f"line {edge.line}: edge names spot {spot_id}, which is not in AllSpots")
            edges.append(sorted(ends, key=lambda spot_id: spots[spot_id][0]))  # earlier frame first
        tracks.append((track_id, unbranched_runs(edges)))
    rows, branched = [], 0
    next_id = max((track_id for track_id, _ in tracks), default=-1) + 1
    for track_id, branches in tracks:
        branched += len(branches) > 1
        for number_in_track, branch in enumerate(branches):
            segment_id = track_id if number_in_track == 0 else next_id
            next_id += number_in_track > 0
            rows.extend((segment_id, *spots[spot_id]) for spot_id in branch)
    if branched:
        warn(path, f"{branched} TrackMate track(s) split or merge; each unbranched part is read as a track of its own")
    table = np.array(rows, dtype=float).reshape(-1, 5)
    return Rows(table[:, 0].astype(np.int64), table[:, 1].astype(np.int64), table[:, 2], table[:, 3], table[:, 4].astype(np.int64))


def calibration(path) -> Calibration:
    """The units a TrackMate file's positions and times are in.

    Raises
    ------
    DataError
        If the file is not TrackMate's, or its positions are calibrated but it gives no pixel size.
    """
    root = parse_xml(path)
    model = root.find("Model") if root.tag == "TrackMate" else None
    if model is None:
        raise DataError(path, f"line {root.line}: not a TrackMate file (expected <TrackMate><Model>, found <{root.tag}>)")
    width, _ = _pixel_size(path, root, model)
    image = _image_data(root)
    interval = number(path, image, "timeinterval") if image is not None and "timeinterval" in image.attrib else 1.0
    time_unit = model.attrib.get("timeunits", FRAME) or FRAME
    if time_unit.lower() in ("frame", "frames"):
        time_unit, interval = FRAME, 1.0
    space_unit = model.attrib.get("spatialunits", PIXEL) or PIXEL
    if _is_pixels(space_unit):
        space_unit = PIXEL
    try:
        return Calibration(width, space_unit, interval if interval > 0 else 1.0, time_unit)
    except ValueError as error:
        raise DataError(path, f"line {model.line}: {error}") from None


def check_pixels(path, line: int, unit: str) -> None:
    """Refuse TrackMate spot-table positions in a calibrated unit (microns...): ours are pixels,
    and a spot table carries no pixel size to convert them.

    Raises
    ------
    DataError
        Naming ``path``, ``line`` and the unit, unless ``unit`` is empty or pixels.

    Example
    -------
    >>> check_pixels("spots.csv", 4, "pixel")
    """
    if not _is_pixels(unit):
        raise DataError(path, f"line {line}: TrackMate's positions are in {unit}, not pixels; export them from the image with its pixel size set to 1 pixel (Image > Properties)")


def _is_pixels(unit: str) -> bool:
    return unit.lower() in ("", "pixel", "pixels")


def _image_data(root):
    settings = root.find("Settings")
    return settings.find("ImageData") if settings is not None else None


def _pixel_size(path, root, model) -> tuple[float, float]:
    """Length of a pixel along x and y in the model's spatial unit (1 when that unit is pixels)."""
    unit = model.attrib.get("spatialunits", "")
    if _is_pixels(unit):
        return 1.0, 1.0
    image = _image_data(root)
    if image is None or "pixelwidth" not in image.attrib:
        raise DataError(path, f"line {model.line}: TrackMate's positions are in {unit}, but the file gives no pixel size (<Settings><ImageData pixelwidth=...>) to turn them into pixels")
    width = number(path, image, "pixelwidth")
    height = number(path, image, "pixelheight") if "pixelheight" in image.attrib else width
    if not (width > 0 and height > 0):
        raise DataError(path, f"line {image.line}: pixel size {width:g} x {height:g} {unit}; it must be positive")
    return width, height


def write(path, rows: dict[str, np.ndarray], units: Calibration | None = None) -> None:
    """Write tracks as a TrackMate model, atomically, in pixels and frames or in the units given
    (positions times the pixel size, ``POSITION_T`` times the frame interval, and the image's
    calibration in ``Settings/ImageData``); single-point tracks are left out."""
    units = units or Calibration()
    ids, counts = np.unique(rows["track_id"], return_counts=True)
    linked = np.isin(rows["track_id"], ids[counts > 1])
    order = np.flatnonzero(linked)[np.lexsort((rows["track_id"][linked], rows["frame"][linked]))]
    root = ET.Element("TrackMate", version="7.0.0")
    model = ET.SubElement(root, "Model", spatialunits=units.space_unit, timeunits=units.time_unit)
    all_spots = ET.SubElement(model, "AllSpots", nspots=str(order.size))
    # Spot ids are row positions in frame order, so the same tracks give the same file.
    spot_id = np.empty(rows["frame"].size, dtype=np.int64)
    spot_id[order] = np.arange(order.size)
    frames_element = {}
    for i in order:
        frame = int(rows["frame"][i])
        if frame not in frames_element:
            frames_element[frame] = ET.SubElement(all_spots, "SpotsInFrame", frame=str(frame))
        ET.SubElement(
            frames_element[frame],
            "Spot",
            ID=str(spot_id[i]),
            name=f"ID{spot_id[i]}",
            FRAME=str(frame),
            POSITION_X=f"{units.length(rows['x'][i]):.4f}",
            POSITION_Y=f"{units.length(rows['y'][i]):.4f}",
            POSITION_Z="0.0",
            POSITION_T=f"{float(units.duration(frame))}",
            QUALITY="1.0",
            RADIUS=f"{units.length(1.0)}",
            VISIBILITY="1",
        )
    all_tracks = ET.SubElement(model, "AllTracks")
    filtered = ET.SubElement(model, "FilteredTracks")
    for track_id in ids[counts > 1]:
        members = np.flatnonzero(rows["track_id"] == track_id)
        members = members[np.argsort(rows["frame"][members])]
        track = ET.SubElement(all_tracks, "Track", name=f"Track_{track_id}", TRACK_ID=str(track_id), NUMBER_SPOTS=str(members.size))
        for source, target in zip(members[:-1], members[1:]):
            ET.SubElement(track, "Edge", SPOT_SOURCE_ID=str(spot_id[source]), SPOT_TARGET_ID=str(spot_id[target]), EDGE_TIME=f"{rows['frame'][source] + 0.5}")
        ET.SubElement(filtered, "TrackID", TRACK_ID=str(track_id))
    if units.calibrated:
        settings = ET.SubElement(root, "Settings")
        size = f"{units.pixel_size}"
        ET.SubElement(settings, "ImageData", pixelwidth=size, pixelheight=size, voxeldepth=size, timeinterval=f"{units.frame_interval}")
    write_xml(path, root)


def unbranched_runs(edges: list[list[int]]) -> list[list[int]]:
    """The unbranched runs of spots of one track, from its (earlier, later) edges: a run ends
    where a spot has other than one successor, or its successor other than one predecessor."""
    after: dict[int, list[int]] = {}
    before: dict[int, list[int]] = {}
    for source, target in edges:
        after.setdefault(source, []).append(target)
        before.setdefault(target, []).append(source)
        after.setdefault(target, [])
        before.setdefault(source, [])

    def continues(spot: int) -> bool:
        return len(after[spot]) == 1 and len(before[after[spot][0]]) == 1

    heads = [spot for spot in sorted(after) if len(before[spot]) != 1 or not continues(before[spot][0])]
    branches = []
    for spot in heads:
        branch = [spot]
        while continues(branch[-1]):
            branch.append(after[branch[-1]][0])
        branches.append(branch)
    return branches
