"""GEFF, the graph exchange file format for tracking (a zarr folder, ``tracks.geff``), read and
written through the ``geff`` package (``pip install 'seedtrack[geff]'``).

A node is a point with properties ``t`` (0-based frame), ``y`` and ``x`` (pixels), ``track_id``
and ``interpolated``; an edge joins the consecutive points of a track. The metadata names the
axes ``t``, ``y``, ``x`` (napari's order) in units ``frame`` and ``pixel`` and, when the tracks
are calibrated, each axis's ``scale`` and ``scaled_unit`` (micrometre per pixel, second per
frame), and gives ``track_id`` as the tracklet property.

On reading, the time axis is the axis of type ``time`` (else ``t``) and the positions the axes
named ``x`` and ``y`` (else the last two space axes, as y then x); they must be in frames and
pixels (or have no unit). Tracks are the tracklet property when the metadata names one, else the
unbranched runs of the graph, numbered from 0 (a dividing cell's graph is read as its branches),
a node on no edge being a track of one point. Rows are numbered after the nodes (node 0 is
"line 1") in error messages.
"""

from __future__ import annotations

import os
import shutil
import tempfile
from pathlib import Path

import numpy as np

from ..calibration import FRAME, PIXEL, Calibration
from ..errors import DataError
from .rows import Rows
from .trackmate import unbranched_runs

# Unit names as the OME-Zarr list GEFF follows spells them, for the usual short ones.
_OME_UNITS = {"um": "micrometer", "µm": "micrometer", "micron": "micrometer", "microns": "micrometer", "mm": "millimeter", "nm": "nanometer", "s": "second", "sec": "second", "ms": "millisecond", "min": "minute", "h": "hour"}


def _geff(path):
    try:
        import geff
        import geff_spec
    except ImportError:
        raise DataError(path, "GEFF files need the geff package: pip install 'seedtrack[geff]'") from None
    return geff, geff_spec


def _read_memory(path):
    path = Path(path)
    if not path.is_dir():
        raise DataError(path, "no such GEFF folder" if not path.exists() else "a GEFF file is a zarr folder, and this is a file")
    _geff(path)
    from geff.core_io import read_to_memory

    try:
        return read_to_memory(str(path))
    except Exception as error:  # the geff package raises many kinds for a bad folder
        raise DataError(path, f"not a readable GEFF folder: {str(error).splitlines()[0] if str(error) else type(error).__name__}") from None


def _axes(path, metadata) -> tuple[object, object, object]:
    """The time axis and the x and y axes of a GEFF's metadata."""
    axes = list(metadata.axes or [])
    by_name = {axis.name: axis for axis in axes}
    time = next((axis for axis in axes if axis.type == "time"), by_name.get("t"))
    space = [axis for axis in axes if axis.type == "space"]
    if "x" in by_name and "y" in by_name:
        x, y = by_name["x"], by_name["y"]
    elif len(space) >= 2:
        y, x = space[-2], space[-1]
    else:
        raise DataError(path, f"GEFF metadata names no x and y axes (axes: {', '.join(by_name) or 'none'})")
    if time is None:
        raise DataError(path, f"GEFF metadata names no time axis (axes: {', '.join(by_name)})")
    return time, x, y


def read(path) -> Rows:
    """Rows of a GEFF folder: one per node."""
    memory = _read_memory(path)
    metadata, props = memory["metadata"], memory["node_props"]
    time, x_axis, y_axis = _axes(path, metadata)
    for axis, wanted in ((time, FRAME), (x_axis, PIXEL), (y_axis, PIXEL)):
        if axis.unit not in (None, wanted):
            raise DataError(path, f"GEFF axis {axis.name} is in {axis.unit}; seedtrack reads {wanted}s (with scale and scaled_unit for physical units)")
    columns = {}
    for name in (time.name, x_axis.name, y_axis.name):
        if name not in props:
            raise DataError(path, f"GEFF nodes have no {name!r} property, which the axes name")
        missing = props[name]["missing"]
        if missing is not None and np.any(missing):
            raise DataError(path, f"line {int(np.flatnonzero(missing)[0]) + 1}: GEFF node without a {name!r} value")
        columns[name] = np.asarray(props[name]["values"], dtype=float)
    frame = columns[time.name]
    bad = np.flatnonzero(frame != np.round(frame))
    if bad.size:
        raise DataError(path, f"line {bad[0] + 1}: GEFF time {frame[bad[0]]:g} is not a whole frame")
    node_ids = np.asarray(memory["node_ids"])
    tracklet = (metadata.track_node_props or {}).get("tracklet")
    if tracklet is not None and tracklet in props:
        track_id = np.asarray(props[tracklet]["values"], dtype=np.int64)
    else:
        track_id = _runs(node_ids, np.asarray(memory["edge_ids"]).reshape(-1, 2), frame)
    interpolated = props.get("interpolated")
    return Rows(
        track_id,
        frame.astype(np.int64),
        columns[x_axis.name],
        columns[y_axis.name],
        np.arange(1, node_ids.size + 1),
        None if interpolated is None else np.asarray(interpolated["values"], dtype=np.int64),
    )


