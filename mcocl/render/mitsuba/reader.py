"""A Mitsuba XML scene → mcocl's JSON scene dictionary (one scene model, two readers).

:func:`read_mitsuba` returns the same kind of dictionary a JSON scene file
holds; :func:`mcocl.render.scene.parse_scene` then validates and
:func:`mcocl.render.compiled.compile_scene` compiles it like any other.
Every object carries ``"comment"`` strings saying which Mitsuba default was
taken and what was substituted (``mcocl convert`` writes them out).
"""

from __future__ import annotations

import copy
import os
from pathlib import Path
from typing import Any

from ...errors import InputError
from ..scene import parse_scene
from .bsdf import translate_bsdf
from .delta_emitter import DELTA_EMITTERS, translate_delta_light
from .file_search import FileSearch
from .instance import GROUP, INSTANCE, expand_instance, group_members
from .properties import split_children
from .report import Reporter, nearest
from .sensor import translate_integrator, translate_sensor
from .shape import ShapeTranslator, translate_radiance
from .xml_source import Node, SourceReader

TOP_LEVEL = ("integrator", "sensor", "bsdf", "shape", "emitter")
DEFAULT_DIFFUSE = ("default-diffuse", {"type": "diffuse", "reflectance": 0.5,
                                       "comment": "Mitsuba's BSDF for a shape without one: diffuse 0.5"})
DEFAULT_BLACK = ("default-black", {"type": "diffuse", "reflectance": 0.0,
                                   "comment": "Mitsuba's BSDF for an emitter without one: black diffuse"})


def _index_ids(root: Node) -> dict[str, Node]:
    ids: dict[str, Node] = {}

    def walk(n: Node) -> None:
        if n.tag != "ref" and "id" in n.attrib:
            key = n.attrib["id"]
            if key in ids:
                n.fail(f"duplicate id {key!r} (first at {ids[key].where()})")
            ids[key] = n
        for c in n.children:
            walk(c)

    walk(root)
    return ids


def _descendants(root: Node):
    """Every element below ``root``, depth first."""
    for c in root.children:
        yield c
        yield from _descendants(c)


def _parent_tag(root: Node, node: Node) -> str:
    """The tag of ``node``'s parent element below ``root``."""
    return next(n.tag for n in (root, *_descendants(root)) if any(c is node for c in n.children))


def _referenced_ids(root: Node) -> set[str]:
    """The ids that some ``<ref id>`` names."""
    return {n.attrib["id"] for n in _descendants(root) if n.tag == "ref" and "id" in n.attrib}


