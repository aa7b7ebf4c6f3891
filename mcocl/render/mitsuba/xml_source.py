"""Mitsuba XML files as trees of :class:`Node` with file and line, ``<default>``/``$name``/``<include>`` resolved.

Parsing uses the standard library's expat parser directly, so that every
element keeps the line it starts on.  Declarations that can expand text
without bound (``<!DOCTYPE ...>`` with ``<!ENTITY ...>``, the "billion laughs"
attack) are refused before they are read.

What Mitsuba 3 does with a file, and so do we (scenes/README.md, "Mitsuba XML"):

- ``<default name="spp" value="64"/>`` declares ``$spp`` unless the caller
  already set it (``params`` / ``-D spp=...``); ``$name`` is replaced in every
  later attribute value, longest names first; ``\\$`` is a literal dollar.
  An undefined ``$name`` is an error, and so is a caller's parameter the file
  never uses (unless ``lenient``).
- ``<include filename="..."/>`` inserts another file's elements (its
  ``<scene>`` root dropped), relative to the including file, confined to the
  main scene file's folder, without cycles.
- Files older than version 2.0 (Mitsuba 0.6) have their property names
  upgraded from camelCase to snake_case (``intIOR`` → ``int_ior``,
  ``maxDepth`` → ``max_depth``), as Mitsuba 3's upgrade pass does, and
  ``<lookAt>`` becomes ``<lookat>``.
"""

from __future__ import annotations

import re
import warnings
import xml.parsers.expat
from dataclasses import dataclass, field
from pathlib import Path
from typing import NoReturn

from ...datafile import read_regular_file
from ...errors import InputError, SceneSubstitutionWarning


@dataclass
class Node:
    """One XML element: tag, attributes (after substitution), children, and where it was written."""

    tag: str
    attrib: dict[str, str]
    file: Path
    line: int
    children: list[Node] = field(default_factory=list)
    version: tuple[int, int, int] = (3, 0, 0)

    def where(self) -> str:
        """``file:line`` of the element, the prefix of every message about it."""
        return f"{self.file}:{self.line}"

    def label(self) -> str:
        """The element as written, e.g. ``<bsdf type="plastic">``."""
        extra = "".join(f' {k}="{self.attrib[k]}"' for k in ("type", "name", "id") if k in self.attrib)
        return f"<{self.tag}{extra}>"

    def fail(self, msg: str) -> NoReturn:
        """Raise :class:`InputError` naming the file, line and element."""
        raise InputError(f"{self.where()}: {self.label()}: {msg}")


# The deepest element nesting accepted.  A Mitsuba scene nests a handful of
# levels (scene, shape, bsdf, nested bsdf, texture, property); 100,000 levels
# overflowed Python's recursion limit in the tree walkers (issue 10).
MAX_DEPTH = 200


class _RefusedDeclarationError(Exception):
    """Raised inside the expat callbacks to stop at a refused declaration."""


def parse_xml_file(path: Path) -> Node:
    """The element tree of one file (no substitution), refusing DOCTYPE and ENTITY declarations.

    Raises:
        InputError: unreadable file, malformed XML or a refused declaration (file and line).
    """
    try:
        data = read_regular_file(path)
    except OSError as e:
        raise InputError(f"{path}: cannot read scene file: {e.strerror or e}") from None
    parser = xml.parsers.expat.ParserCreate()
    parser.SetParamEntityParsing(xml.parsers.expat.XML_PARAM_ENTITY_PARSING_NEVER)
    stack: list[Node] = []
    roots: list[Node] = []

    def start(tag: str, attrs: dict[str, str]) -> None:
        if len(stack) >= MAX_DEPTH:  # the readers that walk the tree recurse once per level
            raise _RefusedDeclarationError(f"{path}:{parser.CurrentLineNumber}: elements are nested more than "
                                           f"{MAX_DEPTH} deep; no scene needs that many levels")
        node = Node(tag, dict(attrs), path, parser.CurrentLineNumber)
        (stack[-1].children if stack else roots).append(node)
        stack.append(node)

    def end(tag: str) -> None:
        stack.pop()

    def refuse(*_args) -> None:
        raise _RefusedDeclarationError(f"{path}:{parser.CurrentLineNumber}: DOCTYPE and ENTITY declarations are refused "
                       "(entities can expand without bound); remove the <!DOCTYPE ...> block")

    parser.StartElementHandler = start
    parser.EndElementHandler = end
    parser.StartDoctypeDeclHandler = refuse
    parser.EntityDeclHandler = refuse
    try:
        parser.Parse(data, True)
    except _RefusedDeclarationError as e:
        raise InputError(str(e)) from None
    except xml.parsers.expat.ExpatError as e:
        raise InputError(f"{path}:{e.lineno}:{e.offset + 1}: not well-formed XML: "
                         f"{xml.parsers.expat.ErrorString(e.code)}") from None
    return roots[0]


