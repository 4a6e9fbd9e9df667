"""Size guards: Python functions <= 80 lines, Python files <= 600 lines, Rust files <= 800 lines.

(Rust functions are guarded by clippy's ``too_many_lines`` at 80 lines: clippy.toml, and the
workspace's lints in Cargo.toml; CI runs clippy with warnings as errors.)

A file or function over its limit must be on the allow-list below with the reason it is
there and the size it had when it was listed: it may shrink, never grow past that size, and
an entry whose file or function has come under the limit must be removed (the test says so).
So the list can only get shorter.
"""

from __future__ import annotations

import ast
import pathlib

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "python" / "vfrs"
RUST = ROOT / "rust"

PY_FUNCTION_LINES = 80
PY_FILE_LINES = 600
RUST_FILE_LINES = 800

#: path relative to the repository (a file) or "path::qualified.name" (a function) ->
#: (lines when listed, why it is still over).
ALLOWED: dict[str, tuple[int, str]] = {
}


def _lines(path: pathlib.Path) -> int:
    return len(path.read_text(encoding="utf-8").splitlines())


def _rel(path: pathlib.Path) -> str:
    return path.relative_to(ROOT).as_posix()


def python_functions(path: pathlib.Path):
    """(qualified name, lines from ``def`` to its last line, docstring included, decorators
    not) of every function and method in a Python file, nested ones too."""
    tree = ast.parse(path.read_text(encoding="utf-8"))

    def walk(node, prefix):
        for child in ast.iter_child_nodes(node):
            if isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef)):
                name = prefix + child.name
                yield name, child.end_lineno - child.lineno + 1
                yield from walk(child, name + ".")
            elif isinstance(child, ast.ClassDef):
                yield from walk(child, prefix + child.name + ".")
            else:
                yield from walk(child, prefix)

    yield from walk(tree, "")


def measured() -> dict[str, tuple[int, int]]:
    """Every file and function of the package and the Rust crates: key -> (lines, limit)."""
    sizes: dict[str, tuple[int, int]] = {}
    for path in sorted(PACKAGE.rglob("*.py")):
        sizes[_rel(path)] = (_lines(path), PY_FILE_LINES)
        for name, n in python_functions(path):
            sizes[f"{_rel(path)}::{name}"] = (n, PY_FUNCTION_LINES)
    for path in sorted(RUST.rglob("*.rs")):
        if "target" not in path.parts:
            sizes[_rel(path)] = (_lines(path), RUST_FILE_LINES)
    return sizes


SIZES = measured()


def test_the_guard_sees_the_code():
    """The walk finds the package's files, functions and methods and the Rust sources (a
    guard that measured nothing would pass everything)."""
    assert "python/vfrs/run/__init__.py" in SIZES and "python/vfrs/run/__init__.py::run" in SIZES
    assert any(k.startswith("rust/vfrs-core/src/") for k in SIZES)
    assert any("." in k.split("::")[1] for k in SIZES if "::" in k)  # methods: Class.method


def test_python_function_lengths_count_the_whole_function(tmp_path):
    src = tmp_path / "m.py"
    src.write_text('def f():\n    """doc\n    string"""\n    return 1\n\n\nclass C:\n    def g(self):\n'
                   '        def inner():\n            pass\n        return inner\n')
    assert dict(python_functions(src)) == {"f": 4, "C.g": 4, "C.g.inner": 2}


def test_nothing_is_over_its_limit_unless_allowed():
    over = {k: v for k, v in SIZES.items() if v[0] > v[1]}
    unlisted = [f"{k}: {n} lines (limit {limit})" for k, (n, limit) in over.items() if k not in ALLOWED]
    grown = [f"{k}: {n} lines, grown past the {ALLOWED[k][0]} it had when allowed" for k, (n, _) in over.items()
             if k in ALLOWED and n > ALLOWED[k][0]]
    assert not unlisted, "over the limit: split them (or, with a reason, add them to ALLOWED):\n" + "\n".join(unlisted)
    assert not grown, "allowed entries may only shrink:\n" + "\n".join(grown)


def test_the_allow_list_holds_only_what_is_over_and_says_why():
    stale = [k for k in ALLOWED if k not in SIZES or SIZES[k][0] <= SIZES[k][1]]
    assert not stale, f"remove from ALLOWED (gone, or within the limit now): {stale}"
    assert all(why.strip() for _, why in ALLOWED.values()), "every ALLOWED entry gives its reason"
    assert len(ALLOWED) <= 3, "issue 44: an allow-list of at most 3 entries"


def test_the_guard_fails_on_a_long_function(tmp_path):
    """The same measure on a made-up file: a function of 81 lines is over the limit."""
    src = tmp_path / "m.py"
    src.write_text("def f():\n" + "    x = 1\n" * 79 + "    return x\n")
    assert dict(python_functions(src)) == {"f": 81} and 81 > PY_FUNCTION_LINES

#: The most modules the package's top level may hold besides its packages (issue 44: 31 stood
#: there; concepts with more than one module are packages).
TOP_LEVEL_MODULES = 22


def test_the_top_level_holds_few_modules():
    top = sorted(p.name for p in PACKAGE.glob("*.py") if p.name not in ("__init__.py", "__main__.py"))
    assert len(top) <= TOP_LEVEL_MODULES, (f"{len(top)} modules at the top of python/vfrs (at most "
                                           f"{TOP_LEVEL_MODULES}): put a concept's modules in its package: {top}")


def private_imports(path: pathlib.Path, label: str | None = None) -> list[str]:
    """``from <a vfrs module> import _name`` in a file: a private name used across modules
    (the extension module ``_core`` is a module, not a private name)."""
    label = label or _rel(path)
    out = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.ImportFrom) and (node.level or (node.module or "").startswith("vfrs")):
            out += [f"{label}:{node.lineno}: {a.name} from {'.' * node.level}{node.module or ''}"
                    for a in node.names if a.name.startswith("_") and not a.name.startswith("__") and a.name != "_core"]
    return out


def test_no_private_name_is_imported_across_modules():
    found = [line for path in sorted(PACKAGE.rglob("*.py")) for line in private_imports(path)]
    assert not found, "private names imported from another module (make them public):\n" + "\n".join(found)


def test_the_private_import_check_finds_one(tmp_path):
    src = tmp_path / "m.py"
    src.write_text("from .analysis import _window, peak\nfrom .. import _core\nfrom vfrs.x import _y\n"
                   "from os import _exit\nfrom __future__ import annotations\n")
    assert private_imports(src, "m.py") == ["m.py:1: _window from .analysis", "m.py:3: _y from vfrs.x"]