class _SceneBuilder:
    def __init__(self, path: Path, root: Node, rep: Reporter, files: FileSearch) -> None:
        self.path = path
        self.files = files
        self.rep = rep
        self.ids = _index_ids(root)
        self.referenced = _referenced_ids(root)
        self.materials: dict[str, Any] = {}
        self.material_names: dict[int, str] = {}  # id(bsdf Node) -> material name
        self.defaults: dict[str, str] = {}  # "black" / "diffuse" -> name of Mitsuba's default material
        self.elements: dict[str, Node] = {}  # JSON key path -> the element it came from (for error messages)
        self.shapes = ShapeTranslator(files, rep, self.material_of, self.resolve)

    def resolve(self, ref: Node) -> Node:
        if set(ref.attrib) - {"id", "name"} or "id" not in ref.attrib:
            ref.fail('expected <ref id="..."/>')
        target = self.ids.get(ref.attrib["id"])
        if target is None:
            known = ", ".join(sorted(self.ids)) or "none"
            ref.fail(f"unresolved reference to {ref.attrib['id']!r} (ids defined: {known})")
        return target

    def _unique(self, base: str) -> str:
        name, k = base, 2
        while name in self.materials:
            name, k = f"{base}-{k}", k + 1
        return name

    def material_of(self, bsdf: Node | None, emits: bool, comments: list[str]) -> str:
        """The material name of ``bsdf`` (translated once per element), or of Mitsuba's default."""
        if bsdf is None:
            which = "black" if emits else "diffuse"
            if which not in self.defaults:
                base, mat = DEFAULT_BLACK if emits else DEFAULT_DIFFUSE
                self.defaults[which] = self._unique(base)
                self.materials[self.defaults[which]] = copy.deepcopy(mat)
            name = self.defaults[which]
            comments.append(f"no BSDF: Mitsuba's default, material {name!r}")
            return name
        key = id(bsdf)
        if key not in self.material_names:
            base = bsdf.attrib.get("id") or f"{bsdf.attrib.get('type', 'bsdf')}-line{bsdf.line}"
            name = self._unique(base)
            self.material_names[key] = name
            self.materials[name] = translate_bsdf(bsdf, self.rep, self.resolve, self.files)
            self.elements[f"materials.{name}"] = bsdf
        return self.material_names[key]

    def build(self, root: Node) -> dict:
        comments = [f"converted from the Mitsuba XML scene {self.path.name} (version "
                    f"{'.'.join(map(str, root.version))}) by mcocl; see scenes/README.md, 'Mitsuba XML'"]
        out: dict[str, Any] = {"comment": comments}
        sensors, integrators, shapes, envs = [], [], [], []
        for ch in root.children:
            if ch.tag == "path":
                # Mitsuba resolves file names when it builds the plugins, after the whole file is read:
                # every <path> applies to every file name, wherever it is written (file_search.py)
                self.files.add_path(ch)
                comments.append(f"line {ch.line}: <path> {ch.attrib['value']!r}: searched for file names first")
        for ch in root.children:
            if ch.tag == "path":
                continue
            if ch.tag == "sensor":
                sensors.append(ch)
            elif ch.tag == "integrator":
                integrators.append(ch)
            elif ch.tag == "bsdf":
                self.material_of(ch, False, [])
            elif ch.tag == "shape":
                shapes.append(ch)
            elif ch.tag == "emitter" and ch.attrib.get("type") == "area" and ch.attrib.get("id") in self.referenced:
                continue  # declared for a <ref> inside a shape (Mitsuba's cbox.xml does this); read there
            elif ch.tag == "emitter":
                envs.append(ch)
            elif ch.tag in ("texture", "sampler", "film", "rfilter") and "id" in ch.attrib:
                continue  # read where a <ref> names it (a BSDF or emitter: texture.py; a sensor or film: sensor.py)
            elif ch.tag in ("texture", "medium", "phase", "volume", "film", "sampler", "rfilter", "alias"):
                self.rep.unsupported(ch, f"<{ch.tag}> elements", "constant colours" if ch.tag == "texture"
                                     else "leave it out", "nothing (ignored)", comments)
            else:
                ch.fail(f"unknown or misplaced element (expected one of: {', '.join(TOP_LEVEL)}; "
                        f"nearest: {nearest(ch.tag, TOP_LEVEL)})")
        if not sensors:
            # Mitsuba also lets a shape carry a sensor (irradiancemeter, ...): name it rather than say there is none
            nested = next((n for n in _descendants(root) if n.tag == "sensor"), None)
            where = (f" (the {nested.label()} at {nested.where()} lies inside a <{_parent_tag(root, nested)}>: "
                     "mcocl renders through a top-level perspective or thinlens sensor only)" if nested else "")
            root.fail(f'the scene has no top-level <sensor>{where}; mcocl needs a camera '
                      '(add <sensor type="perspective">)')
        if len(sensors) > 1:
            comments.append(f"{len(sensors)} sensors: the first (line {sensors[0].line}) is used, as Mitsuba does")
        camera, spp, sampler = translate_sensor(sensors[0], self.rep, self.resolve)
        out["camera"] = camera
        self.elements["camera"] = sensors[0]
        if len(integrators) > 1:
            integrators[1].fail("a scene has at most one <integrator>")
        if integrators:
            integ = translate_integrator(integrators[0], self.rep)
        else:
            integ = {"type": "mis", "max_depth": -1, "rr_depth": 5,
                     "comment": ["no <integrator>: Mitsuba's default path tracer -> mis, max_depth -1, rr_depth 5"]}
        integ["spp"] = spp
        if sampler == "sobol":
            if integ["type"] == "lt":  # the stratified sampler is the path integrators' and bdpt's (mcocl/render/api.py)
                integ["comment"] = [*integ.get("comment", []), "lt draws independent samples, not the sampler's strata"]
            else:
                integ["sampler"] = "sobol"
        elif sampler == "independent":  # the file asks for it; without a <sampler> the default (auto) stays
            integ["sampler"] = "independent"
        out["integrator"] = integ
        out["materials"] = self.materials
        shape_list = []
        for n in shapes:
            kind = n.attrib.get("type", "")
            if kind == GROUP:  # its shapes render only through instances (mcocl/render/mitsuba/instance.py)
                group_members(n, self.resolve)
                continue
            added = (expand_instance(n, self.resolve, self.shapes.translate, self.rep) if kind == INSTANCE
                     else [self.shapes.translate(n)])
            for s in added:
                if s is not None:
                    self.elements[f"shapes[{len(shape_list)}]"] = n
                    shape_list.append(s)
        out["shapes"] = shape_list
        for e in envs:
            if e.attrib.get("type", "") in DELTA_EMITTERS:
                self.elements[f"lights[{len(out.setdefault('lights', []))}]"] = e
                out["lights"].append(translate_delta_light(e, self.rep))
                continue
            env = self._environment(e, comments)
            if env is not None:
                if "environment" in out:
                    e.fail("a scene has at most one environment emitter")
                out["environment"] = env
        return out

    def _environment(self, node: Node, comments: list[str]) -> dict | None:
        kind = node.attrib.get("type", "")
        if kind == "constant":
            ecomments: list[str] = []
            env = {"type": "constant", "radiance": translate_radiance(node, self.rep, ecomments)}
            if ecomments:
                env["comment"] = ecomments
            return env
        if kind == "envmap":
            return self._envmap(node)
        if kind == "area":
            node.fail("an area emitter belongs inside a <shape>")
        alt: dict[str, str] = {}
        self.rep.unsupported(node, f"the emitter {kind!r}",
                             alt.get(kind, "constant, point, spot, directional, or area inside a shape"),
                             "nothing (the emitter is left out)", comments)
        return None


    def _envmap(self, node: Node) -> dict:
        """An ``envmap`` emitter: ``filename`` (EXR or HDR, relative to its file, inside the scene's folder),
        ``scale`` (default 1), ``to_world`` (a rotation)."""
        props, objects = split_children(node)
        comments: list[str] = []
        for o in objects:
            self.rep.unsupported(o, f"<{o.tag}> inside an envmap", "filename", None)
        if "filename" not in props:
            node.fail('an envmap needs <string name="filename" value="..."/>')
        env: dict[str, Any] = {"type": "envmap", "filename": self.files.find(props.get("filename", ("string",)),
                                                                            props.node("filename"), "image file")}
        scale = props.get("scale", ("float",), None)
        if scale is not None:
            env["scale"] = scale
        t = props.get("to_world", ("transform",), None)
        if t is not None:
            env["transform"] = t.ops
        self.rep.leftover(node, props.unread(), ("filename", "scale", "to_world"), comments)
        if comments:
            env["comment"] = comments
        return env


