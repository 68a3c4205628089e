"""Loading WGSL from package resources.

A pass's shader lives beside its Python module, ``aquaspec/gpu/passes/<name>.wgsl``;
the pieces several shaders include (``common.wgsl``, ``tonemap.wgsl``,
``materials.wgsl``, ``lftables.wgsl``, ``shading4.wgsl``) live in
``aquaspec/gpu/wgsl/``. A name is looked up in both folders and must be in
exactly one. Two mechanisms
compose them:

- ``#include "name.wgsl"`` on a line of its own pastes that file (once).
- ``{{ name }}`` is replaced by a template value given to :func:`load_wgsl`;
  an undefined name is an error, so a missing value cannot compile silently.
"""

from __future__ import annotations

import re
from importlib import resources

_INCLUDE = re.compile(r'^\s*#include\s+"([^"]+)"\s*$', re.MULTILINE)
_TEMPLATE = re.compile(r"\{\{\s*([A-Za-z_][A-Za-z0-9_]*)\s*\}\}")

#: Folders of ``aquaspec.gpu`` holding WGSL: the passes' shaders, the shared includes.
WGSL_FOLDERS = ("passes", "wgsl")


def wgsl_path(name: str):
    """The resource of the WGSL file ``name`` (in one of :data:`WGSL_FOLDERS`)."""
    root = resources.files("aquaspec.gpu")
    found = [root / folder / name for folder in WGSL_FOLDERS if (root / folder / name).is_file()]
    if not found:
        raise FileNotFoundError(f"no WGSL resource {name!r} in aquaspec/gpu/"
                                f"{{{','.join(WGSL_FOLDERS)}}}")
    if len(found) > 1:
        raise FileNotFoundError(f"WGSL resource {name!r} is in more than one of aquaspec/gpu/"
                                f"{{{','.join(WGSL_FOLDERS)}}}")
    return found[0]


def _expand(name: str, seen: set[str]) -> str:
    if name in seen:
        return ""
    seen.add(name)
    text = wgsl_path(name).read_text(encoding="utf-8")
    return _INCLUDE.sub(lambda m: _expand(m.group(1), seen), text)


def load_wgsl(name: str, **values) -> str:
    """WGSL source of ``name`` with includes and templates resolved."""
    src = _expand(name, set())

    def sub(m):
        key = m.group(1)
        if key not in values:
            raise KeyError(f"WGSL template value {key!r} used in {name} is not defined")
        return str(values[key])

    return _TEMPLATE.sub(sub, src)
