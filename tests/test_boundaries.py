"""Package boundaries: the layers, the public names, no import circle, no write into another's state.

The packages form layers, ``conformal -> models -> envs -> experiments -> benchmarks``: each may use
the ones before it. Walking the source of all five (every import, module-level or inside a
function), the checker fails on

* **upward import**: a package imports one after it (``import experiments`` in ``models``);
* **internal import**: another package's private module or name (``import models._plan_kernels``,
  ``from models._gl import mujoco``, ``from conformal.dpft import _expand``), or a name its module
  does not export (not in that module's ``__all__``);
* **private name**: ``obj._name`` or ``getattr(obj, "_name")`` read where ``_name`` is a private
  attribute or module-level name defined in another package (``head._rng``);
* **foreign write**: a store into another package's object state -- a private attribute defined
  in another package (``head._hold = 0``, ``setattr(head, "_hold", 0)``), or MuJoCo's ``model`` /
  ``data`` arrays of an object held from outside ``models`` (``head.model.geom_rgba[...] = ...``):
  they belong to ``models.Head``, whose methods change them;
* **import circle**: modules that import each other, directly or around a loop (function-local
  imports included; importing a package's ``__init__`` is not an edge).

Self and ``cls`` are the object's own state. Dunder names are not private. Known debt is listed
in ``ALLOWED`` below, one commented entry per violation; an entry that no longer matches fails too.
The checker is tested by planting each kind of violation into a copy of the sources.
"""

from __future__ import annotations

import ast
import copy
import functools
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
LAYERS = ("conformal", "models", "envs", "experiments", "benchmarks")  # each may import the ones before it
MUJOCO_STATE = ("model", "data")  # models.Head's MjModel and MjData

#: Known debt (issue 37), each a violation its owning package still has to remove. The key is the
#: violation's text without its line number.
ALLOWED: set[str] = set()


def _private(name: str) -> bool:
    return name.startswith("_") and not (name.startswith("__") and name.endswith("__"))


def _module_name(rel: str) -> str:
    parts = rel[:-3].split("/")
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


class Sources:
    """The parsed source of the packages: ``files`` maps 'pkg/x/y.py' to its tree; what the checks
    need from each file is read once (``with_file`` adds one file to a copy)."""

    def __init__(self, files: dict[str, ast.Module]) -> None:
        self.files: dict[str, ast.Module] = {}
        self.modules: dict[str, str] = {}
        self.exports: dict[str, set[str] | None] = {}
        self.imports: dict[str, list[tuple[int, str, str | None, str | None]]] = {}
        self.private_attrs: dict[str, set[str]] = {p: set() for p in LAYERS}  # package -> obj._x it defines
        self.private_top: dict[str, set[str]] = {p: set() for p in LAYERS}  # package -> its modules' _names
        for rel, tree in files.items():
            self._add(rel, tree)

    def _add(self, rel: str, tree: ast.Module) -> None:
        self.files[rel] = tree
        self.modules[_module_name(rel)] = rel
        self.exports[_module_name(rel)] = _exports(tree)
        self.imports[rel] = list(_imports(rel, tree))
        attrs, top = _defined(tree)
        self.private_attrs[rel.split("/")[0]] |= attrs
        self.private_top[rel.split("/")[0]] |= top

    def with_file(self, rel: str, text: str) -> Sources:
        new = copy.copy(self)
        new.files, new.modules, new.exports, new.imports = (dict(self.files), dict(self.modules), dict(self.exports),
                                                            dict(self.imports))
        new.private_attrs = {p: set(v) for p, v in self.private_attrs.items()}
        new.private_top = {p: set(v) for p, v in self.private_top.items()}
        new._add(rel, ast.parse(text))
        return new


def _exports(tree: ast.Module) -> set[str] | None:
    for node in tree.body:
        targets = node.targets if isinstance(node, ast.Assign) else [getattr(node, "target", None)]
        if any(isinstance(t, ast.Name) and t.id == "__all__" for t in targets) and node.value is not None:
            try:
                return set(ast.literal_eval(node.value))
            except ValueError:
                return None
    return None


