"""Host↔kernel contracts, written once: the records and codes that NumPy and OpenCL share.

Every record that the host fills and a kernel reads (or the reverse) is
declared here as a list of (field, C type) pairs, and every code the two
sides must agree on as an :class:`enum.IntEnum`.  From them come

- the NumPy structured dtype of each record (:func:`Record.dtype`), laid
  out by the C rules (each field at a multiple of its alignment, the size a
  multiple of the largest alignment), so that ``array.view(record.dtype)``
  reads what a kernel wrote and a by-value kernel argument has the bytes
  the kernel expects;
- the C side, ``kernels/layouts.cl`` (:func:`c_header`): the same records as
  ``typedef struct``, the codes as ``#define``, and for records stored as
  arrays of ``float4`` (the renderer gathers them one ``float4`` at a time
  across lanes) the position of every field: ``<RECORD>_QUADS`` float4 per
  record, field ``f`` in float4 ``<RECORD>_<F>_QUAD`` at component
  ``<RECORD>_<F>_COMP``, and ``<RECORD>_GATHER`` to load every lane's record.

The header is generated and committed rather than produced at compose time,
so that a reader of a kernel finds the definitions beside the code and a
kernel file compiles with a plain ``#include``; ``tests/test_layouts.py``
regenerates it and fails if the committed bytes differ, and checks on the
OpenCL device that ``sizeof``/``offsetof`` of every struct equal the dtype's.
Regenerate with ``python -m mcocl.layouts``, which also writes the other
generated files: the BSDF dispatcher ``kernels/render/bsdf.cl`` and the
materials and shapes tables of ``scenes/README.md`` (from mcocl/bsdf_registry.py
and mcocl/render/shape_registry.py).
"""

from __future__ import annotations

import enum
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .bsdf_registry import BSDFS, DISPATCHER_PATH, FLAG_BITS, dispatcher_source, markdown_table

HEADER_PATH = "layouts.cl"  # relative to the kernels folder

# C scalar types: (NumPy dtype, size = alignment in bytes).  float4 is the
# OpenCL vector type (16-byte aligned, OpenCL C 1.2 §6.1.5).
_C_TYPES: dict[str, tuple[str, int]] = {
    "float": ("<f4", 4), "uint": ("<u4", 4), "int": ("<i4", 4),
    "ulong": ("<u8", 8), "double": ("<f8", 8), "float4": ("<f4", 16),
}


# ``materials[k].kind``: one code per BSDF registered in mcocl/bsdf_registry.py, in code order.
MaterialKind = enum.IntEnum(
    "MaterialKind", [(s.name.upper(), s.code) for s in sorted(BSDFS.values(), key=lambda s: s.code)],
    module=__name__)
MaterialKind.__doc__ = "``materials[k].kind``: the BSDF of a material (kernels/render/bsdf.cl)."


class Integrator(enum.IntEnum):
    """The render kernel's ``-DINTEGRATOR`` variant (kernels/render/integrator.cl; LT: kernels/render/lt.cl;
    BDPT: kernels/render/bdpt.cl)."""

    PATH = 0
    NEE = 1
    MIS = 2
    LT = 3
    BDPT = 4


class LightShape(enum.IntEnum):
    """``light_record.shape``: how light sampling places a point on the emitter (kernels/render/lights.cl)."""

    TRIANGLE = 0
    SPHERE = 1
    SPHERE_INWARD = 2  # a sphere whose normals point inwards: area sampling only
    # Delta lights (mcocl/render/delta_lights.py; kernels/render/delta_lights.cl): no primitive, never hit.
    POINT = 3  # base: position; radiance: intensity (W/sr per RGB channel)
    SPOT = 4  # as POINT, edge1: unit axis; edge2: cos cutoff, cos beam, cutoff (rad); area: 1 / transition width
    DIRECTIONAL = 5  # base: unit direction of travel; radiance: irradiance


class LightSampler(enum.IntEnum):
    """The render kernel's ``-DLIGHT_SAMPLER``: how an area light is chosen (kernels/render/lights.cl).

    POWER and UNIFORM share one kernel (a CDF over the lights, built on the
    host, mcocl/render/emitter_choice.py); BVH traverses the light BVH from
    the shading point (kernels/render/light_bvh.cl, mcocl/render/light_bvh.py).
    """

    POWER = 0
    UNIFORM = 1
    BVH = 2


