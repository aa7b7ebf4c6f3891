"""The largest user snippet mcocl hands to the OpenCL compiler (issue 10).

PoCL's clang walks an expression recursively, one stack frame or more per
operator of a chain or level of nesting, and its compile time grows with
them.  Measured on this project's machine (PoCL 3.1, LLVM 15, a loaded 2-core
host):

- on the default 8 MiB stack of a thread, 3,000 nested ``!`` killed the process
  with SIGSEGV (no message, nothing saved), 8,000 chained ``+`` did not, and an
  18,000-term sum did (12,000 had worked, issue 10);
- on the 1 GiB stack mcocl builds on (:func:`mcocl.runtime.build`) 49,000
  nested unary minus, 20,000 nested ``!`` and 18,000-term sums and products
  compiled, in 9 s, 127 s and about 50 s; 1,000, 2,000 and 4,500 nested
  conditionals (2 operators each) in 78 s, 74 s and 197 s.  Compile time does
  not count against ``--time`` (:mod:`mcocl.cli.supervise`), so it is bounded
  only by the snippet's size.

So a snippet is refused before compiling when it has more than
``MAX_SNIPPET_OPERATORS`` operators, which bounds the depth of any chain or
nesting (brackets are bounded separately, by clang's 256) and the compile
time: 8,000 is a third below the 12,000-term sum that worked on the small
stack, the 1 GiB stack leaves a margin of more than 100 over the shallowest
crash seen on 8 MiB (3,000 nested ``!``), and an 8,000-term sum compiled in
44 s at a load of 12.
``MAX_SNIPPET_CHARS`` bounds the text itself (long names, comments).
"""

from __future__ import annotations

import re

from .errors import InputError

# The longest snippet accepted, in characters.  Compile time grows faster than
# the length: an 18,000-term sum (90,000 characters) takes about a minute to
# build, and one of 200,000 terms would hold the terminal for hours before
# anything ran.  Longer code belongs in a table (a tabulated proposal) or in a
# loop over fewer statements.
MAX_SNIPPET_CHARS = 100_000
# The most operators accepted in one snippet: see the module docstring.
MAX_SNIPPET_OPERATORS = 8_000

_COMMENT_OR_STRING = re.compile(r"//[^\n]*|/\*.*?\*/|\"(?:\\.|[^\"\\])*\"|'(?:\\.|[^'\\])*'", re.S)
# One C token: a number (hex first, so 0x1p-3f stays whole), a name, or an
# operator (longest first, so <= is one operator and -> none).  A number's
# exponent sign is part of the number, not a minus.
_TOKEN = re.compile(
    r"(?P<num>0[xX][0-9a-fA-F.]*(?:[pP][+-]?\d+)?\w*|(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?\w*)"
    r"|(?P<name>[A-Za-z_]\w*)"
    r"|(?P<arrow>->)"
    r"|(?P<op><<=|>>=|\+\+|--|<<|>>|<=|>=|==|!=|&&|\|\||[-+*/%&|^]=|[-+*/%<>=!~?&|^])"
)


def operator_count(code: str) -> int:
    """The number of C operators in ``code`` (comments and string literals aside)."""
    text = _COMMENT_OR_STRING.sub(" ", code)
    return sum(1 for m in _TOKEN.finditer(text) if m.lastgroup == "op")


def check_snippet_size(label: str, code: str) -> None:
    """Refuse a snippet past ``MAX_SNIPPET_CHARS`` characters or ``MAX_SNIPPET_OPERATORS`` operators.

    Raises:
        InputError: naming ``label``, the limit and what the snippet has.
    """
    if len(code) > MAX_SNIPPET_CHARS:
        raise InputError(f"{label}: the code is {len(code):,} characters long; the limit is "
                         f"{MAX_SNIPPET_CHARS:,} (the OpenCL compiler would take many minutes on it). Shorten "
                         "it, or tabulate the function and use a tabulated proposal")
    n = operator_count(code)
    if n > MAX_SNIPPET_OPERATORS:
        raise InputError(f"{label}: the code has {n:,} operators; the limit is {MAX_SNIPPET_OPERATORS:,} (the "
                         "OpenCL compiler recurses once per operator and takes minutes on more, or crashes). "
                         "Write it as a loop over an array of coefficients, or tabulate the function and use a "
                         "tabulated proposal")