def _runs(node_ids: np.ndarray, edges: np.ndarray, frame: np.ndarray) -> np.ndarray:
    """Track of each node: the unbranched runs of the graph, numbered from 0 in order of their
    first node, then the nodes on no edge."""
    index = {int(node): i for i, node in enumerate(node_ids)}
    pairs = [sorted((index[int(a)], index[int(b)]), key=lambda i: frame[i]) for a, b in edges]
    track = np.full(node_ids.size, -1, dtype=np.int64)
    runs = sorted(unbranched_runs(pairs)) if pairs else []
    for number, run in enumerate(runs):
        track[run] = number
    alone = np.flatnonzero(track < 0)
    track[alone] = len(runs) + np.arange(alone.size)
    return track


def calibration(path) -> Calibration:
    """The units a GEFF's axes carry: pixel size and frame interval from their ``scale`` and
    ``scaled_unit``, pixels and frames when they give none."""
    metadata = _read_memory(path)["metadata"]
    time, x_axis, _ = _axes(path, metadata)
    units = Calibration()
    try:
        if x_axis.scale and x_axis.scaled_unit:
            units = units.overridden(pixel_size=float(x_axis.scale), space_unit=str(x_axis.scaled_unit))
        if time.scale and time.scaled_unit:
            units = units.overridden(frame_interval=float(time.scale), time_unit=str(time.scaled_unit))
    except ValueError as error:
        raise DataError(path, f"GEFF axis scale: {error}") from None
    return units


def write(path, rows: dict[str, np.ndarray], units: Calibration | None = None) -> None:
    """Write tracks as a GEFF folder, which must not exist yet; written beside it and renamed,
    so that a failure leaves nothing."""
    _geff(path)
    from geff.core_io import write_arrays
    from geff_spec import Axis, GeffMetadata

    target = Path(path)
    folder = target.parent if str(target.parent) else Path(".")
    if not folder.is_dir():
        raise DataError(target, f"folder {folder} does not exist")
    if target.exists():
        raise DataError(target, "exists; a GEFF is a folder and is not replaced: remove it or give another name")
    units = units or Calibration()
    order = np.lexsort((rows["frame"], rows["track_id"]))
    track, frame = rows["track_id"][order], rows["frame"][order]
    follows = np.flatnonzero(track[1:] == track[:-1])
    edges = np.column_stack((follows, follows + 1)).astype(np.uint64)

    def prop(values):
        return {"values": np.asarray(values), "missing": None}

    props = {"t": prop(frame.astype(np.int64)), "y": prop(rows["y"][order].astype(float)), "x": prop(rows["x"][order].astype(float)), "track_id": prop(track.astype(np.int64))}
    if "interpolated" in rows:
        props["interpolated"] = prop(np.asarray(rows["interpolated"])[order].astype(np.int8))

    def scaled(calibrated: bool, size: float, unit: str) -> dict:
        return {"scale": size, "scaled_unit": _OME_UNITS.get(unit, unit)} if calibrated else {}

    axes = [
        Axis(name="t", type="time", unit=FRAME, **scaled(units.time_unit != FRAME, units.frame_interval, units.time_unit)),
        *(Axis(name=name, type="space", unit=PIXEL, **scaled(units.space_unit != PIXEL, units.pixel_size, units.space_unit)) for name in ("y", "x")),
    ]
    metadata = GeffMetadata(directed=True, axes=axes, node_props_metadata={}, edge_props_metadata={}, track_node_props={"tracklet": "track_id"})
    temporary = Path(tempfile.mkdtemp(prefix=f".{target.name}.", dir=folder))
    try:
        # Into a folder the package creates (it takes an existing one for an existing GEFF).
        inside = temporary / target.name
        write_arrays(str(inside), np.arange(order.size, dtype=np.uint64), props, edges, None, metadata)
        os.rename(inside, target)
    except OSError as error:
        raise DataError(target, f"cannot write: {error.strerror or error}") from None
    finally:
        if temporary.exists():
            shutil.rmtree(temporary)
