"""The typedef lookup in front of wgpu-py's cffi parser gives the parser's types."""

from __future__ import annotations

import pytest

ffi_module = pytest.importorskip("wgpu.backends.wgpu_native._ffi")

from aquaspec.gpu import ffi_types  # noqa: E402


@pytest.fixture(scope="module")
def parser_and_lookup():
    parser = ffi_module.ffi._parser
    # The parser's own method (install puts the lookup on the instance).
    original = type(parser).parse_type_and_quals.__get__(parser)
    return original, ffi_types.typedef_lookup(parser, original)


def _typedef_names(parser):
    return sorted(k[len("typedef "):] for k in parser._declarations if k.startswith("typedef "))


def test_typedefs_pointers_and_arrays(parser_and_lookup):
    parse, lookup = parser_and_lookup
    names = _typedef_names(ffi_module.ffi._parser)
    assert len(names) > 300
    # Every twelfth typedef (the parser takes 10-50 ms per string) and the
    # kinds wgpu-py asks for: structs, handles, enums, flags.
    sample = names[::12] + ["WGPUStringView", "WGPUBufferDescriptor", "WGPUAdapter",
                            "WGPUTextureFormat", "WGPUBufferUsage"]
    for name in sample:
        for cdecl in (name, f"{name} *", f"{name}*", f"{name}[]", f"  {name} [ ] "):
            assert lookup(cdecl) == parse(cdecl), cdecl


@pytest.mark.parametrize("cdecl", ["uint32_t", "uint8_t []", "char []", "uint8_t *", "intptr_t",
                                   "float", "double *"])
def test_primitive_types(parser_and_lookup, cdecl):
    parse, lookup = parser_and_lookup
    assert lookup(cdecl) == parse(cdecl)


@pytest.mark.parametrize("cdecl", ["void(WGPUMapAsyncStatus, WGPUStringView, void *, void *)",
                                   "unsigned int", "WGPUStringView **", "const char *",
                                   "void *"])
def test_anything_else_goes_to_the_parser(cdecl):
    seen = []
    lookup = ffi_types.typedef_lookup(ffi_module.ffi._parser,
                                      lambda c: seen.append(c) or ("parsed", 0))
    assert lookup(cdecl) == ("parsed", 0)
    assert seen == [cdecl]


def test_unknown_names_go_to_the_parser():
    seen = []
    lookup = ffi_types.typedef_lookup(ffi_module.ffi._parser,
                                      lambda c: seen.append(c) or ("parsed", 0))
    assert lookup("NoSuchType *") == ("parsed", 0)
    assert seen == ["NoSuchType *"]


def test_install_is_idempotent_and_wgpu_still_works(device):
    assert ffi_types.install()
    first = ffi_module.ffi._parser.parse_type_and_quals
    assert ffi_types.install()
    assert ffi_module.ffi._parser.parse_type_and_quals is first
    # A struct type wgpu-py builds through the lookup, read back through cffi.
    p = ffi_module.ffi.new("WGPUBufferDescriptor *")
    assert ffi_module.ffi.typeof(p).item.cname == "WGPUBufferDescriptor"
    buf = device.create_buffer(size=64, usage="STORAGE")
    assert buf.size == 64
