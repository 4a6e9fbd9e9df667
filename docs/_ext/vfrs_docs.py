"""Sphinx glue of the vfrs site: pages generated from the code at build time.

- ``reference/_generated/scene_keys.md``: the scene file reference (:mod:`scene_reference`,
  read from the registries), included by ``reference/scene.md``;
- ``reference/_generated/cited_tests.md``: every test file the pages under docs/ cite, with
  the pages that cite it, included by ``verification.md``.

Both are written when the builder starts (only when their text changed, so an unchanged
build stays incremental) and are build outputs (.gitignore).
"""

from __future__ import annotations

import re
from pathlib import Path

from scene_reference import scene_reference

GENERATED = Path("reference") / "_generated"
TEST_PATH = re.compile(r"tests/test_[A-Za-z0-9_]+\.py")


def cited_tests(docs: Path) -> dict:
    """Test file -> the docs pages (relative to docs/) that name it, for every ``tests/test_*.py``
    a Markdown page under ``docs`` mentions (generated pages and the build excluded)."""
    out: dict = {}
    for page in sorted(docs.rglob("*.md")):
        rel = page.relative_to(docs)
        if rel.parts[0] in ("_build", "auto_gallery") or "_generated" in rel.parts:
            continue
        for name in sorted(set(TEST_PATH.findall(page.read_text(encoding="utf-8")))):
            out.setdefault(name, []).append(rel.as_posix())
    return dict(sorted(out.items()))


def cited_tests_markdown(docs: Path) -> str:
    root = docs.parent
    lines = ["| test file | exists | cited by |", "|---|---|---|"]
    for name, pages in cited_tests(docs).items():
        exists = "yes" if (root / name).is_file() else "**no**"
        # links from verification.md (at the top of docs/), where the include lands
        cites = ", ".join(f"[{p[:-3]}]({p})" for p in pages)
        lines.append(f"| `{name}` | {exists} | {cites} |")
    return "\n".join(lines) + "\n"


def _write(path: Path, text: str) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    if not path.exists() or path.read_text(encoding="utf-8") != text:
        path.write_text(text, encoding="utf-8")


def generate(app) -> None:
    src = Path(app.srcdir)
    _write(src / GENERATED / "scene_keys.md", scene_reference())
    _write(src / GENERATED / "cited_tests.md", cited_tests_markdown(src))


_LITERAL = re.compile(r"(``.*?``|`[^`]*`)")


def escape_bars(app, what, name, obj, options, lines) -> None:
    """The docstrings write norms and magnitudes as ``|F|``, which reStructuredText reads as a
    substitution: outside literals, a bar is escaped (no docstring of vfrs holds a reST table)."""
    for i, line in enumerate(lines):
        if "|" in line:
            parts = _LITERAL.split(line)
            lines[i] = "".join(p if k % 2 else re.sub(r"(?<!\\)\|", r"\\|", p) for k, p in enumerate(parts))


def setup(app):
    app.connect("builder-inited", generate)
    app.connect("autodoc-process-docstring", escape_bars)
    return {"version": "1", "parallel_read_safe": True, "parallel_write_safe": True}
