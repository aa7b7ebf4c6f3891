"""The BSDFs of the renderer, each declared once: one :func:`register_bsdf` class per BSDF.

A registration says everything the rest of mcocl needs to know about a BSDF:

- ``name`` (the scene file's ``"type"``) and ``code`` (its
  :class:`mcocl.layouts.MaterialKind` value, ``MAT_<NAME>`` in C, stored in
  ``material_record.kind``);
- its scene-file keys (:class:`Param`): type, default, range, and the
  ``material_record`` field each one packs into (``rgb``, ``alpha``,
  ``int_ior``, ``ext_ior``, ``alpha_second``, ``eta_rgb``, ``k_rgb``;
  :data:`mcocl.layouts.MATERIAL_RECORD`), plus fixed values of fields it has
  no key for, a check across keys and the packing of keys that fill several
  fields (:meth:`BsdfSpec.derive`);
- its kernel file ``kernels/render/bsdf_<name>.cl`` and the functions it defines
  (:attr:`BsdfSpec.eval_function`, :attr:`BsdfSpec.sample_function`, with the
  signatures written in :func:`dispatcher_source`);
- its flags: ``delta`` (every lobe is a Dirac delta: no ``eval``, no light
  sampling at its surfaces) and ``transmissive`` (sampling may refract and
  report the path's ``eta``).

From the registrations come the ``MaterialKind`` enum (mcocl/layouts.py),
the validation of the scene file's materials (mcocl/render/scene.py), the
packing of material records (mcocl/render/compiled.py), the C dispatcher
``kernels/render/bsdf.cl`` (:func:`dispatcher_source`), the names the Mitsuba
importer accepts (mcocl/render/mitsuba/bsdf.py) and the table of materials in
``scenes/README.md`` (:func:`markdown_table`).  The two generated files are
committed and rewritten by ``python -m mcocl.layouts``; tests/test_bsdf_registry.py
fails when either is stale.

Adding a BSDF: its kernel file, one class here, its test (docs/architecture.md).
This module imports nothing from mcocl but its table of conductor presets
(mcocl/conductor_iors.py, itself without imports), so that mcocl/layouts.py
can derive its enum from it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from .conductor_iors import CONDUCTOR_IORS

# The material_record fields a key can pack into (mcocl/layouts.py, MATERIAL_RECORD),
# with the value a material that does not set them stores.
# Indices of refraction beyond this are refused (no material has one; float32 Fresnel terms degrade).
IOR_LIMIT = 1e6

RECORD_FIELDS: dict[str, object] = {"rgb": (1.0, 1.0, 1.0), "alpha": 0.0, "int_ior": 1.0, "ext_ior": 1.0,
                                    "flags": 0, "alpha_second": 0.0, "eta_rgb": (0.0, 0.0, 0.0), "k_rgb": (0.0, 0.0, 0.0),
                                    "transmittance_rgb": (0.0, 0.0, 0.0)}

# Bits of material_record.flags (``MAT_FLAG_<NAME>`` in kernels/layouts.cl), set by the ``"flag"`` keys
# (bit named as the key) and the ``"choice"`` keys (bit named as the choice; the first choice sets none).
# twosided: the BSDF is mirrored onto the back side (Mitsuba's `twosided` wrapper), see dispatcher_source;
# beckmann: the microfacet distribution of the rough BSDFs (kernels/render/bsdf_roughconductor.cl);
# anisotropic: alpha is the roughness along the first tangent, alpha_v along the second;
# complex_ior: a conductor's Fresnel term from eta_rgb, k_rgb (kernels/render/fresnel_conductor.cl);
# transmittance: a dielectric's transmission is tinted by transmittance_rgb, not by rgb (set by
# :func:`transmittance_flag`; without it both lobes share rgb, and the record's last quad is not read);
# alpha_grid: a roughplastic's alpha is a texture: its tables are a grid over alpha, interpolated per hit
# (mcocl/render/roughplastic_tables.py, alpha_grid_tables).
# The BSDFs read the record's extended fields only for lanes with these bits (render/material.cl).
FLAG_BITS: dict[str, int] = {"twosided": 1, "beckmann": 2, "anisotropic": 4, "complex_ior": 8, "transmittance": 16,
                             "alpha_grid": 32}

DISPATCHER_PATH = "render/bsdf.cl"  # relative to the kernels folder


@dataclass(frozen=True)
class Param:
    """One scene-file key of a material.

    Attributes:
        key: the JSON key.
        kind: ``"rgb"`` (three numbers >= 0, or one for grey), ``"number"``, ``"flag"``
            (a boolean: true sets the bit :data:`FLAG_BITS` ``[key]`` of the ``flags`` field),
            ``"choice"`` (a string of ``choices``: the bit :data:`FLAG_BITS` ``[choice]``, none for the first)
            or ``"name"`` (a string of ``choices``).  A ``"name"`` key and an optional one have the field
            ``""``: they are kept under their key for :meth:`BsdfSpec.derive`, which packs them.
        field: the ``material_record`` field it fills (a key of :data:`RECORD_FIELDS`).
        doc: the meaning, for scenes/README.md.
        default: the value when the key is absent; ``None`` makes the key required.
        lo, hi: bounds of a number (``None``: unbounded); ``lo_open``/``hi_open`` exclude them.
        optional: the key may be absent (then nothing is packed; ``default`` is ``None``).
        texturable: the key also takes a texture object (mcocl/render/textures.py), looked up per hit
            (kernels/render/texture.cl); the record field then holds the texture's mean.
    """

    key: str
    kind: str
    field: str
    doc: str
    default: float | str | None = None
    choices: tuple[str, ...] = ()
    lo: float | None = None
    hi: float | None = None
    lo_open: bool = False
    hi_open: bool = False
    optional: bool = False
    texturable: bool = False

    @property
    def derived(self) -> bool:
        """The key is packed by :meth:`BsdfSpec.derive`, not into a field of its own."""
        return self.kind == "name" or self.optional

    def describe(self) -> str:
        """The key's type, range and default as scenes/README.md writes them."""
        if self.kind == "rgb":
            what = "RGB or a texture" if self.texturable else "RGB"
        elif self.kind == "flag":
            return f"`{self.key}` (boolean, default {'true' if self.default else 'false'}; {self.doc})"
        elif self.kind == "choice":
            return f"`{self.key}` ({' or '.join(map(repr, self.choices))}, default {self.default!r}; {self.doc})"
        elif self.kind == "name":
            return f"`{self.key}` (a name, default {self.default!r}; {self.doc})"
        elif self.lo is not None and self.hi is not None:
            what = f"number in {'(' if self.lo_open else '['}{self.lo:g}, {self.hi:g}{')' if self.hi_open else ']'}"
        elif self.lo is not None:
            what = f"number {'>' if self.lo_open else '≥'} {self.lo:g}"
        else:
            what = "number"
        if self.texturable and self.kind == "number":
            what += " or a texture"
        tail = "optional" if self.optional else "required" if self.default is None else f"default {self.default:g}"
        return f"`{self.key}` ({what}, {tail}{'; ' + self.doc if self.doc else ''})"


