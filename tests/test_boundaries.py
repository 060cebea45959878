"""Package boundaries: no package reads another's private names.

Walks the source of ``conformal``, ``models``, ``envs``, ``experiments`` and ``benchmarks`` and fails on
(1) an import of a ``_private`` name from another of these packages (``from models.x import _y``,
``from conformal.dpft import _tables``) and (2) an attribute access ``obj._name`` (not on ``self`` or
``cls``) in one package where ``_name`` is a private attribute or function defined only in another
package -- e.g. ``head._rng`` in ``envs`` (``models.Head``'s state is public through
``Head.get_state`` / ``set_state``). Dunder names are not private. A checker test beside it proves
the walk finds planted violations.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("conformal", "models", "envs", "experiments", "benchmarks")


def _private(name: str) -> bool:
    return name.startswith("_") and not (name.startswith("__") and name.endswith("__"))


def _files(pkg: str) -> list[Path]:
    return sorted(p for p in (ROOT / pkg).rglob("*.py") if "__pycache__" not in p.parts)


def _defined(tree: ast.Module) -> tuple[set[str], set[str]]:
    """Private names a module defines: (attributes of objects -- ``obj._x = ...`` stores, methods and
    class-level names --, module-level functions, classes and variables)."""
    attrs, top = set(), set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Attribute) and isinstance(node.ctx, ast.Store) and _private(node.attr):
            attrs.add(node.attr)
        elif isinstance(node, ast.ClassDef):
            for item in node.body:
                names = ([item.name] if isinstance(item, (ast.FunctionDef, ast.AsyncFunctionDef)) else
                         [t.id for t in getattr(item, "targets", [getattr(item, "target", None)]) if isinstance(t, ast.Name)])
                attrs.update(n for n in names if _private(n))
    for item in tree.body:
        names = ([item.name] if isinstance(item, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)) else
                 [t.id for t in getattr(item, "targets", [getattr(item, "target", None)]) if isinstance(t, ast.Name)])
        top.update(n for n in names if _private(n))
    return attrs, top


def _module_aliases(tree: ast.Module, packages) -> set[str]:
    """Local names bound to one of ``packages`` or their modules (``import models``, ``import conformal as C``)."""
    out = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for a in node.names:
                if a.name.split(".")[0] in packages:
                    out.add(a.asname or a.name.split(".")[0])
        elif isinstance(node, ast.ImportFrom) and node.module and node.module.split(".")[0] in packages:
            out.update(a.asname or a.name for a in node.names if not a.name[0].isupper())
    return out


def violations(sources: dict[str, dict[str, str]]) -> list[str]:
    """``sources``: package -> {file name: source}. Returns one line per violation."""
    trees = {pkg: {f: ast.parse(src) for f, src in files.items()} for pkg, files in sources.items()}
    defined = {pkg: [_defined(t) for t in files.values()] for pkg, files in trees.items()}
    found = []
    for pkg, files in trees.items():
        attrs = set().union(*(a for o in trees if o != pkg for a, _ in defined[o]))
        top = set().union(*(t for o in trees if o != pkg for _, t in defined[o]))
        for fname, tree in files.items():
            modules = _module_aliases(tree, [o for o in trees if o != pkg])
            for node in ast.walk(tree):
                if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
                    target = node.module.split(".")[0]
                    if target in trees and target != pkg:
                        for alias in node.names:
                            if _private(alias.name) or any(_private(part) for part in node.module.split(".")[1:]
                                                           if part != "_gl"):
                                found.append(f"{fname}:{node.lineno}: imports {node.module}.{alias.name}")
                elif isinstance(node, ast.Attribute) and isinstance(node.ctx, ast.Load) and _private(node.attr):
                    base = node.value
                    if isinstance(base, ast.Name) and base.id in ("self", "cls"):
                        continue
                    root = base
                    while isinstance(root, ast.Attribute):
                        root = root.value
                    on_module = isinstance(root, ast.Name) and root.id in modules and base is root
                    if node.attr in attrs or (on_module and node.attr in top):
                        found.append(f"{fname}:{node.lineno}: reads .{node.attr}, private to another package")
    return found


def _sources() -> dict[str, dict[str, str]]:
    return {pkg: {str(p.relative_to(ROOT)): p.read_text() for p in _files(pkg)} for pkg in PACKAGES}


def test_no_package_reads_another_packages_private_names():
    found = violations(_sources())
    assert not found, "private names read across packages:\n" + "\n".join(found)


@pytest.mark.parametrize("planted", [
    "from models.simulation import _ms\n",
    "def f(head):\n    return head._rng\n",
    "from conformal.dpft import _expand\n",
    "import conformal.dpft as D\nD._expand\n",
    "def f(h):\n    return h.data, h._plan\n",
])
def test_the_walk_finds_planted_violations(planted):
    sources = _sources()
    sources["envs"] = dict(sources["envs"], **{"envs/planted.py": planted})
    assert any(v.startswith("envs/planted.py") for v in violations(sources))
