"""Track file formats: one module per format, each turning a file into flat rows and back.

Every reader returns :class:`Rows` (``track_id``, 0-based ``frame``, ``x``, ``y`` in pixels, and
the source line of each row so that errors can point at it); every writer takes the columns of
:meth:`seedtrack.tracking.tracks.Tracks.to_rows`. :mod:`seedtrack.data.trackfile` picks the module and builds the
track set.
"""

# The one table of file names: extension -> the track formats a file of that name may hold, the
# first being the one written. Readers tell the others apart by content (a CSV's header, an XML
# root element); every reader and writer of tracks and of tables of points goes through it, so
# `.txt` is MOTChallenge text whichever command wrote or reads it.
EXTENSIONS = {
    ".csv": ("csv", "trackpy"),
    ".txt": ("mot",),
    ".xml": ("trackmate", "isbi"),
    ".geff": ("geff",),
    ".npy": ("napari",),
}
# Formats that are CSV tables with a header row; a table of points may be named after these only.
CSV_FORMATS = ("csv", "trackpy")


def described() -> str:
    """The table in words, for error messages."""
    return ", ".join(f"{suffix} ({' or '.join(names)})" for suffix, names in EXTENSIONS.items())