class BsdfSpec:
    """A registered BSDF (see the module docstring).

    Class attributes:
        name: the scene file's ``"type"``.
        code: the ``MaterialKind`` code; never reuse or renumber one (saved scenes and
            records carry it).
        params: the scene-file keys, validated in this order.
        fixed: values of record fields that no key sets (e.g. a dielectric's tint 1).
        delta: every lobe is a Dirac delta.
        transmissive: sampling may refract (writes the path's ``eta``).
        mixed: a delta lobe beside smooth ones: the sample function takes a last
            argument ``intv *delta`` (the lanes that sampled the delta lobe).
        eval_mode: eval depends on the transport mode (refraction's radiance
            scaling of a smooth transmissive BSDF): the eval function takes a last
            argument ``int mode``.
        summary: one line for scenes/README.md.
    """

    name: ClassVar[str]
    code: ClassVar[int]
    params: ClassVar[tuple[Param, ...]] = ()
    fixed: ClassVar[dict[str, object]] = {}
    delta: ClassVar[bool] = False
    transmissive: ClassVar[bool] = False
    mixed: ClassVar[bool] = False
    eval_mode: ClassVar[bool] = False
    summary: ClassVar[str]

    @property
    def kernel_file(self) -> str:
        """The BSDF's kernel file, relative to the kernels folder."""
        return f"render/bsdf_{self.name}.cl"

    @property
    def eval_function(self) -> str:
        """``vec3v <name>_bsdf_eval(const material_v *mat, vec3v wi, vec3v wo, floatv *pdf)``: f cos and pdf
        (with a last argument ``int mode`` when :attr:`eval_mode`)."""
        return f"{self.name}_bsdf_eval"

    @property
    def sample_function(self) -> str:
        """``vec3v <name>_bsdf_sample(mat, wi, u_lobe, u1, u2, &wo, &pdf, &eta, mode)``: the weight f cos / pdf."""
        return f"{self.name}_bsdf_sample"

    @property
    def c_code(self) -> str:
        """The C name of the code (layouts.cl)."""
        return f"MAT_{self.name.upper()}"

    def check(self, values: dict[str, object]) -> tuple[str, str] | None:
        """A check across keys on the validated record ``values``: ``(key, message)`` when it fails."""
        return None

    def derive(self, values: dict[str, object]) -> tuple[str, str] | None:
        """Fill record fields that follow from several keys (``values`` from :func:`record_values`,
        with the ``"name"`` keys and the given optional keys); ``(key, message)`` when they conflict."""
        return None

    def texture_flags(self, values: dict[str, object], textured: set[str]) -> int:
        """Bits of ``flags`` that follow from which record fields are textures (``textured``) and the
        derived ``values``."""
        return transmittance_flag(self, values, textured)


