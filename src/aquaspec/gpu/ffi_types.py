"""A faster lookup of C type names for wgpu-py's cffi interface.

wgpu-py builds every native struct with ``ffi.new("WGPUSomething *")``. cffi
turns each new type string into a type by running pycparser over a small C
file that first re-declares every typedef the wgpu header has (about 430), so
each distinct string costs 15-50 ms the first time it is seen; a one-image
``aquaspec render`` met about 75 of them and spent 1.2 s of its 4.3 s there
(measured 2026-11-24, cffi 2.1.1, pycparser 3.12, wgpu 0.32).

Nearly all of those strings are a typedef or primitive type name, alone or
followed by ``*`` or ``[]``. For those the answer is already in cffi's table
of declarations: the type, a pointer to it or an array of it, exactly what
the parser would have built (``cffi.model`` types compare by value). ``install`` puts that lookup in front
of the parser of wgpu-py's ``ffi``; anything else (function types,
qualifiers, unknown names) still goes to cffi's parser. If cffi's internals are
not what this expects, nothing is changed and wgpu-py works as before, only
slower to start. ``tests/gpu/test_ffi_types.py`` checks that the lookup gives the
parser's answer.
"""

from __future__ import annotations

import re

_SIMPLE = re.compile(r"\s*([A-Za-z_]\w*)\s*(\*|\[\s*\])?\s*")
# Single words the parser rewrites (implicit int) or that are no type on their own.
_NOT_ALONE = {"short", "long", "signed", "unsigned", "void", "__dotdotdot__"}


def typedef_lookup(parser, fallback):
    """``parse_type_and_quals`` for ``"Name"``, ``"Name *"`` and ``"Name[]"``.

    ``Name`` is a typedef of the header (``parser._declarations`` holds
    ``"typedef Name" -> (type, qualifiers)``) or a primitive type such as
    ``uint32_t`` or ``char``; ``fallback`` (the parser) takes anything else.
    ``parser`` is a ``cffi.cparser.Parser``.
    """
    # deferred: cffi's internals, needed only once a device is made (install)
    from cffi import commontypes, model

    declarations = parser._declarations
    primitive = model.PrimitiveType.ALL_PRIMITIVE_TYPES

    def base(name):
        found = declarations.get("typedef " + name)
        if found is not None:
            return found
        if name in primitive and name not in _NOT_ALONE:
            return commontypes.resolve_common_type(parser, name)
        return None

    def parse_type_and_quals(cdecl):
        m = _SIMPLE.fullmatch(cdecl)
        found = base(m.group(1)) if m else None
        # (Function typedefs, whose pointers become function pointers, are
        # left to the parser.)
        if found is None or isinstance(found[0], model.RawFunctionType):
            return fallback(cdecl)
        tp, quals = found
        suffix = m.group(2)
        if not suffix:
            return tp, quals
        if suffix == "*":
            return model.PointerType(tp, quals), 0
        return model.ArrayType(tp, None), quals

    return parse_type_and_quals


def install() -> bool:
    """Put the typedef lookup in front of wgpu-py's cffi parser (once); True if it is there."""
    try:
        # deferred: loads wgpu-native's library; only when a device is made
        from wgpu.backends.wgpu_native._ffi import ffi
        parser = ffi._parser
        current = parser.parse_type_and_quals
        if getattr(current, "_aquaspec_lookup", False):
            return True
        if not isinstance(parser._declarations, dict):
            return False
    except (ImportError, AttributeError):
        return False
    lookup = typedef_lookup(parser, current)
    lookup._aquaspec_lookup = True
    parser.parse_type_and_quals = lookup
    return True
