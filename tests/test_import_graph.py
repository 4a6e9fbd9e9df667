"""The import graph of the whole package (issue 31, item 4): no circle, and no import up the
floors. Every ``import`` / ``from ... import`` statement of every module counts, at the top or
inside a function, and importing ``vfrs.a.b`` also runs the package ``vfrs.a`` (its
``__init__``); the registries' lazy loading (module names as strings, imported on first use)
is not an import statement and is how a lower floor reaches the plug-ins above it.

A module may import modules of its own floor and of the floors below. The floors, lowest
first, are :data:`FLOORS`; a module not listed fails the test, so a new module is placed
deliberately."""

from __future__ import annotations

import ast
from collections import defaultdict
from pathlib import Path

PKG = Path(__file__).resolve().parent.parent / "python" / "vfrs"

#: Lowest first. A name covers the module and everything under it (the longest name wins).
FLOORS = [
    ("ground: the Rust core, errors, parameters, registries and role protocols", [
        "vfrs._core", "vfrs._compat", "vfrs._version", "vfrs.errors", "vfrs.registry", "vfrs.params", "vfrs.linalg",
        "vfrs.signals", "vfrs.bandlimit", "vfrs.roles", "vfrs.effects", "vfrs.studies", "vfrs.studies.verification",
        "vfrs.studies.validation", "vfrs.studies.extra", "vfrs.studies.derived", "vfrs.figures"]),
    ("geometry and elements: meshes, materials, assembly, contact geometry", [
        "vfrs.mesh", "vfrs.mesh_quality", "vfrs.quadratic", "vfrs.materials", "vfrs.assembly", "vfrs.contact",
        "vfrs.meshes", "vfrs.finite_strain"]),
    ("the scene", ["vfrs.scene"]),
    ("the run folder: written (atomically), read back, checkpoints", ["vfrs.output", "vfrs.checkpoint"]),
    ("physics: integrators, effects, history, measures", [
        "vfrs.dynamics", "vfrs.flow", "vfrs.enforcement", "vfrs.history", "vfrs.summary", "vfrs.modes",
        "vfrs.acoustics"]),
    ("a run and its results", ["vfrs.run", "vfrs.result"]),
    ("tools on runs", ["vfrs.plot", "vfrs.studies.sweep", "vfrs.studies.converge", "vfrs.studies.accuracy", "vfrs.cli", "vfrs.__main__"]),
    ("the package's front", ["vfrs"]),
]


def _modules() -> dict:
    mods = {"vfrs._core": None}  # the extension (its submodules are one module here)
    for path in PKG.rglob("*.py"):
        parts = path.relative_to(PKG.parent).with_suffix("").parts
        name = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
        mods[name] = path
    return mods


def _known(name: str, mods: dict) -> str | None:
    if name.startswith("vfrs._core"):
        return "vfrs._core"
    while name and name not in mods:
        name = name.rpartition(".")[0]
    return name or None


def _edges(mods: dict) -> dict:
    edges: dict = defaultdict(set)
    for m, path in mods.items():
        if path is None:
            continue
        package = m if path.name == "__init__.py" else m.rpartition(".")[0]
        for node in ast.walk(ast.parse(path.read_text())):
            targets = []
            if isinstance(node, ast.Import):
                targets = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                base = node.module or ""
                if node.level:
                    up = package.split(".")[: len(package.split(".")) - (node.level - 1)]
                    base = ".".join(up) + ("." + node.module if node.module else "")
                targets = [f"{base}.{a.name}" if f"{base}.{a.name}" in mods or f"{base}.{a.name}".startswith("vfrs._core")
                           else base for a in node.names]
            for t in targets:
                t = _known(t, mods) if t.startswith("vfrs") else None
                if t and t != m and (t == "vfrs" or not m.startswith(t + ".")):
                    edges[m].add(t)  # what the statement names (the package front too: `import vfrs`)
                while t and "." in t:  # importing vfrs.a.b runs vfrs.a's __init__ too (vfrs's own: always)
                    t = t.rpartition(".")[0]
                    if t != "vfrs" and t != m and not m.startswith(t + "."):
                        edges[m].add(t)
    return edges


def _floor(m: str) -> int | None:
    best = None
    for i, (_, names) in enumerate(FLOORS):
        for n in names:
            if (m == n or m.startswith(n + ".")) and (best is None or len(n) > best[1]):
                best = (i, len(n))
    return None if best is None else best[0]


def _cycles(mods: dict, edges: dict) -> list:
    """The strongly connected components with more than one module (Tarjan)."""
    index: dict = {}
    low: dict = {}
    stack: list = []
    on: set = set()
    out: list = []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in edges[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    for v in sorted(mods):
        if v not in index:
            visit(v)
    return out


def test_every_module_has_a_floor():
    assert [m for m in sorted(_modules()) if _floor(m) is None] == []


def test_no_import_circle():
    mods = _modules()
    assert _cycles(mods, _edges(mods)) == []


def test_no_import_up_the_floors():
    mods = _modules()
    edges = _edges(mods)
    up = [f"{m} ({FLOORS[_floor(m)][0]}) imports {t} ({FLOORS[_floor(t)][0]})"
          for m in sorted(mods) for t in sorted(edges[m])
          if _floor(m) is not None and _floor(t) is not None and _floor(t) > _floor(m)]
    assert up == [], "\n".join(up)


def test_an_import_of_the_package_front_is_an_edge(tmp_path):
    """``import vfrs`` (or ``from . import __version__``) in a module is an import of the front,
    the top floor, and fails the floors test (it is not mistaken for the implicit run of
    vfrs/__init__ that every import inside the package makes)."""
    low = tmp_path / "errors.py"
    low.write_text("def f():\n    import vfrs\n    from . import __version__\n")
    mods = {"vfrs": PKG / "__init__.py", "vfrs.errors": low}
    assert _edges(mods)["vfrs.errors"] == {"vfrs"}
    assert _floor("vfrs") > _floor("vfrs.errors")


def test_the_graph_sees_imports_inside_functions_and_packages():
    """The test can fail: a function-local import up a floor (scene's of the surfaces check
    used to be one) and the package __init__ an import runs are edges."""
    mods = _modules()
    edges = _edges(mods)
    assert "vfrs.scene" in edges["vfrs.enforcement.surfaces"]  # via vfrs.scene.contact_keys: runs scene/__init__
    assert "vfrs.roles" in edges["vfrs.scene.parse"]  # imported inside read_time()
    assert _cycles({"a": 1, "b": 1}, defaultdict(set, {"a": {"b"}, "b": {"a"}})) == [["a", "b"]]


def floors_markdown() -> str:
    """The numbered list of docs/architecture.md's "Floors" section, made from :data:`FLOORS`
    (``python tests/test_import_graph.py`` prints it)."""
    def name(n):
        return "`vfrs/__init__.py`" if n == "vfrs" else f"`{n.removeprefix('vfrs.')}`"

    return "\n".join(f"{i}. **{label}**: {', '.join(name(n) for n in names)}"
                     for i, (label, names) in enumerate(FLOORS, 1))


def test_architecture_md_lists_the_floors_this_test_checks():
    """docs/architecture.md's list of floors is the one this test enforces, not a copy by hand
    that drifts (it omitted seven modules): regenerate it with ``python tests/test_import_graph.py``."""
    text = (PKG.parent.parent / "docs" / "architecture.md").read_text()
    assert floors_markdown() in text, "docs/architecture.md: replace the floors list by: python tests/test_import_graph.py"


if __name__ == "__main__":
    print(floors_markdown())