def camel_to_snake(name: str) -> str:
    """Mitsuba 3's upgrade of 0.6 property names: ``intIOR`` → ``int_ior``, ``maxDepth`` → ``max_depth``.

    An underscore goes before an upper-case letter that follows a lower-case
    one; that letter and the upper-case letters right after it become lower case.
    """
    return re.sub(r"(?<=[a-z])([A-Z]+)", lambda m: "_" + m.group(1).lower(), name)


def parse_version(node: Node) -> tuple[int, int, int]:
    """The root element's ``version="major.minor.patch"`` (missing parts are 0)."""
    text = node.attrib.get("version")
    if text is None:
        node.fail('missing the version attribute (write e.g. <scene version="3.0.0">)')
    parts = text.strip().split(".")
    if not 1 <= len(parts) <= 3 or not all(p.isdigit() for p in parts):
        node.fail(f"invalid version number {text!r} (expected e.g. 3.0.0 or 0.6.0)")
    nums = [int(p) for p in parts] + [0] * (3 - len(parts))
    return nums[0], nums[1], nums[2]


class SourceReader:
    """Reads the main file and its includes into one tree, applying ``<default>`` and ``$name`` substitution."""

    def __init__(self, path: Path, params: dict[str, str], lenient: bool = False) -> None:
        self.path = path
        self.folder = path.resolve().parent
        self.lenient = lenient
        self.user = dict(params)
        self.values = dict(params)
        self.used: set[str] = set()

    def read(self) -> Node:
        """The ``<scene>`` tree with includes spliced in and every attribute substituted."""
        root = self._load(self.path, ())
        if root.tag != "scene":
            root.fail("the root element must be <scene>")
        unused = sorted(set(self.user) - self.used)
        if unused:
            declared = sorted(set(self.values) - set(self.user)) or ["none"]
            msg = (f"{self.path}: parameter(s) {', '.join(unused)} are not used by the scene "
                   f"(its parameters: {', '.join(declared)})")
            if not self.lenient:
                raise InputError(msg)
            warnings.warn(msg, SceneSubstitutionWarning, stacklevel=4)
        return root

    def _load(self, path: Path, stack: tuple[Path, ...]) -> Node:
        raw = parse_xml_file(path)
        version = parse_version(raw)
        return self._expand(raw, version, stack + (path.resolve(),))

    def _expand(self, node: Node, version: tuple[int, int, int], stack: tuple[Path, ...]) -> Node:
        attrs = {k: self._substitute(v, node) for k, v in node.attrib.items()}
        tag = node.tag
        if version < (2, 0, 0):
            if "name" in attrs and tag != "default":
                attrs["name"] = camel_to_snake(attrs["name"])
            if tag == "lookAt":
                tag = "lookat"
        out = Node(tag, attrs, node.file, node.line, [], version)
        for child in node.children:
            if child.tag == "default":
                self._default(Node(child.tag, {k: self._substitute(v, child) for k, v in child.attrib.items()},
                                   child.file, child.line))
            elif child.tag == "include":
                inc = self._include(Node(child.tag, {k: self._substitute(v, child) for k, v in child.attrib.items()},
                                         child.file, child.line), stack)
                out.children.extend(inc.children if inc.tag == "scene" else [inc])
            else:
                out.children.append(self._expand(child, version, stack))
        return out

    def _default(self, node: Node) -> None:
        name, value = node.attrib.get("name"), node.attrib.get("value")
        if not name or value is None or set(node.attrib) - {"name", "value"}:
            node.fail('expected <default name="..." value="..."/>')
        self.values.setdefault(name, value)

    def _include(self, node: Node, stack: tuple[Path, ...]) -> Node:
        rel = node.attrib.get("filename")
        if not rel or set(node.attrib) - {"filename", "name"}:
            node.fail('expected <include filename="..."/>')
        target = (node.file.parent / rel).resolve()
        if not target.is_relative_to(self.folder):
            node.fail(f"the included file {rel!r} lies outside the scene's folder {self.folder}")
        if target in stack:
            chain = " -> ".join(p.name for p in (*stack, target))
            node.fail(f"include cycle: {chain}")
        if not target.is_file():
            node.fail(f"included file {rel!r} not found (looked for {target})")
        return self._load(target, stack)

    def _substitute(self, text: str, node: Node) -> str:
        if "$" not in text:
            return text
        for key in sorted(self.values, key=len, reverse=True):
            pattern = re.compile(r"(?<!\\)\$" + re.escape(key))
            text, n = pattern.subn(lambda _m, v=self.values[key]: v, text)
            if n:
                self.used.add(key)
        left = re.search(r"(?<!\\)\$([A-Za-z0-9_]*)", text)
        if left:
            node.fail(f"undefined parameter ${left.group(1)} (declare it with <default name=\"{left.group(1)}\" "
                      f"value=\"...\"/> or pass -D {left.group(1)}=... / params={{...}})")
        return text.replace("\\$", "$")


__all__ = ["Node", "SourceReader", "camel_to_snake", "parse_version", "parse_xml_file"]
