"""The documentation site's generated pages (issue 35): the scene file reference is read from
the registries at build time, so it cannot drift from the code; the verification page links
test files that exist; the scene reference fits a 1280 px window (scripts/check_doc_layout.py).
The test command (README, .ci/run: scripts/test_all.sh) runs every check and is quiet when green.
(The site itself is built by scripts/build_docs.sh, the test command's last step.)"""

import dataclasses
import os
import re
import shutil
import subprocess
import sys
import typing
from dataclasses import dataclass
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
DOCS = ROOT / "docs"
sys.path.insert(0, str(DOCS / "_ext"))
sys.path.insert(0, str(ROOT / "scripts"))

import check_doc_layout  # noqa: E402  (scripts/: the built site's layout check)
import scene_reference  # noqa: E402  (docs/_ext: the generator, kept outside the package)
import vfrs_docs  # noqa: E402

from vfrs.params import param, param_keys  # noqa: E402


def _field(cls, name):
    return {f.name: f for f in dataclasses.fields(cls)}[name]


def _entry(text: str, key: str):
    """The definition of ``key``'s first entry in the reference's definition lists, or None."""
    m = re.search(rf"^`{re.escape(key)}`\n: (.*)$", text, re.M)
    return m.group(1) if m else None


def test_every_registered_section_and_key_appears():
    text = scene_reference.scene_reference()
    regs = scene_reference.registries()
    checked = 0
    for kind in ("integrators", "effects", "methods", "detectors", "solvers", "generators", "materials"):
        for name, cls in regs[kind].items():
            params = cls if kind in ("generators", "materials") else getattr(cls, "Params", None)
            assert any(f in text for f in (f'"{name}"', f"[{name}]", f"(`{name}`)")), f"{kind} {name!r} is missing"
            if params is None:
                continue
            for key in param_keys(params):
                sub = typing.get_type_hints(params).get(key)
                if dataclasses.is_dataclass(sub) and isinstance(sub, type):  # a nested table: its keys
                    keys = [f"{key}.{k}" for k in param_keys(sub)]
                else:
                    keys = [key]
                for k in keys:
                    assert _entry(text, k) is not None, f"{kind} {name!r}: key {k!r} is not in the reference"
                    checked += 1
    for name in regs["schemes"]:
        assert _entry(text, name) is not None
    from vfrs.enforcement.effect import ContactParams

    for key in param_keys(ContactParams):
        assert _entry(text, key) is not None
    assert checked > 100  # the walk reached the registries' keys, not an empty page


def test_a_changed_default_changes_the_page(monkeypatch):
    from vfrs.enforcement import METHODS

    growth = _field(METHODS["augmented_lagrange"].Params, "growth")
    default = re.compile(r"^number · default `([^`]*)` ·")
    before = default.match(_entry(scene_reference.scene_reference(), "growth"))
    assert before and before.group(1) == f"{growth.default:g}"
    monkeypatch.setattr(growth, "default", 12.5)
    assert default.match(_entry(scene_reference.scene_reference(), "growth")).group(1) == "12.5"
    # and a changed unit and range, from param()'s metadata
    monkeypatch.setattr(growth, "metadata", {**growth.metadata, "unit": "furlong", "low": 2.0})
    assert _entry(scene_reference.scene_reference(), "growth").startswith("number (furlong) · default `12.5` · [2, 1e+06] — ")


def test_a_newly_registered_effect_gets_a_section():
    from vfrs.effects import Effect, register_effect, unregister_effect

    @register_effect
    class Breeze(Effect):
        """The ``[breeze_doc_test]`` section: a test's effect."""

        name = "breeze_doc_test"

        @dataclass(frozen=True)
        class Params:
            speed: float = param(2.5, doc="wind speed", unit="m/s", positive=True)
            gust: str = param("none", doc="gusts", choices=("none", "some"))

    try:
        text = scene_reference.scene_reference()
    finally:
        unregister_effect("breeze_doc_test")
    assert "### `[breeze_doc_test]`" in text
    assert _entry(text, "speed") == "number (m/s) · default `2.5` · > 0 — wind speed"
    assert _entry(text, "gust") == "string · default `\"none\"` · one of `none`, `some` — gusts"
    assert "breeze_doc_test" not in scene_reference.scene_reference()