BSDFS: dict[str, BsdfSpec] = {}


def register_bsdf(cls: type[BsdfSpec]) -> type[BsdfSpec]:
    """Class decorator: make ``cls`` a material type of scene files and a branch of the kernels' dispatcher."""
    spec = cls()
    if spec.name in BSDFS or any(s.code == spec.code for s in BSDFS.values()):
        raise ValueError(f"BSDF {spec.name!r} (code {spec.code}): name or code already registered")
    unknown = [p.field for p in spec.params if p.field not in RECORD_FIELDS and not (p.field == "" and p.derived)] \
        + [f for f in spec.fixed if f not in RECORD_FIELDS]
    if unknown:
        raise ValueError(f"BSDF {spec.name!r}: no material_record field {unknown[0]!r}")
    bad_flags = [p.key for p in spec.params if (p.kind in ("flag", "choice")) != (p.field == "flags") or
                 (p.kind == "flag" and p.key not in FLAG_BITS) or
                 (p.kind == "choice" and any(c not in FLAG_BITS for c in p.choices[1:]))]
    if bad_flags:
        raise ValueError(f"BSDF {spec.name!r}: {bad_flags[0]!r} must be a flag of FLAG_BITS packed into 'flags'")
    BSDFS[spec.name] = spec
    return cls


def record_values(spec: BsdfSpec, given: dict[str, object]) -> dict[str, object]:
    """Every record field of a material: the validated keys, the spec's fixed values, else the defaults.

    ``given`` maps record fields to values, except that ``"flag"`` and
    ``"choice"`` keys are given under their key names (a boolean, a choice);
    their bits are OR-ed into ``flags``; derived keys (:attr:`Param.derived`) are
    given under their key names too, and stay so for :meth:`BsdfSpec.derive`.
    """
    out = dict(RECORD_FIELDS)
    out.update(spec.fixed)
    flags = int(out["flags"])  # type: ignore[call-overload]
    packed = {p.key: p for p in spec.params if p.field == "flags"}
    for k, v in given.items():
        p = packed.get(k)
        if p is None:
            out[k] = v
        elif p.kind == "flag":
            flags |= FLAG_BITS[k] if v else 0
        else:
            flags |= FLAG_BITS.get(str(v), 0)
    out["flags"] = flags
    return out


# The rough BSDFs' alpha may be a texture (its luminance, clamped to [1e-4, 1]); roughplastic's coat tables
# are then a grid over the texture's range of alpha (FLAG_BITS alpha_grid).
ALPHA_TEXTURED = Param("alpha", "number", "alpha", "a texture's luminance, clamped to [1e-4, 1]", default=0.1,
                       lo=1e-4, hi=1.0, texturable=True)
