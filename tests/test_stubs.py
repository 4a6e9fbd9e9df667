"""The type stub of vfrs._core names exactly what the extension exports."""

import ast
from pathlib import Path

import vfrs._core as core

STUB = Path(__file__).resolve().parent.parent / "python" / "vfrs" / "_core.pyi"


def test_stub_and_extension_agree():
    tree = ast.parse(STUB.read_text())
    stub = {n.name for n in tree.body if isinstance(n, (ast.FunctionDef, ast.ClassDef))}
    exported = {n for n in dir(core) if not n.startswith("_")}
    assert stub == exported, (stub ^ exported)
    for node in tree.body:
        if isinstance(node, ast.ClassDef) and not node.name.endswith("Error"):
            methods = {f.name for f in node.body if isinstance(f, ast.FunctionDef) and not f.name.startswith("__")}
            missing = [m for m in methods if not hasattr(getattr(core, node.name), m)]
            assert not missing, (node.name, missing)
