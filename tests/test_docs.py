"""The README and the docs pages: every relative link leads to a file, and every #anchor to a
heading of the page it names (GitHub's slugs), so that moving text between pages breaks no link;
the docs site builds with mkdocs --strict; the pages' Python examples and every module's
docstring examples run as doctests; benchmark tables are replaced between their markers."""

from __future__ import annotations

import doctest
import importlib
import importlib.util
import pkgutil
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
LINK = re.compile(r"\[[^\]]*\]\(([^)\s]+)\)")
FENCE = re.compile(r"^```.*?^```", re.S | re.M)
PYTHON = re.compile(r"^```python\n(.*?)^```", re.S | re.M)
DOCTEST_FLAGS = doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE


def _slug(heading: str) -> str:
    text = re.sub(r"[^\w\- ]", "", heading.strip().lower())
    return text.replace(" ", "-")


def _anchors(page: Path) -> set[str]:
    text = FENCE.sub("", page.read_text())
    return {_slug(line.lstrip("#")) for line in text.splitlines() if re.match(r"#{1,6} ", line)}


def _links(page: Path) -> list[str]:
    return [target for target in LINK.findall(FENCE.sub("", page.read_text())) if not target.startswith(("http://", "https://", "mailto:"))]


@pytest.mark.parametrize("page", PAGES, ids=lambda page: page.name)
def test_every_relative_link_resolves(page):
    broken = []
    for target in _links(page):
        path, _, anchor = target.partition("#")
        linked = (page.parent / path).resolve() if path else page
        if not linked.exists():
            broken.append(target)
        elif anchor and linked.suffix == ".md" and anchor not in _anchors(linked):
            broken.append(target)
    assert not broken, f"{page.name}: broken links {broken}"


def test_readme_is_a_short_entry():
    assert len((ROOT / "README.md").read_text().splitlines()) <= 150


def test_the_docs_site_builds_strictly(tmp_path):
    """mkdocs --strict fails on a page left out of the nav, a broken link or anchor."""
    site = tmp_path / "site"
    build = [sys.executable, "-m", "mkdocs", "build", "--strict", "--quiet", "--config-file", str(ROOT / "mkdocs.yml"), "--site-dir", str(site)]
    result = subprocess.run(build, cwd=tmp_path, capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr
    built = {path.parent.name for path in site.glob("*/index.html")}
    assert built == {page.stem for page in (ROOT / "docs").glob("*.md")} - {"index"}


@pytest.mark.parametrize("page", [page for page in PAGES[1:] if PYTHON.search(page.read_text())], ids=lambda page: page.name)
def test_python_examples_of_the_docs_run_as_doctests(page, tmp_path, monkeypatch):
    """Each page's ```python blocks, in order, in one namespace, run in an empty folder."""
    text = page.read_text()
    monkeypatch.chdir(tmp_path)
    runner, names, report = doctest.DocTestRunner(optionflags=DOCTEST_FLAGS), {}, []
    for block in PYTHON.finditer(text):
        line = text.count("\n", 0, block.start(1))
        test = doctest.DocTestParser().get_doctest(block[1], names, page.name, str(page), line)
        assert test.examples, f"{page.name}:{line + 1}: a python block with no >>> example is never checked"
        runner.run(test, out=report.append, clear_globs=False)
    assert runner.failures == 0, "".join(report)


def _modules() -> list[str]:
    packages = ["seedtrack", "seedtrack.detection", "seedtrack.tracking", "seedtrack.data", "seedtrack.data.formats", "seedtrack.annotate", "seedtrack.commands"]
    found = {info.name for package in packages for info in pkgutil.iter_modules(importlib.import_module(package).__path__, package + ".")}
    return sorted(found - {"seedtrack.__main__"} - set(packages))


def test_every_module_s_docstring_examples_run(tmp_path, monkeypatch):
    """The numpydoc Examples of every module of the installed package (a few seconds in all)."""
    monkeypatch.chdir(tmp_path)
    failed, attempted = [], 0
    for name in _modules():
        result = doctest.testmod(importlib.import_module(name), optionflags=DOCTEST_FLAGS, report=False)
        attempted += result.attempted
        failed += [name] * (result.failed > 0)
    assert not failed, f"doctest failures in {failed}"
    assert attempted > 100


def _tables():
    spec = importlib.util.spec_from_file_location("tables", ROOT / "tests" / "benchmarks" / "tables.py")
    tables = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(tables)
    return tables


def test_a_benchmark_table_replaces_only_its_own_block(tmp_path):
    tables = _tables()
    page = tmp_path / "page.md"
    page.write_text("# Speed\n\n<!-- table: a -->\nold a\n<!-- /table: a -->\n\ntext between\n\n<!-- table: b -->\nold b\n<!-- /table: b -->\nend\n")
    tables.write_table(page, "a", ["points", "CPU s"], [[100, 0.07], [1000, "a|b"]], command="python bench.py --write-docs")
    text = page.read_text()
    block = text.split("<!-- table: a -->\n")[1].split("<!-- /table: a -->")[0]
    assert block.startswith("Written by `python bench.py --write-docs` at commit ")
    assert re.search(r" on \d+ cores, .+, Python 3\.\d+.*, \d{4}-\d\d-\d\d \d\d:\d\d UTC\.\n\n", block)
    assert block.endswith("| points | CPU s |\n| --- | --- |\n| 100 | 0.07 |\n| 1000 | a\\|b |\n")
    assert "old a" not in text and text.startswith("# Speed\n\n<!-- table: a -->\n") and text.endswith("text between\n\n<!-- table: b -->\nold b\n<!-- /table: b -->\nend\n")
    tables.write_table(page, "a", ["points"], [[5]], command="again", note="Slope: 1.04.")
    assert text.split("<!-- /table: a -->")[1] == page.read_text().split("<!-- /table: a -->")[1]
    assert "| 5 |\n\nSlope: 1.04.\n<!-- /table: a -->" in page.read_text()
    assert page.read_text().count("<!-- table: a -->") == 1 and "| 100 |" not in page.read_text()
    with pytest.raises(ValueError, match="table: c"):
        tables.write_table(page, "c", ["x"], [[1]], command="x")
    with pytest.raises(ValueError, match="2 cells"):
        tables.markdown_table(["x", "y"], [[1]])


def test_every_table_marker_in_the_docs_is_paired_and_named_by_a_script():
    """Each marked table has its closing marker and a benchmark script that writes it."""
    scripts = "".join(path.read_text() for path in (ROOT / "tests" / "benchmarks").glob("bench_*.py"))
    for page in PAGES[1:]:
        text = page.read_text()
        for name in re.findall(r"^ *<!-- table: ([\w-]+) -->$", text, re.M):
            assert text.count(f"<!-- /table: {name} -->") == 1, f"{page.name}: table {name} is not closed"
            assert f'"{name}"' in scripts, f"{page.name}: no benchmark script writes table {name}"
