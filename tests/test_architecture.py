"""The shape of the package: layers without cycles, imports at the top, modules of one concept.

The layers and the no-cycle rule are import-linter contracts in
``pyproject.toml`` (``[tool.importlinter]``); these tests run them and add the
two rules import-linter cannot state.
"""

from __future__ import annotations

import ast
import importlib
import re
import subprocess
import sys
import tomllib
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
PACKAGE = REPO / "src" / "aquaspec"

#: Modules allowed above :data:`MAX_LINES`, each with why it is one concept.
LONG_MODULES: dict[str, str] = {}
MAX_LINES = 620


def _modules():
    return sorted(p for p in PACKAGE.rglob("*.py"))


def test_import_contracts_hold():
    """Layers, no cycles, and a GPU-free NumPy side (``lint-imports``)."""
    lint = Path(sys.executable).with_name("lint-imports")
    done = subprocess.run([str(lint), "--no-cache"], cwd=REPO, capture_output=True, text=True)
    assert done.returncode == 0, done.stdout[-6000:] + done.stderr[-2000:]


def test_every_package_is_in_a_layer():
    """A new package cannot escape the layers: the contract is exhaustive and names them all."""
    config = tomllib.loads((REPO / "pyproject.toml").read_text())["tool"]["importlinter"]
    layers = next(c for c in config["contracts"] if c["type"] == "layers")
    assert layers["exhaustive"] is True
    named = {name.strip() for layer in layers["layers"] for name in layer.split("|")}
    children = {p.stem if p.is_file() else p.name for p in PACKAGE.iterdir()
                if (p.suffix == ".py" and p.stem not in ("__init__", "__main__"))
                or (p.is_dir() and (p / "__init__.py").is_file())}
    assert children == named
    assert any(c["type"] == "acyclic_siblings" and c["ancestors"] == ["aquaspec"]
               for c in config["contracts"])


def _function_level_imports(path: Path):
    tree = ast.parse(path.read_text(encoding="utf-8"))
    lines = path.read_text(encoding="utf-8").splitlines()
    for node in ast.walk(tree):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            for inner in ast.walk(node):
                if isinstance(inner, (ast.Import, ast.ImportFrom)):
                    text = " ".join(lines[inner.lineno - 2:inner.end_lineno])
                    yield inner.lineno, text


def test_imports_inside_functions_only_defer_heavy_dependencies():
    """An import inside a function hides a cycle unless it defers a heavy optional
    dependency; each such import says so with a ``# deferred: <why>`` comment
    (on its line or the line above)."""
    found = [f"{p.relative_to(REPO)}:{line}" for p in _modules()
             for line, text in _function_level_imports(p) if "# deferred:" not in text]
    assert not found, "function-level imports without '# deferred: <why>':\n" + "\n".join(found)


def test_modules_hold_one_concept():
    """No module over about 600 lines unless :data:`LONG_MODULES` says why it is one concept."""
    long = {str(p.relative_to(PACKAGE)): n for p in _modules()
            if (n := len(p.read_text(encoding="utf-8").splitlines())) > MAX_LINES}
    assert set(long) <= set(LONG_MODULES), f"modules over {MAX_LINES} lines: {long}"
    assert not set(LONG_MODULES) - {str(p.relative_to(PACKAGE)) for p in _modules()}


def test_wgsl_lives_beside_its_pass():
    """Each GPU pass module with a shader of its own has it beside it."""
    passes = PACKAGE / "gpu" / "passes"
    for wgsl in passes.glob("*.wgsl"):
        assert wgsl.with_suffix(".py").is_file(), f"{wgsl.name} has no pass module beside it"


_REFERENCE = re.compile(r":(?:func|mod|class|data|meth|attr|exc):`~?(aquaspec(?:\.\w+)+)(?:\(\))?`")


def _resolves(dotted: str) -> bool:
    parts = dotted.split(".")
    for cut in range(len(parts), 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:cut]))
        except ImportError:
            continue
        for name in parts[cut:]:
            if not hasattr(obj, name):
                return False
            obj = getattr(obj, name)
        return True
    return False


def test_docstring_references_resolve():
    """Every ``:func:`aquaspec...``` (and :mod:, :class:, :data:, :meth:...) in the
    sources names something that exists, so a reader can follow it."""
    broken = sorted({f"{p.relative_to(REPO)}: {ref}" for p in _modules()
                     for ref in _REFERENCE.findall(p.read_text(encoding="utf-8"))
                     if not _resolves(ref)})
    assert not broken, "references to nothing:\n" + "\n".join(broken)


def test_shader_paths_named_in_sources_exist():
    """A ``.wgsl`` file named in a Python or WGSL source exists in the package."""
    names = {p.name for p in PACKAGE.rglob("*.wgsl")}
    named = {(p.relative_to(REPO), m) for p in list(_modules()) + list(PACKAGE.rglob("*.wgsl"))
             for m in re.findall(r"(?<![\w.])([a-z][a-z0-9_/]*\.wgsl)\b(?!\()", p.read_text(encoding="utf-8"))
             if m != "name.wgsl"}
    missing = sorted(f"{p}: {m}" for p, m in named if Path(m).name not in names)
    assert not missing, "\n".join(missing)