DISTRIBUTION = Param("distribution", "choice", "flags", "the microfacet distribution", default="ggx",
                     choices=("ggx", "beckmann"))
TWOSIDED = Param("twosided", "flag", "flags", "the same BSDF mirrored onto the back side, as Mitsuba's `twosided`", default=False)
# The tints of a dielectric's two lobes (Mitsuba 3's names): they scale the reflected and the transmitted
# weight, not the choice between the lobes (which stays the Fresnel term's).
SPECULAR_REFLECTANCE = Param("specular_reflectance", "rgb", "rgb", "tint of the reflection", default=1.0,
                             texturable=True)
SPECULAR_TRANSMITTANCE = Param("specular_transmittance", "rgb", "transmittance_rgb", "tint of the transmission",
                               default=1.0, texturable=True)
TINTS = (SPECULAR_REFLECTANCE, SPECULAR_TRANSMITTANCE)


def transmittance_flag(spec: BsdfSpec, values: dict[str, object], textured: set[str]) -> int:
    """The ``transmittance`` bit of a material's flags: set when its transmission's tint is not its reflection's.

    ``values``: the record fields (:func:`record_values`); ``textured``: the record fields given by a
    texture.  Without the bit the kernels tint both lobes by ``rgb`` (render/material.cl), so a material
    whose two tints are the same constant renders as the one-tint dielectric did.
    """
    if not any(p.field == "transmittance_rgb" for p in spec.params):
        return 0
    split = tuple(values["transmittance_rgb"]) != tuple(values["rgb"]) or bool(  # type: ignore[arg-type]
        {"rgb", "transmittance_rgb"} & textured)
    return FLAG_BITS["transmittance"] if split else 0


@register_bsdf
class Diffuse(BsdfSpec):
    """Lambertian, one-sided (kernels/render/bsdf_diffuse.cl)."""

    name = "diffuse"
    code = 0
    params = (Param("reflectance", "rgb", "rgb", "", texturable=True), TWOSIDED)
    summary = "Lambertian with that albedo, one-sided (black from behind) unless `twosided`"


METAL = Param("material", "name", "", "Mitsuba's conductor presets (Au, Ag, Cu, Al, Cr, ...: "
              "mcocl/conductor_iors.py); 'none' is a perfect mirror", default="none",
              choices=("none", *CONDUCTOR_IORS))
ETA = Param("eta", "rgb", "", "real part of the complex index of refraction (with `k`; not with `material`)",
            optional=True)
K = Param("k", "rgb", "", "imaginary part (absorption); default 1 when only `eta` is given", optional=True)
ALPHA_U = Param("alpha_u", "number", "", "roughness along the first tangent (with `alpha_v`: anisotropic; "
                "replaces `alpha`).  The tangent is the x axis of the frame built from the normal alone "
                "(Duff et al. 2017), not the surface's dp/du: Mitsuba's only where the two agree, e.g. on "
                "an unrotated rectangle", lo=1e-4, hi=1.0, optional=True)
ALPHA_V = Param("alpha_v", "number", "", "roughness along the second tangent", lo=1e-4, hi=1.0, optional=True)


def _derive_conductor(values: dict[str, object]) -> tuple[str, str] | None:
    """The complex index of refraction of a conductor (Mitsuba 3's rules): a named preset, or eta/k
    (defaults 0 and 1: a perfect mirror), or neither: the constant specular reflectance."""
    name, eta, k = values.pop("material", "none"), values.pop("eta", None), values.pop("k", None)
    if name != "none" and (eta is not None or k is not None):
        return "material", "give either material or eta/k, not both"
    if name != "none":
        eta, k = CONDUCTOR_IORS[str(name)]
    if eta is None and k is None:
        return None
    values["eta_rgb"] = tuple(float(x) for x in (eta if eta is not None else (0.0, 0.0, 0.0)))  # type: ignore[union-attr]
    values["k_rgb"] = tuple(float(x) for x in (k if k is not None else (1.0, 1.0, 1.0)))  # type: ignore[union-attr]
    values["flags"] = int(values["flags"]) | FLAG_BITS["complex_ior"]  # type: ignore[call-overload]
    return None


