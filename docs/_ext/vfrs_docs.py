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


TOCTREE = re.compile(r"^```\{toctree\}\n(.*?)^```", re.M | re.S)
#: Folders whose pages are not pages of the site's navigation (build outputs, included parts).
NOT_PAGES = ("_build", "auto_gallery", "gallery", "_ext")


def listed_pages(docs: Path) -> set:
    """The docnames the toctrees of docs/index.md and docs/tutorials/index.md list."""
    out: set = set()
    for index in (docs / "index.md", docs / "tutorials" / "index.md"):
        prefix = "" if index.parent == docs else index.parent.relative_to(docs).as_posix() + "/"
        for block in TOCTREE.findall(index.read_text(encoding="utf-8")):
            out |= {prefix + line.strip() for line in block.splitlines() if line.strip() and not line.startswith(":")}
    return out


def unlisted_pages(docs: Path) -> list:
    """Markdown pages under docs/ that no toctree lists (a page another change just added)."""
    pages = []
    for page in sorted(docs.rglob("*.md")):
        rel = page.relative_to(docs)
        if rel.parts[0] in NOT_PAGES or "_generated" in rel.parts or rel.name == "index.md":
            continue
        pages.append(rel.with_suffix("").as_posix())
    listed = listed_pages(docs)
    return [p for p in pages if p not in listed]


def add_unlisted(app, docname, source) -> None:
    """A page no toctree lists yet joins the index under "More pages" (so a page written by
    another change builds at once; move it into its section of docs/index.md)."""
    if docname != "index":
        return
    extra = unlisted_pages(Path(app.srcdir))
    if extra:
        source[0] += "\n```{toctree}\n:caption: More pages\n:maxdepth: 1\n\n" + "\n".join(extra) + "\n```\n"


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
    app.connect("source-read", add_unlisted)
    return {"version": "1", "parallel_read_safe": True, "parallel_write_safe": True}