def test_the_generated_files_are_written_where_the_pages_include_them(tmp_path):
    (tmp_path / "docs").mkdir()
    (tmp_path / "docs" / "page.md").write_text("see tests/test_scene.py and tests/test_nowhere.py\n")
    app = type("App", (), {"srcdir": str(tmp_path / "docs")})()
    vfrs_docs.generate(app)
    gen = tmp_path / "docs" / "reference" / "_generated"
    assert (gen / "scene_keys.md").read_text() == scene_reference.scene_reference()
    cited = (gen / "cited_tests.md").read_text()
    assert "| `tests/test_nowhere.py` | **no** | [page](page.md) |" in cited  # no such test in tmp_path
    included = re.findall(r"```\{include\} (\S+)", (DOCS / "reference" / "scene.md").read_text())
    assert included == ["_generated/scene_keys.md"]


def _linked_tests(page: Path) -> list:
    return re.findall(r"\]\((?:\.\./)+(tests/[^)#]+)\)", page.read_text())


def test_the_verification_page_links_test_files_that_exist():
    page = DOCS / "verification.md"
    linked = _linked_tests(page)
    assert len(linked) >= 10, "the verification page lists its cases with their tests"
    missing = [t for t in linked if not (ROOT / t).is_file()]
    assert not missing, f"docs/verification.md links test files that do not exist: {missing}"


def test_every_test_file_a_page_cites_exists():
    cited = vfrs_docs.cited_tests(DOCS)
    assert cited
    missing = {t: pages for t, pages in cited.items() if not (ROOT / t).is_file()}
    assert not missing, f"pages cite test files that do not exist: {missing}"


@pytest.mark.parametrize("name", ["first_collision", "change_parameters", "contact_methods", "sweeps",
                                  "error_estimate", "listen", "own_mesh"])
def test_the_tutorials_are_in_the_issue_order(name):
    index = (DOCS / "tutorials" / "index.md").read_text()
    order = ["first_collision", "change_parameters", "contact_methods", "sweeps", "error_estimate", "listen",
             "own_mesh"]
    listed = [line.strip() for line in index.splitlines() if line.strip() in order]
    assert listed == order
    assert (DOCS / "tutorials" / f"{name}.md").is_file()


def _test_commands(path: Path) -> list:
    """The commands in ``path``'s bash blocks that follow "Install and run all tests"."""
    return [b.strip() for b in re.findall(r"Install and run all tests.*?```bash\n(.*?)```", path.read_text(), re.S)]


#: What the test command runs (issue 43 item 13: only its output may change), and whether the
#: step's output is kept in a log printed on failure (scripts/quietly.sh).
TEST_STEPS = {'python -m pip install -e ".[test,docs]"': True, "cargo fmt --all -- --check": False,
              "cargo clippy --workspace --all-targets -- -D warnings": True, "cargo test": True,
              "python -m mypy python/vfrs": False, "python -m pytest -q --runslow": False,
              "scripts/build_docs.sh": True}


def test_ci_runs_the_readme_command_and_it_runs_every_check():
    readme = _test_commands(ROOT / "README.md")
    assert len(readme) == 1, "README: one bash block after 'Install and run all tests'"
    command = readme[0]
    for page in sorted(DOCS.rglob("*.md")):  # a page that shows the test command shows the README's
        assert set(_test_commands(page)) <= {command}, f"{page.relative_to(ROOT)} shows another test command"
    ci = [line for line in (ROOT / ".ci" / "run").read_text().splitlines() if line and not line.startswith(("#", "set ", "cd "))]
    assert ci == [command], f".ci/run runs {ci}, the README says {command!r}"
    assert command == "scripts/test_all.sh"
    steps = [line for line in (ROOT / command).read_text().splitlines() if line and not line.startswith(("#", "set ", "cd ", "q="))]
    for step, quiet in TEST_STEPS.items():
        line = next((x for x in steps if x.endswith(step)), None)
        assert line is not None, f"scripts/test_all.sh does not run {step!r}"
        assert line.startswith("$q ") == quiet, f"{step!r}: quiet {quiet} expected, the line is {line!r}"
    assert len(steps) == len(TEST_STEPS)
    for script in (command, "scripts/quietly.sh", "scripts/build_docs.sh", ".ci/run"):
        assert (ROOT / script).stat().st_mode & 0o111, f"{script} is not executable"


