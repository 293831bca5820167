"""``python -m seedtrack`` runs the ``seedtrack`` command."""

from .cli import main

raise SystemExit(main())
