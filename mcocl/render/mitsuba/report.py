"""Strict or lenient handling of what mcocl cannot render, and the comments that explain each choice.

Strict (the default): an unsupported plugin, property or value raises
:class:`~mcocl.errors.InputError` naming the file, line, element and the
nearest supported alternative.  Lenient: the same message becomes a
:class:`~mcocl.errors.SceneSubstitutionWarning` and the documented substitute
is used; the substitute is also recorded as a ``"comment"`` of the JSON object
it affects (``mcocl convert`` writes them out).
"""

from __future__ import annotations

import difflib
import warnings

from ...errors import InputError, SceneSubstitutionWarning
from .xml_source import Node


def nearest(name: str, choices: list[str] | tuple[str, ...]) -> str:
    """The closest of ``choices`` to ``name`` (difflib), or all of them when none is close."""
    close = difflib.get_close_matches(name, list(choices), n=1, cutoff=0.5)
    return close[0] if close else " / ".join(choices)


class Reporter:
    """Raises or warns about unsupported input; collects comments for the converted scene."""

    def __init__(self, lenient: bool) -> None:
        self.lenient = lenient
        self.substitutions: list[str] = []

    def unsupported(self, node: Node, what: str, alternative: str, substitute: str | None,
                    comments: list[str] | None = None) -> None:
        """Report ``what`` (at ``node``) as unsupported.

        Strict, or lenient without a ``substitute``: raise :class:`InputError`.
        Lenient: warn, and append ``"line N: ... -> substitute"`` to ``comments``.
        """
        msg = f"{node.where()}: {node.label()}: {what} is not supported (nearest supported: {alternative})"
        if not self.lenient or substitute is None:
            hint = f"; lenient=True / --lenient substitutes {substitute}" if substitute else ""
            raise InputError(msg + hint)
        warnings.warn(f"{msg}; using {substitute}", SceneSubstitutionWarning, stacklevel=2)
        note = f"line {node.line}: {what} is not supported; substituted {substitute}"
        self.substitutions.append(f"{node.where()}: {what} -> {substitute}")
        if comments is not None:
            comments.append(note)

    def leftover(self, owner: Node, nodes: list[Node], supported: tuple[str, ...], comments: list[str]) -> None:
        """Report each property in ``nodes`` (not read by a translator) as unsupported; lenient ignores it."""
        plugin = owner.attrib.get("type", owner.tag)
        for n in nodes:
            name = n.attrib.get("name", "")
            alt = nearest(name, supported) if supported else "leave it out"
            self.unsupported(n, f"property {name!r} of {plugin!r}", f"{alt} (supported: {', '.join(supported) or 'none'})"
                             if supported else alt, "nothing (the property is ignored)", comments)


__all__ = ["Reporter", "nearest"]
