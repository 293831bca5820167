"""Where the real footage is: trackpy's bulk-water beads (BSD licence) in shared/data beside the
checkout (or beside the folder of worktrees), or where SEEDTRACK_BEADS says."""

import os
from pathlib import Path

import pytest

_SHARED = next((folder / "shared" / "data" for folder in Path(__file__).resolve().parents if (folder / "shared" / "data").is_dir()), Path("."))
BEADS = Path(os.environ.get("SEEDTRACK_BEADS", _SHARED / "bulk-water-240-479.mp4"))
needs_beads = pytest.mark.skipif(not BEADS.exists(), reason=f"the real bead footage is not at {BEADS} (set SEEDTRACK_BEADS)")