def _derive_anisotropy(values: dict[str, object]) -> tuple[str, str] | None:
    """alpha_u/alpha_v (both or neither): equal ones are an isotropic alpha, else the anisotropic flag."""
    au, av = values.pop("alpha_u", None), values.pop("alpha_v", None)
    if au is None and av is None:
        return None
    if au is None or av is None:
        return ("alpha_v" if av is None else "alpha_u"), "give both alpha_u and alpha_v (or alpha)"
    values["alpha"] = au
    if au != av:
        values["alpha_second"] = av
        values["flags"] = int(values["flags"]) | FLAG_BITS["anisotropic"]  # type: ignore[call-overload]
    return None


@register_bsdf
class Conductor(BsdfSpec):
    """A perfect mirror (kernels/render/bsdf_conductor.cl)."""

    name = "conductor"
    code = 1
    params = (Param("specular_reflectance", "rgb", "rgb", "", default=1.0, texturable=True), METAL, ETA, K, TWOSIDED)
    delta = True
    summary = ("a smooth metal: the conductor Fresnel term of `material` or `eta`/`k` times "
               "`specular_reflectance` (a perfect mirror without them); one-sided unless `twosided`")

    def derive(self, values: dict[str, object]) -> tuple[str, str] | None:
        """The complex index of refraction."""
        return _derive_conductor(values)


@register_bsdf
class RoughConductor(BsdfSpec):
    """GGX or Beckmann microfacet reflection (kernels/render/bsdf_roughconductor.cl); alpha's default is Mitsuba 3's.

    The distribution's default stays GGX in mcocl's JSON (its meaning before the
    key existed); the Mitsuba importer writes Mitsuba's default, Beckmann.
    """

    name = "roughconductor"
    code = 2
    params = (Param("specular_reflectance", "rgb", "rgb", "", default=1.0, texturable=True), METAL, ETA, K,
              ALPHA_TEXTURED, ALPHA_U, ALPHA_V, DISTRIBUTION, TWOSIDED)
    summary = ("microfacet reflection with roughness α (or anisotropic α_u, α_v): GGX sampled by visible normals, "
               "or Beckmann sampled by D(m) cos θ_m; Fresnel as `conductor`; one-sided unless `twosided`")

    def derive(self, values: dict[str, object]) -> tuple[str, str] | None:
        """The complex index of refraction and the anisotropic roughness."""
        return _derive_conductor(values) or _derive_anisotropy(values)


@register_bsdf
class Dielectric(BsdfSpec):
    """Smooth glass (kernels/render/bsdf_dielectric.cl); int_ior's default is Mitsuba 3's (BK7 glass)."""

    name = "dielectric"
    code = 3
    params = (Param("int_ior", "number", "int_ior", "BK7", default=1.5046, lo=0.0, lo_open=True, hi=IOR_LIMIT),
              Param("ext_ior", "number", "ext_ior", "", default=1.0, lo=0.0, lo_open=True, hi=IOR_LIMIT), *TINTS)
    delta = True
    transmissive = True
    summary = "smooth glass: Fresnel reflection and refraction; `int_ior` is inside (behind the front side)"

    def check(self, values: dict[str, object]) -> tuple[str, str] | None:
        """An interface between equal indices would be invisible."""
        if values["int_ior"] == values["ext_ior"]:
            return "int_ior", "int_ior equals ext_ior: the interface would be invisible"
        return None


@register_bsdf
class Plastic(BsdfSpec):
    """A smooth dielectric coat over a Lambertian base (kernels/render/bsdf_plastic.cl), Mitsuba 3's `plastic`.

    Defaults are Mitsuba 3's: polypropylene inside (1.49), air outside, a
    base albedo of 0.5; its specular reflectance is 1 and its model the linear one.
    """

    name = "plastic"
    code = 4
    params = (Param("diffuse_reflectance", "rgb", "rgb", "base albedo", default=0.5, texturable=True),
              Param("int_ior", "number", "int_ior", "polypropylene", default=1.49, lo=0.0, lo_open=True, hi=IOR_LIMIT),
              Param("ext_ior", "number", "ext_ior", "air", default=1.000277, lo=0.0, lo_open=True, hi=IOR_LIMIT),
              TWOSIDED)
    mixed = True
    summary = ("smooth plastic: Fresnel mirror coat over a Lambertian base (Mitsuba's `plastic`, linear); "
               "one-sided unless `twosided`")