def read_mitsuba(path: str | os.PathLike[str], params: dict[str, Any] | None = None,
                 lenient: bool = False, mesh_folder: str | os.PathLike[str] | None = None) -> dict:
    """Read a Mitsuba 3 (or 0.6) XML scene into mcocl's JSON scene dictionary.

    Args:
        path: the ``.xml`` file.
        params: values for ``$name`` parameters, overriding the file's
            ``<default>`` elements (``-D name=value`` on the command line).
        lenient: replace what mcocl does not support by the documented
            substitute with a :class:`~mcocl.errors.SceneSubstitutionWarning`
            instead of raising.
        mesh_folder: one more folder (besides the scene file's folder and
            those below it) that meshes and images may come from, e.g. a
            ``<path>`` folder outside the scene's folder.

    Raises:
        InputError: malformed or unsafe XML, a missing file, an include
            outside the scene's folder, or (unless ``lenient``) anything
            unsupported; the message names the file, line and element.
    """
    return _translate(Path(path), params, lenient, mesh_folder)[0]


def _translate(p: Path, params: dict[str, Any] | None, lenient: bool,
               mesh_folder: str | os.PathLike[str] | None) -> tuple[dict, dict[str, Node]]:
    values = {str(k): _param_text(v) for k, v in (params or {}).items()}
    root = SourceReader(p, values, lenient).read()
    builder = _SceneBuilder(p, root, Reporter(lenient), FileSearch(p, mesh_folder))
    return _drop_empty_comments(builder.build(root)), builder.elements


def load_mitsuba(path: str | os.PathLike[str], params: dict[str, Any] | None = None, lenient: bool = False,
                 mesh_folder: str | os.PathLike[str] | None = None):
    """Read, translate and validate a Mitsuba XML scene into a :class:`mcocl.render.scene.Scene`.

    A validation error of the translated scene (e.g. an alpha out of range)
    is reported at the XML element the offending JSON key came from.
    ``mesh_folder``: as :func:`read_mitsuba`.
    """
    p = Path(path)
    data, elements = _translate(p, params, lenient, mesh_folder)
    try:
        return parse_scene(data, p, mesh_folder)
    except InputError as e:
        msg = str(e)
        head = f"{p}: "
        key = msg[len(head):].split(":", 1)[0] if msg.startswith(head) else ""
        owners = [k for k in elements if key == k or key.startswith(k + ".") or key.startswith(k + "[")]
        if not owners:
            raise
        node = elements[max(owners, key=len)]
        raise InputError(f"{node.where()}: {node.label()}: {msg[len(head):]}") from None


def _drop_empty_comments(obj: Any) -> Any:
    """``obj`` without empty ``"comment"`` lists (in place), so that converted files stay readable."""
    if isinstance(obj, dict):
        if obj.get("comment") == []:
            del obj["comment"]
        for v in obj.values():
            _drop_empty_comments(v)
    elif isinstance(obj, list):
        for v in obj:
            _drop_empty_comments(v)
    return obj


def _param_text(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (list, tuple)):
        return " ".join(str(x) for x in v)
    return str(v)


__all__ = ["load_mitsuba", "read_mitsuba"]
