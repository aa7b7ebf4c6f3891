"""Where the files a Mitsuba XML scene names (meshes, images) are looked for, and where they may lie.

Mitsuba 3 resolves a relative ``filename`` when it builds the plugin, through its file
resolver: the folders of the scene's ``<path value="..."/>`` elements (the one written last
first; each relative to the file it is written in), then the main scene file's folder.  An
included file's meshes are therefore found from the *main* file's folder (Mitsuba's own
``cbox.xml`` includes ``fragments/shapes.xml``, whose ``meshes/...`` lie beside ``cbox.xml``).
mcocl searches the same folders in the same order, then, as it did before ``<path>`` was
read, the folder of the file the ``filename`` is written in.  The first folder holding the file
wins, as in Mitsuba.

A scene file is data, so what it reads is confined (scenes/README.md): a file found must lie
inside the main file's folder or inside the one extra folder the user allows
(``--mesh-folder`` / ``mesh_folder=``); a ``<path>`` outside them is accepted but the files
found through it are refused with a message naming that option.
"""

from __future__ import annotations

import os
from pathlib import Path

from .xml_source import Node


class FileSearch:
    """The search folders of one scene (:meth:`add_path` for each ``<path>``) and its allowed roots."""

    def __init__(self, scene_file: Path, extra_root: str | os.PathLike[str] | None = None) -> None:
        self.folder = scene_file.resolve().parent
        self.roots = [self.folder] + ([Path(extra_root).resolve()] if extra_root is not None else [])
        self.paths: list[Path] = []  # the <path> folders, the one written last first (Mitsuba prepends)

    def add_path(self, node: Node) -> None:
        """Read a top-level ``<path value="..."/>``: relative to its file, else to a folder searched so far."""
        if set(node.attrib) != {"value"} or node.children:
            node.fail('expected <path value="FOLDER"/>')
        value = node.attrib["value"]
        # relative to the file it is written in first, then through the folders searched so far (as Mitsuba)
        candidates = list(dict.fromkeys([(node.file.parent / value).resolve()]
                                        + [(b / value).resolve() for b in (*self.paths, self.folder)]))
        folder = next((c for c in candidates if c.is_dir()), None)
        if folder is None:
            node.fail(f"folder {value!r} not found (looked for {', '.join(map(str, candidates))})")
        self.paths.insert(0, folder)

    def find(self, rel: str, at: Node, what: str) -> str:
        """``rel`` (a ``filename`` property, ``at``) as a path relative to the main file's folder.

        Raises:
            InputError: (at ``at``) the file is in none of the search folders, or lies outside
                the allowed roots.
        """
        written_in = at.file.parent.resolve()
        bases = [*self.paths, self.folder] + ([written_in] if written_in not in (*self.paths, self.folder) else [])
        candidates = [Path(rel).resolve()] if Path(rel).is_absolute() else [(b / rel).resolve() for b in bases]
        found = next((c for c in candidates if c.is_file()), None)
        if found is None and not any(self.allowed(c) for c in candidates):
            found = candidates[0]  # nowhere it may lie: say so rather than that it is missing
        if found is None:
            looked = ", ".join(str(c) for c in candidates)
            at.fail(f"{what} {rel!r} not found (looked for {looked})")
        if not self.allowed(found):
            inside = " or ".join(str(r) for r in self.roots)
            at.fail(f"the {what} {rel!r} ({found}) lies outside the scene's folder"
                    f"{'s' if len(self.roots) > 1 else ''} {inside}; a scene reads files only from its own folder "
                    f"and below, and from one more folder the user allows (--mesh-folder DIR / mesh_folder=DIR)")
        return Path(os.path.relpath(found, self.folder)).as_posix()

    def allowed(self, path: Path) -> bool:
        """Whether ``path`` (resolved) lies inside the main file's folder or the extra allowed folder."""
        return any(path.is_relative_to(r) for r in self.roots)


__all__ = ["FileSearch"]