@register_bsdf
class RoughPlastic(BsdfSpec):
    """A rough dielectric coat over a Lambertian base (kernels/render/bsdf_roughplastic.cl), Mitsuba 3's `roughplastic`.

    Defaults are Mitsuba 3's (as ``plastic``, with alpha 0.1) but for the
    distribution, GGX in mcocl's JSON as for the other rough BSDFs (the
    Mitsuba importer writes Mitsuba's default, Beckmann).  Its coat's
    transmittance and internal reflectance are tabulated per material at load
    time (mcocl/render/roughplastic_tables.py; the record's ``table`` field).
    """

    name = "roughplastic"
    code = 7
    params = (Param("diffuse_reflectance", "rgb", "rgb", "base albedo", default=0.5, texturable=True),
              Param("int_ior", "number", "int_ior", "polypropylene", default=1.49, lo=0.0, lo_open=True, hi=IOR_LIMIT),
              Param("ext_ior", "number", "ext_ior", "air", default=1.000277, lo=0.0, lo_open=True, hi=IOR_LIMIT),
              ALPHA_TEXTURED, DISTRIBUTION, TWOSIDED)
    summary = ("rough plastic: a microfacet coat (GGX or Beckmann, roughness α) over a Lambertian base, the "
               "light between them summed with the coat's tabulated transmittance (Mitsuba's `roughplastic`, "
               "linear); one-sided unless `twosided`")

    def texture_flags(self, values: dict[str, object], textured: set[str]) -> int:
        """A textured alpha reads its coat's tables from a grid over alpha."""
        return FLAG_BITS["alpha_grid"] if "alpha" in textured else 0


def _distinct_iors(values: dict[str, object]) -> tuple[str, str] | None:
    """An interface between equal indices would be invisible."""
    if values["int_ior"] == values["ext_ior"]:
        return "int_ior", "int_ior equals ext_ior: the interface would be invisible"
    return None


@register_bsdf
class RoughDielectric(BsdfSpec):
    """Rough glass, Walter et al. 2007 (kernels/render/bsdf_roughdielectric.cl), Mitsuba 3's `roughdielectric`.

    As roughconductor, the distribution's default is GGX in mcocl's JSON; the
    Mitsuba importer writes Mitsuba's default, Beckmann.
    """

    name = "roughdielectric"
    code = 5
    params = (Param("int_ior", "number", "int_ior", "BK7", default=1.5046, lo=0.0, lo_open=True, hi=IOR_LIMIT),
              Param("ext_ior", "number", "ext_ior", "", default=1.0, lo=0.0, lo_open=True, hi=IOR_LIMIT),
              ALPHA_TEXTURED, ALPHA_U, ALPHA_V, DISTRIBUTION, *TINTS)
    transmissive = True
    eval_mode = True
    summary = ("rough glass (Walter et al. 2007): microfacet reflection and refraction with roughness α, GGX "
               "sampled by visible normals or Beckmann by D(m) cos θ_m; `int_ior` is inside")

    def check(self, values: dict[str, object]) -> tuple[str, str] | None:
        """An interface between equal indices would be invisible."""
        return _distinct_iors(values)

    def derive(self, values: dict[str, object]) -> tuple[str, str] | None:
        """The anisotropic roughness."""
        return _derive_anisotropy(values)


@register_bsdf
class ThinDielectric(BsdfSpec):
    """A thin glass sheet (kernels/render/bsdf_thindielectric.cl), Mitsuba 3's `thindielectric`."""

    name = "thindielectric"
    code = 6
    params = (Param("int_ior", "number", "int_ior", "BK7", default=1.5046, lo=0.0, lo_open=True, hi=IOR_LIMIT),
              Param("ext_ior", "number", "ext_ior", "", default=1.0, lo=0.0, lo_open=True, hi=IOR_LIMIT), *TINTS)
    delta = True
    transmissive = True  # goes through the surface (eta stays 1: no change of medium)
    summary = ("a thin glass sheet: Fresnel reflection with the inter-reflections of its two faces summed, "
               "transmission straight through (no refraction)")

    def check(self, values: dict[str, object]) -> tuple[str, str] | None:
        """An interface between equal indices would be invisible."""
        return _distinct_iors(values)


