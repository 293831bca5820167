"""Benchmark tables written into the docs pages by the scripts that measure them, never by hand.

A page marks each table's place with two comments, ``<!-- table: NAME -->`` and
``<!-- /table: NAME -->``; a benchmark script run with ``--write-docs`` calls :func:`write_table`,
which replaces what lies between them with the table and a line saying which command made it, at
which commit, on which machine and when. The text around the markers (what the table shows, why
the figures moved) stays the page's own.
"""

from __future__ import annotations

import datetime
import os
import platform
import re
import shlex
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
DOCS = ROOT / "docs"


def markdown_table(header: list[str], rows: list[list[object]]) -> str:
    """``header`` and ``rows`` as a markdown table; cells are written with ``str``.

    >>> print(markdown_table(["snr", "recall"], [[2, "0.854"], [4, "0.995"]]))
    | snr | recall |
    | --- | --- |
    | 2 | 0.854 |
    | 4 | 0.995 |
    """
    if any(len(row) != len(header) for row in rows):
        raise ValueError(f"every row needs {len(header)} cells, as the header has")
    lines = [header, ["---"] * len(header), *rows]
    return "\n".join("| " + " | ".join(str(cell).replace("|", "\\|") for cell in line) + " |" for line in lines)


def commit() -> str:
    """The checkout's short commit, with ``+changes`` when its tracked files other than the docs
    differ from it (tables written by an earlier script change the docs, not what is measured)."""
    def git(*args: str) -> str:
        return subprocess.run(["git", *args], cwd=ROOT, capture_output=True, text=True, check=True).stdout.strip()
    try:
        changed = git("status", "--porcelain", "--untracked-files=no", "--", ".", ":!docs", ":!*.md")
        return git("rev-parse", "--short", "HEAD") + ("+changes" if changed else "")
    except (OSError, subprocess.CalledProcessError):
        return "unknown commit"


def machine() -> str:
    """Cores, CPU model (from /proc/cpuinfo where there is one) and Python version of this machine."""
    model = platform.processor() or platform.machine()
    cpuinfo = Path("/proc/cpuinfo")
    if cpuinfo.exists():
        found = re.search(r"^model name\s*:\s*(.+)$", cpuinfo.read_text(errors="replace"), re.M)
        model = found[1].strip() if found else model
    load = f", load {os.getloadavg()[0]:.1f}" if hasattr(os, "getloadavg") else ""
    return f"{os.cpu_count()} cores, {model}, Python {platform.python_version()}{load}"


def provenance() -> str:
    """Where and when figures are measured: the commit, the machine, the date and time."""
    now = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    return f"commit {commit()} on {machine()}, {now}"


def stamp(command: str) -> str:
    """The line above a written table: the command that made it, the commit, the machine, the date."""
    return f"Written by `{command}` at {provenance()}."


def replace_block(text: str, name: str, body: str) -> str:
    """``text`` with what lies between the markers of table ``name`` replaced by ``body``,
    indented as the opening marker is (a table inside a list item stays in it).

    >>> page = "before\\n  <!-- table: speed -->\\n  old\\n  <!-- /table: speed -->\\nafter\\n"
    >>> print(replace_block(page, "speed", "new\\n\\n| a |"), end="")
    before
      <!-- table: speed -->
      new
    <BLANKLINE>
      | a |
      <!-- /table: speed -->
    after
    """
    begin, end = f"<!-- table: {name} -->", f"<!-- /table: {name} -->"
    if text.count(begin) != 1 or text.count(end) != 1 or text.index(begin) > text.index(end):
        raise ValueError(f"the page needs one {begin} and, after it, one {end}")
    head, rest = text.split(begin)
    indent = head[head.rfind("\n") + 1:]
    if indent.strip():
        raise ValueError(f"{begin} must start its line")
    tail = rest.split(end)[1]
    lines = "\n".join(indent + line if line else "" for line in body.strip().splitlines())
    return f"{head}{begin}\n{lines}\n{indent}{end}{tail}"


def write_table(page: str | Path, name: str, header: list[str], rows: list[list[object]], command: str | None = None, note: str = "") -> Path:
    """Replace table ``name`` of docs page ``page`` (a name under docs/ or a path) with ``rows``,
    stamped with ``command`` (default: this script's command line), the commit and the machine,
    and followed by ``note`` (a figure the script printed that is no row, such as a slope).
    The page is written to a temporary file and renamed, so it is whole whatever happens."""
    path = Path(page) if Path(page).is_absolute() or Path(page).exists() else DOCS / page
    command = command or "python " + shlex.join([os.path.relpath(sys.argv[0], ROOT), *sys.argv[1:]])
    body = f"{stamp(command)}\n\n{markdown_table(header, rows)}" + (f"\n\n{note}" if note else "")
    text = replace_block(path.read_text(encoding="utf-8"), name, body)
    temporary = path.with_name(path.name + ".tmp")
    temporary.write_text(text, encoding="utf-8")
    temporary.replace(path)
    print(f"wrote table {name} of {path}")
    return path