def _defined(tree: ast.Module) -> tuple[set[str], set[str]]:
    """Private names a module defines: (attributes of objects -- ``obj._x = ...`` stores, methods and
    class-level names --, module-level functions, classes and variables)."""
    attrs, top = set(), set()

    def names(item) -> list[str]:
        if isinstance(item, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            return [item.name]
        return [t.id for t in getattr(item, "targets", [getattr(item, "target", None)]) if isinstance(t, ast.Name)]

    for node in ast.walk(tree):
        if isinstance(node, ast.Attribute) and isinstance(node.ctx, ast.Store) and _private(node.attr):
            attrs.add(node.attr)
        elif isinstance(node, ast.ClassDef):
            for item in node.body:
                attrs.update(n for n in names(item) if _private(n))
    for item in tree.body:
        top.update(n for n in names(item) if _private(n))
    return attrs, top


def _imports(rel: str, tree: ast.Module):
    """(line, module, name or None, the local name bound) for every import of ``tree``, relative
    ones made absolute."""
    here = _module_name(rel).split(".")
    package = here if rel.endswith("__init__.py") else here[:-1]
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for a in node.names:
                yield node.lineno, a.name, None, a.asname or a.name.split(".")[0]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                up = package[:len(package) - node.level + 1]
                base = ".".join(up + ([base] if base else []))
            for a in node.names:
                yield node.lineno, base, a.name, a.asname or a.name


def _chain(node: ast.expr) -> tuple[ast.expr, list[str]]:
    """The root of ``a.b[i].c`` and its attribute names (``a``, ``['b', 'c']``)."""
    attrs = []
    while isinstance(node, (ast.Attribute, ast.Subscript)):
        if isinstance(node, ast.Attribute):
            attrs.append(node.attr)
        node = node.value
    return node, attrs[::-1]


def _foreign(src: Sources, pkg: str, name: str) -> bool:
    """``name`` is a private attribute defined in another package."""
    return _private(name) and any(name in src.private_attrs[o] for o in LAYERS if o != pkg)


def _file_violations(src: Sources, rel: str, tree: ast.Module) -> list[tuple[int, str]]:
    pkg = rel.split("/")[0]
    found: list[tuple[int, str]] = []
    module_aliases = set()  # local names of another package's modules
    views = _views(tree)
    for line, module, name, local in src.imports[rel]:
        target = module.split(".")[0]
        if target not in LAYERS or target == pkg:
            continue
        if name is None or f"{module}.{name}" in src.modules:
            module_aliases.add(local)
        if LAYERS.index(target) > LAYERS.index(pkg):
            found.append((line, f"upward import: {pkg} imports {module}"))
        full = f"{module}.{name}" if name else module
        if any(_private(part) for part in full.split(".")[1:]):
            found.append((line, f"internal import: {full}"))
        elif name and f"{module}.{name}" not in src.modules:
            exported = src.exports.get(module)
            if exported is not None and name != "*" and name not in exported:
                found.append((line, f"internal import: {full} (not in its __all__)"))
    for node in ast.walk(tree):
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and len(node.args) >= 2 \
                and node.func.id in ("getattr", "hasattr", "setattr", "delattr") \
                and isinstance(node.args[1], ast.Constant) and isinstance(node.args[1].value, str):
            attr = node.args[1].value
            obj = node.args[0]
            if not (isinstance(obj, ast.Name) and obj.id in ("self", "cls")) and _foreign(src, pkg, attr):
                kind = "foreign write" if node.func.id in ("setattr", "delattr") else "private name"
                found.append((node.lineno, f"{kind}: {node.func.id}(..., {attr!r}), private to another package"))
        elif isinstance(node, ast.Attribute) and isinstance(node.ctx, ast.Load) and _private(node.attr):
            base = node.value
            if isinstance(base, ast.Name) and base.id in ("self", "cls"):
                continue
            on_module = isinstance(base, ast.Name) and base.id in module_aliases
            others = [o for o in LAYERS if o != pkg]
            if _foreign(src, pkg, node.attr) or (on_module and any(node.attr in src.private_top[o] for o in others)):
                found.append((node.lineno, f"private name: reads .{node.attr}, private to another package"))
        elif isinstance(node, (ast.Assign, ast.AugAssign, ast.AnnAssign, ast.Delete)):
            targets = node.targets if isinstance(node, (ast.Assign, ast.Delete)) else [node.target]
            for target in targets:
                for t in ast.walk(target):
                    if not isinstance(t, (ast.Attribute, ast.Subscript)) or not isinstance(t.ctx, (ast.Store, ast.Del)):
                        continue
                    root, attrs = _chain(t)
                    if not isinstance(root, ast.Name):
                        continue
                    text = ".".join([root.id, *attrs])
                    if any(_foreign(src, pkg, a) for a in _held(root, attrs)):
                        found.append((node.lineno, f"foreign write: {text}, private to another package"))
                    elif pkg != "models" and (_mujoco_view(t) or root.id in views):
                        what = views.get(root.id, text)
                        found.append((node.lineno, f"foreign write: {what} (MuJoCo state of models.Head)"))
    return found


def _held(root: ast.Name, attrs: list[str]) -> list[str]:
    """The attributes of a chain that belong to objects the code does not own (past ``self.x``)."""
    return attrs[1:] if root.id in ("self", "cls") else attrs


def _mujoco_view(node: ast.expr) -> str | None:
    """``head.model.geom_rgba`` (or ``self.head.data.qpos``): an array of MuJoCo's model or data held
    by another object (``models.Head``), as text; None for anything else."""
    root, attrs = _chain(node)
    if isinstance(root, ast.Name) and any(a in MUJOCO_STATE for a in _held(root, attrs)[:-1]):
        return ".".join([root.id, *attrs])
    return None


def _views(tree: ast.Module) -> dict[str, str]:
    """Names bound to a MuJoCo array of another object, directly (``rgba = head.model.geom_rgba``) or
    by a loop over such arrays (``for key, arr in (("qpos", head.data.qpos), ...)``): name -> what."""
    views = {}
    for node in ast.walk(tree):
        if isinstance(node, ast.Assign) and _mujoco_view(node.value):
            for t in node.targets:
                views.update({n.id: f"{n.id} (a view of {_mujoco_view(node.value)})"
                              for n in ast.walk(t) if isinstance(n, ast.Name)})
        elif isinstance(node, ast.For) and isinstance(node.iter, (ast.Tuple, ast.List)):
            held = [_mujoco_view(e) for e in ast.walk(node.iter) if isinstance(e, (ast.Attribute, ast.Subscript))]
            held = [h for h in held if h]
            if held:
                views.update({n.id: f"{n.id} (a view of {', '.join(held)})"
                              for n in ast.walk(node.target) if isinstance(n, ast.Name)})
    return views


def _circles(src: Sources) -> list[str]:
    """Every set of modules that import each other (strongly connected components of the import
    graph, package ``__init__`` modules left out), as 'import circle: a -> b -> c' (sorted)."""
    graph: dict[str, set[str]] = {rel: set() for rel in src.files if not rel.endswith("__init__.py")}
    for rel in graph:
        for _, module, name, _ in src.imports[rel]:
            for candidate in ((f"{module}.{name}",) if name else ()) + (module,):
                dest = src.modules.get(candidate)
                if dest is not None:
                    if not dest.endswith("__init__.py") and dest != rel:
                        graph[rel].add(dest)
                    break
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    out = []

    def visit(v: str) -> None:  # Tarjan's strongly connected components
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in graph[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                out.append("import circle: " + " -> ".join(sorted(component)))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return sorted(out)


def violations(src: Sources, files: list[str] | None = None) -> list[str]:
    """One line per violation: 'file:line: kind: what' (circles: 'import circle: a -> b'); ``files``:
    only those files' own violations (and no circles)."""
    found = []
    for rel in sorted(src.files if files is None else files):
        found += [f"{rel}:{line}: {text}" for line, text in sorted(set(_file_violations(src, rel, src.files[rel])))]
    return found + (_circles(src) if files is None else [])


def _key(violation: str) -> str:
    """The violation without its line number (the allow-list's key)."""
    head, _, rest = violation.partition(": ")
    return f"{head.split(':')[0]}: {rest}" if head.endswith(tuple("0123456789")) else violation


@functools.lru_cache(maxsize=1)
def _sources() -> Sources:
    files = {}
    for pkg in LAYERS:
        for p in sorted((ROOT / pkg).rglob("*.py")):
            if "__pycache__" not in p.parts:
                files[p.relative_to(ROOT).as_posix()] = ast.parse(p.read_text(), str(p))
    return Sources(files)


def test_packages_keep_their_boundaries():
    """No violation beyond the allow-list, and the allow-list holds only live debt (a fixed entry
    must be removed from it)."""
    found = violations(_sources())
    assert not [v for v in found if _key(v) not in ALLOWED], "boundary violations:\n" + "\n".join(
        v for v in found if _key(v) not in ALLOWED)
    fixed = ALLOWED - {_key(v) for v in found}
    assert not fixed, f"fixed, remove from ALLOWED: {sorted(fixed)}"


PLANTS = {  # (file, source, the kind of violation it must produce)
    "upward import": ("models/planted.py", "import experiments\n", "upward import"),
    "upward import in a function": ("conformal/planted.py", "def f():\n    from envs import tasks\n",
                                    "upward import"),
    "internal module of another package": ("envs/planted.py",
                                           "def f():\n    from models.saccade_generator import simulate\n",
                                           "internal import"),
    "import models._plan_kernels": ("envs/planted.py", "import models._plan_kernels\n", "internal import"),
    "from models._gl import": ("benchmarks/planted.py", "from models._gl import mujoco\n", "internal import"),
    "from package import _module": ("experiments/planted.py", "from models import _plan_kernels as K\n",
                                    "internal import"),
    "private function": ("envs/planted.py", "from conformal.dpft import _mirror_series\n", "internal import"),
    "getattr(head, '_rng')": ("envs/planted.py", "def f(head):\n    return getattr(head, '_rng')\n",
                              "private name"),
    "head._rng": ("experiments/planted.py", "def f(head):\n    return head._rng\n", "private name"),
    "module's private name": ("envs/planted.py", "import conformal.dpft as D\nD._mirror_series\n", "private name"),
    "head._hold = 0": ("envs/planted.py", "def f(head):\n    head._hold = 0\n", "foreign write"),
    "setattr(head, '_hold', 0)": ("experiments/planted.py", "def f(head):\n    setattr(head, '_hold', 0)\n",
                                  "foreign write"),
    "head.model.geom_rgba[...] =": ("experiments/planted.py", "def f(head):\n    head.model.geom_rgba[3, 3] = 0\n",
                                    "foreign write"),
    "self.head.data.qpos[:] =": ("envs/planted.py", "class A:\n    def f(self):\n        self.head.data.qpos[:] = 0\n",
                                 "foreign write"),
    "a view of head.model.geom_rgba": ("experiments/planted.py",
                                       "def f(head):\n    rgba = head.model.geom_rgba\n    rgba[3, 3] = 0\n",
                                       "foreign write"),
    "a loop over MuJoCo arrays": ("experiments/planted.py",  # psychophysics/snapshots.py before issue 37
                                  "def f(head, snap):\n    for key, arr in ((\"qpos\", head.data.qpos),\n"
                                  "                     (\"geom_rgba\", head.model.geom_rgba)):\n"
                                  "        arr[:] = snap[key]\n", "foreign write"),
}


@pytest.mark.parametrize("plant", PLANTS)
def test_each_planted_violation_is_found(plant):
    rel, text, kind = PLANTS[plant]
    found = violations(_sources().with_file(rel, text), [rel])
    assert any(f": {kind}: " in v for v in found), (plant, found)
    assert not [v for v in found if _key(v) in ALLOWED]  # no exemption covers a new file


def test_a_planted_circle_is_found():
    """Two modules that import each other (one inside a function, one through a relative import)."""
    src = _sources().with_file("envs/planted_a.py", "from . import planted_b\n")
    src = src.with_file("envs/planted_b.py", "def f():\n    from envs.planted_a import g\n")
    assert "import circle: envs/planted_a.py -> envs/planted_b.py" in _circles(src)


def test_own_state_and_public_names_are_not_violations():
    ok = ("class A:\n    def f(self, head):\n        self._x = head.get_state()\n        self.model = 1\n"
          "        self.model.x = 2\n        return head.time_ms, head.model.geom_rgba[0]\n"
          "import models\nfrom conformal import checks\nfrom models import Head\n")
    assert violations(_sources().with_file("experiments/planted.py", ok), ["experiments/planted.py"]) == []