def test_a_quiet_step_prints_nothing_when_green_and_its_whole_log_when_it_fails(tmp_path):
    env = {**os.environ, "VFRS_TEST_LOGS": str(tmp_path / "logs")}
    green = subprocess.run([str(ROOT / "scripts" / "quietly.sh"), "green", "bash", "-c", "seq 300; seq 5 >&2"],
                           capture_output=True, text=True, env=env)
    assert (green.returncode, green.stdout, green.stderr) == (0, "", "")
    assert (tmp_path / "logs" / "green.log").read_text().split() == [str(i) for i in range(1, 301)] + ["1", "2", "3", "4", "5"]
    red = subprocess.run([str(ROOT / "scripts" / "quietly.sh"), "red", "bash", "-c", "echo compiling; echo 'error: boom' >&2; exit 3"],
                         capture_output=True, text=True, env=env)
    assert red.returncode == 3 and red.stdout == ""
    assert "compiling" in red.stderr and "error: boom" in red.stderr
    assert "FAILED (red, exit 3)" in red.stderr and str(tmp_path / "logs" / "red.log") in red.stderr


FAKE_TOOL = """#!/usr/bin/env bash
# a stand-in for python or cargo: 150 lines, or mypy's and pytest's one; the command FAIL_STEP fails
case "$*" in
  *mypy*) echo "Success: no issues found"; exit 0 ;;
  *pytest*) echo "....... 7 passed"; exit 0 ;;
  *fmt*) exit 0 ;;  # cargo fmt --check is silent when the code is formatted
esac
for i in $(seq 150); do echo "$(basename "$0") $1 $2 noise $i"; done
if [ "$(basename "$0") $*" = "$FAIL_STEP" ]; then echo "error: $FAIL_STEP broke" >&2; exit 7; fi
"""


def _run_test_command(tmp_path, fail_step: str):
    """scripts/test_all.sh in a copy of the repository's scripts, with fake python and cargo
    (150 lines of output each but mypy's and pytest's one line) and a fake docs build."""
    repo = tmp_path / "repo"
    (repo / "scripts").mkdir(parents=True)  # tmp_path: a new folder per call
    for name in ("test_all.sh", "quietly.sh"):
        shutil.copy2(ROOT / "scripts" / name, repo / "scripts" / name)
    bin_dir = tmp_path / "bin"
    bin_dir.mkdir()
    for tool in ("python", "cargo"):
        (bin_dir / tool).write_text(FAKE_TOOL)
    (repo / "scripts" / "build_docs.sh").write_text(FAKE_TOOL)
    for path in [*bin_dir.iterdir(), repo / "scripts" / "build_docs.sh"]:
        path.chmod(0o755)
    env = {**os.environ, "PATH": f"{bin_dir}:{os.environ['PATH']}", "FAIL_STEP": fail_step}
    env.pop("VFRS_TEST_LOGS", None)
    return subprocess.run([str(repo / "scripts" / "test_all.sh")], capture_output=True, text=True, env=env)


def test_a_green_test_command_prints_only_mypy_and_pytest_and_a_red_step_its_log(tmp_path):
    green = _run_test_command(tmp_path / "green", fail_step="no step")
    assert green.returncode == 0
    assert (green.stdout + green.stderr).splitlines() == ["Success: no issues found", "....... 7 passed"]
    assert len((tmp_path / "green" / "repo" / "target" / "test-logs" / "cargo-test.log").read_text().splitlines()) == 150
    red = _run_test_command(tmp_path / "red", fail_step="cargo test")  # clippy passed, mypy never runs
    assert red.returncode == 7
    assert "cargo test  noise 150" in red.stderr and "error: cargo test broke" in red.stderr
    assert "FAILED (cargo-test, exit 7)" in red.stderr and "clippy" not in red.stderr
    assert "Success" not in red.stdout + red.stderr


def test_the_readme_and_getting_started_give_the_same_time_for_the_main_job():
    pattern = re.compile(r"(\d+ s \(\d+ s CPU\) on a \d-core\s+machine)")
    readme = pattern.findall((ROOT / "README.md").read_text())
    started = pattern.findall((DOCS / "getting_started.md").read_text())
    assert readme and started, "README and docs/getting_started.md quote the main job's measured time"
    assert {" ".join(t.split()) for t in readme} == {" ".join(t.split()) for t in started}


