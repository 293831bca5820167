"""Track file formats: one module per format, each turning a file into flat rows and back.

Every reader returns :class:`Rows` (``track_id``, 0-based ``frame``, ``x``, ``y`` in pixels, and
the source line of each row so that errors can point at it); every writer takes the columns of
:meth:`seedtrack.tracking.tracks.Tracks.to_rows`. :mod:`seedtrack.data.trackfile` picks the module and builds the
track set.
"""
