"""The tutorials' code runs (issue 35): every ``python`` block of docs/tutorials/*.md and of
docs/getting_started.md, in order, in one namespace per page, and every ``$ vfrs ...`` line
of its ``console`` blocks through ``vfrs.cli.main``, in a fresh folder holding ``examples/``
(a link to the repository's). A block preceded by ``% file: NAME`` (a MyST comment, not
shown) is written to NAME instead; one preceded by ``% not run in CI: why`` is skipped, and
the page says why in its text. The tutorials use the coarse mesh and short end times."""

import os
import re
import shlex
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
DOCS = ROOT / "docs"
PAGES = [DOCS / "getting_started.md"] + sorted(p for p in (DOCS / "tutorials").glob("*.md") if p.name != "index.md")
FENCE = re.compile(r"^(?:(%[^\n]*)\n)?```(\w*)[^\n]*\n(.*?)^```[ \t]*$", re.M | re.S)


def blocks(text: str) -> list:
    """(directive comment or '', language, code) of every fenced block, in order."""
    return [(m.group(1) or "", m.group(2), m.group(3)) for m in FENCE.finditer(text)]


def commands(console: str) -> list:
    """The ``$ ...`` commands of a console block (a trailing backslash continues a line)."""
    out, current = [], None
    for line in console.splitlines():
        if current is not None:
            current += " " + line.strip()
        elif line.startswith("$ "):
            current = line[2:].strip()
        else:
            continue
        if current.endswith("\\"):
            current = current[:-1].rstrip()
        else:
            out.append(current)
            current = None
    return out


def test_the_block_reader():
    text = "% file: a.toml\n```toml\nx = 1\n```\n\n% not run in CI: slow\n```console\n$ vfrs run a\n```\n" \
           "```python\nprint(1)\n```\n"
    assert blocks(text) == [("% file: a.toml", "toml", "x = 1\n"), ("% not run in CI: slow", "console", "$ vfrs run a\n"),
                            ("", "python", "print(1)\n")]
    assert commands("$ vfrs run a \\\n   -o b\nout\n$ vfrs plot b\n") == ["vfrs run a -o b", "vfrs plot b"]


@pytest.mark.parametrize("page", PAGES, ids=[p.stem for p in PAGES])
def test_the_tutorial_runs(page, tmp_path, monkeypatch):
    from vfrs.cli import main

    monkeypatch.chdir(tmp_path)
    (tmp_path / "examples").symlink_to(ROOT / "examples")
    monkeypatch.setenv("MPLBACKEND", "Agg")
    namespace: dict = {"__name__": "__tutorial__"}
    ran = 0
    for comment, lang, code in blocks(page.read_text()):
        if comment.startswith("% not run in CI"):
            continue
        if comment.startswith("% file:"):
            Path(comment.split(":", 1)[1].strip()).write_text(code)
            continue
        if lang == "python":
            exec(compile(code, f"{page.name} (python block)", "exec"), namespace)
            ran += 1
        elif lang == "console":
            for cmd in commands(code):
                argv = shlex.split(cmd)
                assert argv[0] == "vfrs", f"{page.name}: {cmd!r} is not a vfrs command; mark its block " \
                                          "'% not run in CI: why' if it cannot run here"
                assert main(argv[1:]) == 0, f"{page.name}: {cmd!r} failed"
                ran += 1
    assert ran, f"{page.name} has no code that runs"
    assert os.getcwd() == str(tmp_path)
