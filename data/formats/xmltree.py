"""A small XML element tree that remembers the line of every element, for error messages.

``xml.etree`` drops line numbers; its parser, expat, reports them, so the XML formats read
through this and write with ``xml.etree``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
import xml.etree.ElementTree as ET
from xml.parsers import expat

from ..atomic import atomic_path
from ..errors import DataError, check_file


@dataclass
class Element:
    """An XML element: tag, attributes, 1-based line of its start tag, children in order."""

    tag: str
    attrib: dict[str, str]
    line: int
    children: list["Element"] = field(default_factory=list)

    def iter(self, tag: str):
        """Every descendant (and self) with this tag, in document order."""
        if self.tag == tag:
            yield self
        for child in self.children:
            yield from child.iter(tag)

    def find(self, tag: str) -> "Element | None":
        """The first child with this tag, or None."""
        return next((child for child in self.children if child.tag == tag), None)


def parse_xml(path) -> Element:
    """Parse an XML file into :class:`Element` nodes.

    Raises
    ------
    DataError
        If the file is missing or is not well-formed XML (naming the line and column).
    """
    path = Path(path)
    check_file(path)
    parser = expat.ParserCreate()
    stack: list[Element] = []
    roots: list[Element] = []

    def start(tag, attrib):
        element = Element(tag, attrib, parser.CurrentLineNumber)
        (stack[-1].children if stack else roots).append(element)
        stack.append(element)

    def end(tag):
        stack.pop()

    parser.StartElementHandler = start
    parser.EndElementHandler = end
    try:
        with open(path, "rb") as handle:
            parser.ParseFile(handle)
    except expat.ExpatError as error:
        raise DataError(path, f"line {error.lineno}, column {error.offset + 1}: malformed XML ({expat.ErrorString(error.code)})") from None
    return roots[0]


def root_tag(path) -> tuple[str, int]:
    """The root element's tag and line, reading only as far as its start tag.

    Raises
    ------
    DataError
        If the file is missing, or is malformed or ends before the root element.
    """
    path = Path(path)
    check_file(path)
    parser = expat.ParserCreate()
    found: list[tuple[str, int]] = []
    parser.StartElementHandler = lambda tag, attrib: found.append((tag, parser.CurrentLineNumber)) if not found else None
    try:
        with open(path, "rb") as handle:
            while not found:
                chunk = handle.read(1 << 16)
                parser.Parse(chunk, not chunk)
                if not chunk:
                    break
    except expat.ExpatError as error:
        raise DataError(path, f"line {error.lineno}, column {error.offset + 1}: malformed XML ({expat.ErrorString(error.code)})") from None
    return found[0]


def number(path, element: Element, name: str, whole: bool = False) -> float:
    """Attribute ``name`` of ``element`` as a number.

    Raises
    ------
    DataError
        Naming the element's line if the attribute is missing or not a (whole) number.
    """
    text = element.attrib.get(name)
    if text is None:
        raise DataError(path, f"line {element.line}: <{element.tag}> has no {name} attribute")
    try:
        value = float(text)
    except ValueError:
        raise DataError(path, f"line {element.line}: {name}={text!r} is not a number") from None
    if not math.isfinite(value):
        raise DataError(path, f"line {element.line}: {name}={text!r} is not a finite number")
    if whole and value != round(value):
        raise DataError(path, f"line {element.line}: {name}={text!r} is not a whole number")
    return value


def write_xml(path, root) -> None:
    """Write an ``xml.etree`` element as an indented UTF-8 file, atomically."""
    ET.indent(root)
    with atomic_path(path) as temporary:
        ET.ElementTree(root).write(temporary, encoding="UTF-8", xml_declaration=True)