class FilmStat(enum.IntEnum):
    """Column of the film's per-pixel statistics (mcocl/render/film.py, kernels/render/integrator.cl)."""

    SUM_R = 0
    SUM_G = 1
    SUM_B = 2
    SUMSQ_R = 3
    SUMSQ_G = 4
    SUMSQ_B = 5
    SAMPLES = 6
    NONFINITE = 7


# The C name prefix of each enum's codes.
ENUM_PREFIXES: dict[type[enum.IntEnum], str] = {
    MaterialKind: "MAT_", Integrator: "INTEGRATOR_", LightShape: "LIGHT_", LightSampler: "LIGHT_SAMPLER_",
    FilmStat: "FILM_",
}


@dataclass(frozen=True)
class Record:
    """One struct shared by host and kernels.

    Attributes:
        name: the C typedef name.
        fields: ``(name, C type, count)``; count > 1 is a C array (``float normal[3]``).
        doc: one line for the C comment.
        quads: the record is stored as an array of ``float4`` and gathered
            one float4 at a time: every field is 4 bytes wide and no field
            straddles two float4.
    """

    name: str
    fields: tuple[tuple[str, str, int], ...]
    doc: str
    quads: bool = False

    def offsets(self) -> list[int]:
        """Byte offset of each field by the C layout rules."""
        out, off = [], 0
        for _, ctype, count in self.fields:
            align = _C_TYPES[ctype][1]
            off = -(-off // align) * align
            out.append(off)
            off += _C_TYPES[ctype][1] * count
        return out

    @property
    def itemsize(self) -> int:
        """``sizeof`` of the struct: the end of the last field rounded up to the largest alignment."""
        offs = self.offsets()
        end = max((o + _C_TYPES[t][1] * c for o, (_, t, c) in zip(offs, self.fields)), default=0)
        align = max((_C_TYPES[t][1] for _, t, _ in self.fields), default=1)
        return -(-end // align) * align

    def dtype(self) -> np.dtype:
        """The NumPy structured dtype with the C offsets and size."""
        names, formats = [], []
        for fname, ctype, count in self.fields:
            base = np.dtype(_C_TYPES[ctype][0])
            if ctype == "float4":
                formats.append((base, (4 * count,)))
            else:
                formats.append((base, (count,)) if count > 1 else base)
            names.append(fname)
        return np.dtype({"names": names, "formats": formats, "offsets": self.offsets(),
                         "itemsize": self.itemsize})

    def field_quads(self) -> dict[str, tuple[int, str]]:
        """For a float4-stored record: field → (float4 index, first component letter)."""
        out = {}
        for (fname, _, _), off in zip(self.fields, self.offsets()):
            out[fname] = (off // 16, "xyzw"[(off % 16) // 4])
        return out

    def c_text(self) -> str:
        """The ``typedef struct`` and, for a float4-stored record, its field positions."""
        lines = [f"/* {self.doc} */", "typedef struct {"]
        for fname, ctype, count in self.fields:
            lines.append(f"    {ctype} {fname}{f'[{count}]' if count > 1 else ''};")
        lines.append(f"}} {self.name};")
        if self.quads:
            up = self.name.upper()
            nq = self.itemsize // 16
            lines.append(f"#define {up}_QUADS {nq}u")
            lines.append(f"/* Every lane's record `index` of a float4 table into rec4v q0 .. q{nq - 1}"
                         " (render/lane_io.cl's gather_rec4). */")
            gathers = ", ".join(f"q##{k} = gather_rec4((table), (index) * {nq}u + {k}u)" for k in range(nq))
            lines.append(f"#define {up}_GATHER(q, table, index) rec4v {gathers}")
            for (fname, _, count), (q, comp) in zip(self.fields, self.field_quads().values()):
                lines.append(f"#define {up}_{fname.upper()}_QUAD {q}")
                lines.append(f"#define {up}_{fname.upper()}_COMP {comp}")
                first = "xyzw".index(comp)
                for i in range(1, count):
                    lines.append(f"#define {up}_{fname.upper()}_COMP{i} {'xyzw'[first + i]}")
        return "\n".join(lines)

    def check(self) -> None:
        """Raise ValueError if a float4-stored record breaks its rule (a field straddling float4s)."""
        if not self.quads:
            return
        if self.itemsize % 16:
            raise ValueError(f"{self.name}: size {self.itemsize} is not a whole number of float4")
        for (fname, ctype, count), off in zip(self.fields, self.offsets()):
            if _C_TYPES[ctype][1] != 4 or off // 16 != (off + 4 * count - 1) // 16:
                raise ValueError(f"{self.name}.{fname}: must be 4-byte values inside one float4")


def _quad_record(name: str, doc: str, *fields: tuple[str, str] | tuple[str, str, int]) -> Record:
    return Record(name, tuple((f[0], f[1], f[2] if len(f) > 2 else 1) for f in fields), doc, quads=True)


# Primitive shading record, one per primitive id (host: mcocl/render/device_scene.py, prim_records).
PRIM_RECORD = _quad_record(
    "prim_record", "shading data of primitive p: front normal (0 for spheres), area, material, emitter",
    ("normal", "float", 3), ("area", "float"),
    ("material", "uint"), ("emitter", "int"),  # emitter -1: the primitive does not emit
    ("pmf", "float"),  # probability that light sampling chooses the primitive (0: not a light)
    ("inward", "float"),  # 1: a sphere whose normals point inwards
)

# Light sampling record, one per emitting primitive (host: device_scene.light_records).
LIGHT_RECORD = _quad_record(
    "light_record", "emitting primitive k: triangle v0 and edges, or sphere centre and radius",
    ("base", "float", 3), ("area", "float"),  # triangle v0 or sphere centre
    ("edge1", "float", 3), ("shape", "float"),  # triangle v1 - v0, or (radius, 0, 0); shape: LightShape code
    ("edge2", "float", 3), ("pmf", "float"),  # triangle v2 - v0; exact choice probability on the uniforms' grid
    ("radiance", "float", 3), ("prim", "uint"),
)

# Light BVH node (host: mcocl/render/light_bvh.py; kernel: render/light_bvh.cl), node 0 the root.
# Bounding sphere, power and orientation cone of the lights below it (Conty Estevez & Kulla 2018).
LIGHT_BVH_NODE = _quad_record(
    "light_bvh_node", "light BVH node: bounding sphere, cone (axis, cos theta_o), power, children or light",
    ("center", "float", 3), ("radius2", "float"),  # a sphere holding every light below (radius squared)
    ("axis", "float", 3), ("cos_o", "float"),  # the emitters' normals lie within theta_o of axis
    ("power", "float"), ("ref", "uint"),  # count 1 (a leaf): ref is a light (light_record); else the first child
    ("count", "uint"),  # lights below: each gets at least a grid cell when it can shine
    ("cos_e", "float"),  # each emits within theta_e of its normal
)

# Material record (host: compiled.compile_scene, fields packed as mcocl/bsdf_registry.py declares;
# kernel: render/material.cl material_load).
MATERIAL_RECORD = _quad_record(
    "material_record", "a material: its MaterialKind code (as a float) and parameters",
    ("kind", "float"), ("rgb", "float", 3),  # albedo (diffuse) or specular reflectance (conductors, dielectrics)
    ("alpha", "float"), ("int_ior", "float"), ("ext_ior", "float"),
    ("flags", "float"),  # FLAG_BITS of mcocl/bsdf_registry.py (an integer stored as a float): twosided, beckmann, ...
    # Read only by the BSDFs and lanes that use them (render/material.cl):
    ("alpha_second", "float"),  # roughness along the second tangent (anisotropic; the key alpha_v)
    ("eta_rgb", "float", 3), ("k_rgb", "float", 3),  # complex index of refraction of a conductor
    ("table", "float"),  # index of the first float of the material's table in the materials table (roughplastic)
    # a dielectric's specular transmittance when it differs from its reflectance `rgb` (MAT_FLAG_TRANSMITTANCE)
    ("transmittance_rgb", "float", 3), ("pad", "float"),
)

# Camera (host: compiled.camera_matrix; kernel: camera.cl), one per scene.
CAMERA_RECORD = _quad_record(
    "camera_record", "perspective camera: origin and the right/up/forward axes (right, up scaled by the fov); "
    "thin lens: aperture radius (0: a pinhole) and focus distance; a film crop's centre in the crop's NDC units",
    ("origin", "float", 3), ("aperture_radius", "float"), ("right", "float", 3), ("focus_distance", "float"),
    ("up", "float", 3), ("crop_shift_x", "float"), ("forward", "float", 3), ("crop_shift_y", "float"),
)

# BVH (host: mcocl/render/bvh.py; kernels: bvh.cl, trace_packet.cl): nodes[0] is the header,
# internal node k the 4 float4 at 1 + 4k; the device table appends one LEAF_PRIM per slot of
# prims (mcocl/render/bvh_leaves.py; the header's leaf_row says where they start) and after
# them the 8-wide nodes of the single-ray traversal (mcocl/render/bvh_wide.py).
BVH_HEADER = _quad_record(
    "bvh_header", "nodes[0] of a BVH: primitive count, internal nodes, depth, row of the leaf primitives",
    ("nprims", "uint"), ("num_nodes", "uint"), ("depth", "uint"), ("leaf_row", "uint"),
)
BVH_NODE = _quad_record(
    "bvh_node", "internal BVH node: both children's boxes; cnt 0: child is node ref, else leaf prims[ref..ref+cnt)",
    ("lo0", "float", 3), ("ref0", "uint"), ("hi0", "float", 3), ("cnt0", "uint"),
    ("lo1", "float", 3), ("ref1", "uint"), ("hi1", "float", 3), ("cnt1", "uint"),
)

BVH_WIDE_NODE = _quad_record(
    "bvh_wide_node", "8-wide BVH node (mcocl/render/bvh_wide.py): its children's boxes as structure of arrays; "
    "cnt 0: child is wide node ref, 0xffffffff: no child, else a leaf of cnt leaf records from ref; "
    "field f_0 holds children 0-3, f_4 children 4-7 (a float8 is two float4 rows)",
    *((f"{f}_{half}", "uint" if f in ("ref", "cnt") else "float", 4)
      for f in ("lo_x", "lo_y", "lo_z", "hi_x", "hi_y", "hi_z", "ref", "cnt") for half in (0, 4)),
)
LEAF_PRIM = _quad_record(
    "leaf_prim", "a BVH leaf slot's primitive in leaf order: triangle v0, e1 = v1-v0, e2 = v2-v0; sphere (e1, pad1) = centre, radius",
    ("v0", "float", 3), ("prim", "uint"), ("e1", "float", 3), ("pad1", "float"),
    ("e2", "float", 3), ("pad2", "float"),
)

# The render kernel's scalar parameters, passed by value (host: mcocl/render/job.py).
RENDER_PARAMS = Record("render_params", (
    ("first_block", "ulong", 1), ("seed", "ulong", 1),
    ("nblocks", "uint", 1), ("spp_per_block", "uint", 1), ("spp_limit", "uint", 1),
    ("width", "uint", 1), ("height", "uint", 1), ("tile_pixels", "uint", 1), ("ntiles", "uint", 1),
    ("max_depth", "int", 1), ("rr_depth", "uint", 1),
    ("ntris", "uint", 1), ("nspheres", "uint", 1),
    ("nlights", "uint", 1), ("light_top", "uint", 1),  # light_top: largest power of two <= nlights (0: none)
    ("env_threshold", "float", 1), ("env_pmf", "float", 1),
    # bdpt's one strategy (s, t) to render, -1: all; whether without its MIS weight; the power
    # heuristic (1) or the balance heuristic (0); Russian roulette on connection shadow rays (1: on)
    ("bdpt_only_s", "int", 1), ("bdpt_only_t", "int", 1), ("bdpt_unweighted", "int", 1), ("bdpt_power_mis", "int", 1),
    ("bdpt_roulette", "int", 1),
    # the camera's clip planes along its optical axis (kernels/render/camera.cl, camera_clip): near 0 and
    # far +inf clip nothing; launch values, not build options, so that one build serves every clip
    ("near_clip", "float", 1), ("far_clip", "float", 1),
    # the reconstruction filter of a -DPIXEL_FILTER_SHAPED build (kernels/render/pixel_filter.cl): its kind
    # (mcocl/render/pixel_filter.py FILTER_CODES), radius and stddev in pixels; launch values for the same reason
    ("filter_kind", "int", 1), ("filter_radius", "float", 1), ("filter_stddev", "float", 1),
    ("env_radiance", "float4", 1),
    # caustic casters (mcocl/render/caster_guiding.py): how many rows of casters hold one (centre xyz, radius),
    # the probability that a guided vertex aims at one (kernels/render/caster_guiding.cl), and per row the
    # side its caustic falls on (unit axis from the small light through the caster, cos of the half-angle),
    # and how far, in caster radii, from its centre a point still aims at it
    ("ncasters", "uint", 1), ("caster_share", "float", 1), ("caster_reach", "float", 1),
    ("casters", "float4", 8), ("caster_axes", "float4", 8),
), "scalar parameters of render_blocks (kernels/render/integrator.cl)")

# The walk kernel's scalar parameters, passed by value (host: mcocl/walks/job.py, walk_params).
WALK_PARAMS = Record("walk_params", (
    ("first_block", "ulong", 1), ("walk_limit", "ulong", 1), ("seed", "ulong", 1),
    ("nwork", "uint", 1), ("nq", "uint", 1), ("wpb", "uint", 1),  # work-items, query points, walks per block
    ("survival", "float", 1), ("depth", "uint", 1), ("max_len", "uint", 1),
), "scalar parameters of walk_blocks (kernels/walks/walk.cl)")

# Where the parts of the walks' table buffer lie (host: mcocl/walks/tabulate.py,
# WalkTables.geometry; kernels: walks/transition.cl's walk_tables_at).
WALK_TABLE_GEOMETRY = Record("walk_table_geometry", (
    ("nxa", "uint", 1), ("nya", "uint", 1),  # cells of x per axis, bins of y per axis
    ("nb", "uint", 1), ("lognb", "uint", 1),  # bins (nya^DIM) and log2 of it
    ("trans_off", "uint", 1), ("q_off", "uint", 1), ("src_off", "uint", 1),  # transition CDFs, survival, source CDF
), "the tabulated densities of a walk: grid sizes and where each table starts in the buffer")

RECORDS: tuple[Record, ...] = (PRIM_RECORD, LIGHT_RECORD, LIGHT_BVH_NODE, MATERIAL_RECORD, CAMERA_RECORD, BVH_HEADER, BVH_NODE,
                               BVH_WIDE_NODE, LEAF_PRIM, RENDER_PARAMS, WALK_PARAMS, WALK_TABLE_GEOMETRY)


def c_header() -> str:
    """The text of ``kernels/layouts.cl``, generated from the enums and records above."""
    parts = [
        "/* layouts.cl — GENERATED from mcocl/layouts.py by `python -m mcocl.layouts`; do not edit.",
        " *",
        " * The records and codes the host and the kernels share (see mcocl/layouts.py).",
        " * tests/test_layouts.py checks that this file is what the generator writes and",
        " * that sizeof/offsetof of every struct match the NumPy dtypes on the device. */",
        "#ifndef MCOCL_LAYOUTS_CL",
        "#define MCOCL_LAYOUTS_CL",
    ]
    for en, prefix in ENUM_PREFIXES.items():
        parts.append("")
        parts.append(f"/* {en.__name__}: {(en.__doc__ or '').strip()} */")
        parts += [f"#define {prefix}{m.name} {int(m)}" for m in en]
    parts.append(f"#define FILM_STATS {len(FilmStat)}")
    parts.append("")
    parts.append("/* Bits of material_record.flags (mcocl/bsdf_registry.py, FLAG_BITS). */")
    parts += [f"#define MAT_FLAG_{k.upper()} {v}" for k, v in FLAG_BITS.items()]
    parts.append("")
    parts.append("/* A field of a float4-stored record gathered by <RECORD>_GATHER(q, ...) into rec4v q0, q1, ...:")
    parts.append(" * REC_FIELD(q, PRIM_RECORD_AREA) is q0.w.  The gather macros read `index` once per float4:")
    parts.append(" * pass a variable, not a call (a search repeated per float4 cost the render kernel ~7 %). */")
    parts.append("#define REC_CAT_(a, b) a##b")
    parts.append("#define REC_CAT(a, b) REC_CAT_(a, b)")
    parts.append("#define REC_FIELD(q, F) (REC_CAT(q, F##_QUAD).F##_COMP)")
    parts.append("/* A float[3] field as a vec3v (render/vec3.cl); REC_FIELD gives its first component. */")
    parts.append("#define REC_VEC3(q, F) v3(REC_CAT(q, F##_QUAD).F##_COMP, REC_CAT(q, F##_QUAD).F##_COMP1, \\")
    parts.append("                      REC_CAT(q, F##_QUAD).F##_COMP2)")
    for r in RECORDS:
        r.check()
        parts.append("")
        parts.append(r.c_text())
    parts.append("")
    parts.append("#endif")
    return "\n".join(parts) + "\n"


def header_file() -> Path:
    """Where the committed header lives: the kernels folder beside the package (or the installed copy)."""
    from .runtime import KERNEL_DIR

    return Path(KERNEL_DIR) / HEADER_PATH


def dispatcher_file() -> Path:
    """Where the committed BSDF dispatcher lives (``kernels/render/bsdf.cl``)."""
    from .runtime import KERNEL_DIR

    return Path(KERNEL_DIR) / DISPATCHER_PATH


def scenes_readme() -> Path | None:
    """scenes/README.md of a source checkout (it holds the generated table of materials), else None."""
    from .runtime import KERNEL_DIR

    path = Path(KERNEL_DIR).parent / "scenes" / "README.md"
    return path if path.exists() else None


def with_block(text: str, block: str, where: str = "scenes/README.md") -> str:
    """``text`` with the generated block whose first and last lines (its markers) are ``block``'s replaced."""
    lines = block.split("\n")
    head, sep, rest = text.partition(lines[0])
    _, sep2, tail = rest.partition(lines[-1])
    if not sep or not sep2:
        raise ValueError(f"{where}: the markers {lines[0]!r} ... {lines[-1]!r} are missing")
    return head + block + tail


def generated_files() -> list[tuple[Path, str]]:
    """Every committed generated file with the text the generators write now."""
    from .render.shape_registry import shapes_table

    out = [(header_file(), c_header()), (dispatcher_file(), dispatcher_source())]
    readme = scenes_readme()
    if readme is not None:
        out.append((readme, with_block(with_block(readme.read_text(), markdown_table()), shapes_table())))
    return out


def main(argv: list[str] | None = None) -> int:
    """Write ``kernels/layouts.cl``, ``kernels/render/bsdf.cl`` and the tables of scenes/README.md.

    ``--check``: write nothing; exit 1 if a committed file differs from the generator's text.
    """
    args = sys.argv[1:] if argv is None else argv
    stale = 0
    for path, text in generated_files():
        if "--check" in args:
            same = path.exists() and path.read_text() == text
            stale += not same
            print(f"{path}: {'up to date' if same else 'differs from the generator'}")
        elif not path.exists() or path.read_text() != text:
            path.write_text(text)
            print(f"wrote {path}")
    return 1 if stale else 0


if __name__ == "__main__":
    raise SystemExit(main())


__all__ = ["BVH_HEADER", "BVH_NODE", "BVH_WIDE_NODE", "CAMERA_RECORD", "ENUM_PREFIXES", "LEAF_PRIM", "LIGHT_BVH_NODE", "LIGHT_RECORD", "MATERIAL_RECORD",
           "PRIM_RECORD", "RECORDS", "RENDER_PARAMS", "WALK_PARAMS", "WALK_TABLE_GEOMETRY", "FilmStat", "Integrator", "LightSampler", "LightShape", "MaterialKind",
           "Record", "c_header", "dispatcher_file", "generated_files", "header_file",
           "scenes_readme", "with_block"]
