"""User-supplied OpenCL C snippets pasted into kernel templates.

A snippet is either an expression (``exp(-x[0]*x[0])``) or a function body
that ``return``s.  It is wrapped into a function whose parameters are the
snippet's variables, and surrounded by ``#line`` directives so that the
compiler reports errors against the snippet's *own* line numbers under the
snippet's name (``integrand:1:9: error: ...``); :func:`explain_build_log`
turns such a log into a message that quotes the user's line.

Every snippet is rendered twice: as a scalar function (``float``) and as a
lane function in which ``float`` means the lane vector type ``floatv`` (see
``kernels/lanes.cl``).  The vector form lets plain scalar-looking code such as
``exp(-x[0]*x[0])`` run 8 or 16 samples per instruction; code that is not
valid on vectors (an ``if`` on a coordinate, an ``(int)`` cast) simply fails to
build in that form and the engine falls back to the scalar build.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from .errors import InputError, KernelBuildError
from .snippet_size import check_snippet_size

_RETURN = re.compile(r"\breturn\b")
# A decimal floating literal with an f suffix (1.5f, .5f, 2e-3f, 1.f); not hex
# literals (0x1p-3f, 0x1fu) nor identifiers: what precision="double" widens.
_FLOAT_LITERAL = re.compile(r"(?<![\w.])((?:\d+\.\d*|\.\d+)(?:[eE][+-]?\d+)?|\d+[eE][+-]?\d+)[fF]\b")
# The snippet types of each precision (scalar, lane vector).
REAL_TYPES = {"float": ("float", "floatv"), "double": ("double", "doublev")}
_IDENT = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")
# clang prints "file:line:col: error: msg"; PoCL's log "error: file:line:col: msg".
_DIAG = (
    re.compile(
        r"^(?P<file>[^\s:][^:\n]*):(?P<line>\d+):(?P<col>\d+):\s*(?P<kind>fatal error|error|warning|note):\s*(?P<msg>.*)$"
    ),
    re.compile(
        r"^(?P<kind>fatal error|error|warning|note):\s*(?P<file>[^\s:][^:\n]*):(?P<line>\d+):(?P<col>\d+):\s*(?P<msg>.*)$"
    ),
)


@dataclass(frozen=True)
class UserFunction:
    """One user snippet and the signature it is compiled under.

    Attributes:
        label: the name errors refer to (``integrand``, ``kernel``, ...).
        code: the snippet text, an expression or a body that returns.
        func: the C function name it becomes.
        params: ``(name, length)`` pairs; a parameter of length n > 0 is an
            array ``float name[n]`` (``x[dim]``), of length 0 a single ``float``.
        real: ``"float"`` (the default) or ``"double"``: the type the word
            ``float`` means in the snippet, of its parameters and of its value.
            In ``"double"`` the snippet's float literals (``0.3f``) are
            compiled without their suffix, as double constants: otherwise
            ``0.3f`` would carry float's rounding into a double evaluation.
    """

    label: str
    code: str
    func: str
    params: tuple[tuple[str, int], ...]
    real: str = "float"

    def __post_init__(self) -> None:
        if not isinstance(self.code, str) or not self.code.strip():
            raise InputError(f"{self.label}: expected OpenCL C code (an expression or a body that returns), got {self.code!r}")
        check_snippet_size(self.label, self.code)
        if not _IDENT.match(self.func):
            raise ValueError(f"bad function name {self.func!r}")
        if self.real not in REAL_TYPES:
            raise ValueError(f"bad snippet type {self.real!r}")
        self._check_constant_indices()

    def _check_constant_indices(self) -> None:
        """Refuse ``x[5]`` in a snippet over ``float x[2]``: an index written as a
        number is checked here; without this the kernel reads whatever lies
        beyond the array and the estimate is silently wrong."""
        for name, length in self.params:
            if length <= 0:
                continue
            for m in re.finditer(rf"(?<![\w.]){re.escape(name)}\s*\[\s*(\d+)[uU]?\s*\]", self.code):
                if int(m.group(1)) >= length:
                    valid = f"{name}[0]" if length == 1 else f"{name}[0] .. {name}[{length - 1}]"
                    raise InputError(
                        f"{self.label}: {m.group(0)} is beyond the {length} coordinate(s) of {name} "
                        f"(valid: {valid}); raise the dimension or fix the index"
                    )

    @property
    def is_body(self) -> bool:
        """True when the snippet is a function body (it contains ``return``)."""
        return bool(_RETURN.search(self.code))

    def render(self, vector: bool) -> str:
        """The snippet as an OpenCL C function, scalar or over lane vectors.

        The scalar function is named ``func`` + ``_s``, the lane one ``func``
        + ``_v``; in the lane form the word ``float`` inside the snippet means
        ``floatv`` (``real="double"``: ``double`` and ``doublev``).
        """
        name = self.func + ("_v" if vector else "_s")
        ftype = REAL_TYPES[self.real][1 if vector else 0]
        args = ", ".join(
            f"const {ftype} *{p}" if n else f"const {ftype} {p}" for p, n in self.params
        )
        code = self.code.rstrip()
        if self.real == "double":
            code = _FLOAT_LITERAL.sub(r"\1", code)
        lines = [f"MC_INLINE {ftype} {name}({args}) {{"]
        redefine = vector or self.real != "float"
        if redefine:
            lines.append(f"#define float {ftype}")
        if self.is_body:
            lines.append(f'#line 1 "{self.label}"')
            lines.append(code)
        else:
            lines.append("return (")
            lines.append(f'#line 1 "{self.label}"')
            lines.append(code)
            lines.append(f'#line 1 "{self.label}(end)"')
            lines.append(");")
        if redefine:
            lines.append("#undef float")
        lines.append("}")
        return "\n".join(lines) + "\n"


def explain_build_log(log: str, users: list[UserFunction], what: str) -> KernelBuildError:
    """Turn a compiler log into a :class:`KernelBuildError` that quotes user lines.

    Diagnostics that point into a user snippet are shown with the snippet's
    line and a caret under the column; diagnostics elsewhere (the engine's own
    template) are listed after them.  Warnings are dropped unless nothing else
    was found.
    """
    by_label = {u.label: u for u in users}
    shown: list[str] = []
    other: list[str] = []
    seen: set[tuple[str, int, int, str]] = set()
    for raw in log.splitlines():
        m = _DIAG[0].match(raw.strip()) or _DIAG[1].match(raw.strip())
        if not m or m["kind"] not in ("error", "fatal error"):
            continue
        fname = m["file"].strip()
        line, col, msg = int(m["line"]), int(m["col"]), m["msg"].strip()
        key = (fname, line, col, msg)
        if key in seen:
            continue
        seen.add(key)
        label = fname[: -len("(end)")] if fname.endswith("(end)") else fname
        user = by_label.get(label)
        if user is not None:
            src = user.code.splitlines() or [""]
            if fname.endswith("(end)"):
                # the error is at the closing parenthesis we add after an expression
                shown.append(f"{label}: {msg} (at the end of the expression)\n    {src[-1]}")
                continue
            text = src[line - 1] if 0 < line <= len(src) else ""
            caret = " " * max(col - 1, 0) + "^"
            shown.append(f"{label}, line {line}, column {col}: {msg}\n    {text}\n    {caret}")
        else:
            other.append(f"{fname}:{line}:{col}: {msg}")
    if not shown and not other:
        tail = "\n".join(log.strip().splitlines()[-20:])
        return KernelBuildError(f"{what} failed to compile; compiler log:\n{tail}", log)
    parts = [f"{what} failed to compile:"]
    parts += ["  " + s.replace("\n", "\n  ") for s in shown]
    if other:
        if shown:
            parts.append("  (consequent errors in the generated kernel)")
        parts += ["  " + s for s in other[:10]]
    return KernelBuildError("\n".join(parts), log)


def probe_source(users: tuple[UserFunction, ...]) -> str:
    """A kernel evaluating every snippet in scalar and lane form on probe points.

    ``probe_users(pts, out_s, out_v)``: ``pts`` holds the arguments transposed
    (argument-major, one row of NP points per scalar argument); work-item g
    evaluates points g*LANES .. g*LANES + LANES-1.  Used by the runtime to check
    that a snippet means the same thing on vector lanes as on scalars.
    """
    lines = [
        "kernel void probe_users(global const float *pts, global float *out_s, global float *out_v) {",
        "    const uint np = get_global_size(0) * LANES;",
        "    const uint p0 = get_global_id(0) * LANES;",
    ]
    for k, u in enumerate(users):
        # lane form; a double snippet gets the float points widened and its value rounded to float
        wide = u.real != "float"
        scalar, lane = REAL_TYPES[u.real]
        lines.append("    {")
        arg_names = []
        row = 0
        for name, n in u.params:
            cnt = max(n, 1)
            lines.append(f"        {lane} v_{name}[{cnt}];")
            for j in range(cnt):
                load = f"MC_CAT(vload, LANE_SUFFIX)(0, pts + {row} * np + p0)"
                lines.append(f"        v_{name}[{j}] = {f'to_doublev({load})' if wide else load};")
                row += 1
            arg_names.append(f"v_{name}" if n else f"v_{name}[0]")
        value = f"{u.func}_v({', '.join(arg_names)})"
        lines.append(f"        MC_CAT(vstore, LANE_SUFFIX)({f'to_floatv({value})' if wide else value}, 0, out_v + {k} * np + p0);")
        # scalar form, lane by lane
        lines.append("        for (uint l = 0; l < LANES; ++l) {")
        arg_names = []
        row = 0
        for name, n in u.params:
            cnt = max(n, 1)
            lines.append(f"            {scalar} s_{name}[{cnt}];")
            for j in range(cnt):
                lines.append(f"            s_{name}[{j}] = pts[{row} * np + p0 + l];")
                row += 1
            arg_names.append(f"s_{name}" if n else f"s_{name}[0]")
        lines.append(f"            out_s[{k} * np + p0 + l] = (float){u.func}_s({', '.join(arg_names)});"
                     if wide else f"            out_s[{k} * np + p0 + l] = {u.func}_s({', '.join(arg_names)});")
        lines.append("        }")
        lines.append("    }")
    lines.append("}")
    return "\n".join(lines) + "\n"