def test_the_scene_reference_lists_its_keys_in_lines_that_fit_1280_px():
    """The six-column key tables overflowed a 1280 px window (the description one word wide):
    the keys are definition lists, and no code literal is too long for the narrowest article."""
    text = scene_reference.scene_reference()
    assert not [line for line in text.splitlines() if line.startswith("|")], "a Markdown table in the reference"
    entries = re.findall(r"^`[^`]+`\n: .+$", text, re.M)
    assert len(entries) > 150
    code = re.findall(r"`([^`]+)`", text)
    assert max(len(w) for c in code for w in c.split()) <= check_doc_layout.LONGEST_CODE


def _page(sidebar_classes: str, nav: str, article: str) -> str:
    return (f'<div id="pst-primary-sidebar" class="{sidebar_classes}"><nav class="bd-docs-nav">{nav}</nav></div>'
            f'<main id="main-content"><article class="bd-article" role="main">{article}</article></main>')


def test_the_layout_check_finds_what_made_the_reference_overflow(tmp_path):
    (tmp_path / "reference").mkdir()
    wide = _page("bd-sidebar-primary bd-sidebar", "<p>Section Navigation</p>", "<table><tr><td>x</td></tr></table>")
    (tmp_path / "reference" / "scene.html").write_text(wide)
    (tmp_path / "page.html").write_text(wide)  # a table elsewhere is not the reference's
    problems = check_doc_layout.static_check(tmp_path)
    assert len(problems) == 3 and sum("empty left sidebar" in p for p in problems) == 2
    assert any(p.startswith("reference/scene.html: 1 tables") for p in problems)
    def scene(chars):  # the reference with one code literal of ``chars`` characters, no table
        code = f'<code class="docutils literal notranslate"><span class="pre">{"a" * chars}</span></code>'
        return _page("bd-sidebar-primary bd-sidebar hide-on-wide", "", f"<dl><dt>{code}</dt></dl>")

    (tmp_path / "reference" / "scene.html").write_text(scene(check_doc_layout.LONGEST_CODE))
    (tmp_path / "page.html").write_text(_page("bd-sidebar-primary bd-sidebar", '<a href="x.html">x</a>', "<table></table>"))
    assert check_doc_layout.static_check(tmp_path) == []
    (tmp_path / "reference" / "scene.html").write_text(scene(check_doc_layout.LONGEST_CODE + 1))
    assert [p[:45] for p in check_doc_layout.static_check(tmp_path)] == ["reference/scene.html: a code literal of 71 ch"]


def test_a_page_no_toctree_lists_joins_the_index(tmp_path):
    docs = tmp_path / "docs"
    (docs / "tutorials").mkdir(parents=True)
    (docs / "index.md").write_text("# x\n\n```{toctree}\n:caption: A\n\nfirst\ntutorials/index\n```\n")
    (docs / "tutorials" / "index.md").write_text("# t\n\n```{toctree}\n\none\n```\n")
    for name in ("first.md", "new_page.md", "tutorials/one.md", "tutorials/two.md"):
        (docs / name).write_text("# p\n")
    assert vfrs_docs.unlisted_pages(docs) == ["new_page", "tutorials/two"]
    app = type("App", (), {"srcdir": str(docs)})()
    source = [(docs / "index.md").read_text()]
    vfrs_docs.add_unlisted(app, "index", source)
    assert source[0].endswith("```{toctree}\n:caption: More pages\n:maxdepth: 1\n\nnew_page\ntutorials/two\n```\n")


def test_the_bodies_and_obstacles_keys_are_read_from_the_scene_reader(monkeypatch):
    """[[bodies]]' and [[obstacles]]' own keys (read by hand, not through Params) are recorded from
    vfrs.scene's own readers at build time: every key of a body and its constraints and loads is
    listed, and a key the reader starts to read appears without any change to the generator."""
    from vfrs.scene import parse

    keys = scene_reference.read_keys()
    body = {row[0] for row in keys["bodies"]}
    assert {"`damping.a0`", "`mass`", "`velocity`", "`fixed[].components`", "`loads[].type`", "`loads[].value`"} <= body
    assert {row[0] for row in keys["obstacles"]} == {"`type`", "`name`", "`point`", "`normal`"}
    original = parse.read_body

    def reads_more(t, base_dir):
        t.number("stiffness_scale", 1.0, positive=True, what=" (a new key)")
        return original(t, base_dir)

    monkeypatch.setattr(parse, "read_body", reads_more)
    rows = scene_reference.read_keys()["bodies"]
    assert ("`stiffness_scale`", "number", "`1`", "", "> 0", "a new key") in rows
