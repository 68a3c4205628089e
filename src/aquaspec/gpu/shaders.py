"""Loading WGSL from package resources.

Shaders live in ``aquaspec/shaders/*.wgsl``. Two mechanisms compose them:

- ``#include "name.wgsl"`` on a line of its own pastes that file (once).
- ``{{ name }}`` is replaced by a template value given to :func:`load_wgsl`;
  an undefined name is an error, so a missing value cannot compile silently.
"""

from __future__ import annotations

import re
from importlib import resources

_INCLUDE = re.compile(r'^\s*#include\s+"([^"]+)"\s*$', re.MULTILINE)
_TEMPLATE = re.compile(r"\{\{\s*([A-Za-z_][A-Za-z0-9_]*)\s*\}\}")


def _read(name: str) -> str:
    path = resources.files("aquaspec") / "shaders" / name
    if not path.is_file():
        raise FileNotFoundError(f"no WGSL resource {name!r} in aquaspec/shaders")
    return path.read_text(encoding="utf-8")


def _expand(name: str, seen: set[str]) -> str:
    if name in seen:
        return ""
    seen.add(name)
    return _INCLUDE.sub(lambda m: _expand(m.group(1), seen), _read(name))


def load_wgsl(name: str, **values) -> str:
    """WGSL source of ``shaders/<name>`` with includes and templates resolved."""
    src = _expand(name, set())

    def sub(m):
        key = m.group(1)
        if key not in values:
            raise KeyError(f"WGSL template value {key!r} used in {name} is not defined")
        return str(values[key])

    return _TEMPLATE.sub(sub, src)