def _any_kind(specs: list[BsdfSpec]) -> str:
    """C: the lanes whose material is one of ``specs``."""
    if not specs:
        return "(intv)(0)"
    return " | ".join(f"(m->kind == {s.c_code})" for s in specs)


def dispatcher_source() -> str:
    """The text of ``kernels/render/bsdf.cl``: one branch per registered BSDF, in code order.

    In a lane build the paths of a packet may sit on different materials: every
    kind present in the packet runs and each lane keeps its own kind's result
    (an absent kind costs one test); in the scalar build it is an ordinary branch.
    """
    specs = sorted(BSDFS.values(), key=lambda s: s.code)
    smooth = [s for s in specs if not s.delta]
    out = [
        "/* bsdf.cl — GENERATED from mcocl/bsdf_registry.py by `python -m mcocl.layouts`; do not edit.",
        " *",
        " * One entry point per BSDF query, dispatching on material_record.kind to the",
        " * functions of each registered BSDF's kernel file (render/bsdf_<name>.cl).",
        " * In a lane build the paths of a packet may sit on different materials: every",
        " * kind present in the packet is evaluated and the lanes take their own kind's",
        " * result (a kind absent from the packet costs one test); in the scalar build",
        " * the same code is an ordinary branch.",
        " *",
        " * Conventions (Mitsuba 3): directions in the local frame of the surface's",
        " * front normal, both pointing away from the surface; eval returns f cos(theta_o)",
        " * and the solid-angle pdf of sampling wo; sample returns f cos / pdf.",
        " *",
        " * Transport modes (Veach's thesis §5.2; pbrt-v4's and Mitsuba 3's TransportMode):",
        " * camera paths carry radiance (TRANSPORT_RADIANCE), light paths importance",
        " * (TRANSPORT_IMPORTANCE).  The BSDFs here are symmetric but for refraction's",
        " * radiance scaling: sample passes the mode to every BSDF's sample function,",
        " * eval (bsdf_eval_mode) to the smooth refracting ones (roughdielectric).",
        " */",
        "#ifndef MCOCL_BSDF_CL",
        "#define MCOCL_BSDF_CL",
        "",
        '#include "render/material.cl"',
        "",
        "#define TRANSPORT_RADIANCE 0",
        "#define TRANSPORT_IMPORTANCE 1",
        "",
        *[f'#include "{s.kernel_file}"' for s in specs],
        "",
        "/* Lanes that see a twosided material from behind.  There the BSDF is the",
        " * front one mirrored through the surface (Mitsuba 3's `twosided`): eval and",
        " * sample flip the z of wi (and of wo) so that every BSDF sees a front-side",
        " * query, and sample flips the z of the sampled wo back. */",
        "MC_INLINE intv bsdf_mirrored(const material_v *m, vec3v wi) {",
        "    return ((m->flags & MAT_FLAG_TWOSIDED) != 0) & (wi.z < 0.0f);",
        "}",
        "",
        "/* Lanes whose material has a non-delta lobe: light sampling applies there. */",
        "MC_INLINE intv bsdf_is_smooth(const material_v *m) {",
        f"    return {_any_kind(smooth)};",
        "}",
        "",
        "/* f cos(theta_o) for the pair (wi, wo), and the pdf of sampling wo from wi, in",
        " * transport mode `mode` (it matters to rough refraction only, see the top).",
        " * Zero for the delta materials (a mirror never reflects a sampled light). */",
        "MC_INLINE vec3v bsdf_eval_mode(const material_v *m, vec3v wi, vec3v wo, floatv *pdf, int mode) {",
        "    vec3v f = v3s(0.0f);",
        "    floatv p = (floatv)(0.0f);",
        "    intv back = bsdf_mirrored(m, wi);",
        "    wi.z = lane_select(wi.z, -wi.z, back);",
        "    wo.z = lane_select(wo.z, -wo.z, back);",
    ]
    for s in smooth:
        out += [
            f"    intv is_{s.name} = m->kind == {s.c_code};",
            f"    if (lane_any(is_{s.name})) {{",
            "        floatv pk;",
            f"        vec3v fk = {s.eval_function}(m, wi, wo, &pk{', mode' if s.eval_mode else ''});",
            f"        f = v3_select(f, fk, is_{s.name});",
            f"        p = lane_select(p, pk, is_{s.name});",
            "    }",
        ]
    out += [
        "    *pdf = p;",
        "    return f;",
        "}",
        "",
        "/* bsdf_eval_mode for camera paths (radiance). */",
        "MC_INLINE vec3v bsdf_eval(const material_v *m, vec3v wi, vec3v wo, floatv *pdf) {",
        "    return bsdf_eval_mode(m, wi, wo, pdf, TRANSPORT_RADIANCE);",
        "}",
        "",
        "typedef struct {",
        "    vec3v wo;      /* sampled direction (local frame) */",
        "    vec3v weight;  /* f cos / pdf; zero when the sample failed */",
        "    floatv pdf;    /* solid-angle pdf, or the lobe's probability for a delta lobe */",
        "    floatv eta;    /* eta_t / eta_i of the move (refraction), else 1 */",
        "    intv delta;    /* the sampled lobe is a Dirac delta */",
        "} bsdf_sample_v;",
        "",
        "/* Sample wo given wi; u_lobe picks a lobe (dielectric), (u1, u2) the direction;",
        " * mode: TRANSPORT_RADIANCE or TRANSPORT_IMPORTANCE. */",
        "MC_INLINE bsdf_sample_v bsdf_sample(const material_v *m, vec3v wi, floatv u_lobe, floatv u1, floatv u2,",
        "                                    int mode) {",
        "    bsdf_sample_v s;",
        "    s.wo = v3(0.0f, 0.0f, 1.0f);",
        "    s.weight = v3s(0.0f);",
        "    s.pdf = (floatv)(0.0f);",
        "    s.eta = (floatv)(1.0f);",
        f"    s.delta = {_any_kind([s for s in specs if s.delta])};",
        "    intv back = bsdf_mirrored(m, wi);",
        "    wi.z = lane_select(wi.z, -wi.z, back);",
    ]
    for s in specs:
        out += [
            f"    intv is_{s.name} = m->kind == {s.c_code};",
            f"    if (lane_any(is_{s.name})) {{",
            "        vec3v wo;",
            "        floatv p, e;",
            *(["        intv dl;"] if s.mixed else []),
            f"        vec3v w = {s.sample_function}(m, wi, u_lobe, u1, u2, &wo, &p, &e, mode{', &dl' if s.mixed else ''});",
            f"        s.wo = v3_select(s.wo, wo, is_{s.name});",
            f"        s.weight = v3_select(s.weight, w, is_{s.name});",
            f"        s.pdf = lane_select(s.pdf, p, is_{s.name});",
        ]
        if s.transmissive:
            out.append(f"        s.eta = lane_select(s.eta, e, is_{s.name});")
        if s.mixed:
            out.append(f"        s.delta = lane_select(s.delta, dl, is_{s.name});")
        out.append("    }")
    out += ["    s.wo.z = lane_select(s.wo.z, -s.wo.z, back);", "    return s;", "}", "", "#endif"]
    return "\n".join(out) + "\n"


TABLE_BEGIN = "<!-- BEGIN materials table: generated from mcocl/bsdf_registry.py by `python -m mcocl.layouts` -->"
TABLE_END = "<!-- END materials table -->"


def markdown_table() -> str:
    """The table of material types in scenes/README.md, with its markers :data:`TABLE_BEGIN`, :data:`TABLE_END`."""
    rows = [TABLE_BEGIN, "| type | keys | meaning |", "|---|---|---|"]
    for s in sorted(BSDFS.values(), key=lambda s: s.code):
        keys = ", ".join(p.describe() for p in s.params) or "—"
        rows.append(f"| `{s.name}` | {keys} | {s.summary} |")
    rows.append(TABLE_END)
    return "\n".join(rows)


__all__ = ["BSDFS", "DISPATCHER_PATH", "FLAG_BITS", "RECORD_FIELDS", "TWOSIDED", "TABLE_BEGIN", "TABLE_END", "BsdfSpec", "Param",
           "dispatcher_source", "markdown_table", "record_values", "register_bsdf", "transmittance_flag"]
