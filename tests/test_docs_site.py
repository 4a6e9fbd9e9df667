"""The documentation site's generated pages (issue 35): the scene file reference is read from
the registries at build time, so it cannot drift from the code; the verification page links
test files that exist. (The site itself is built by scripts/build_docs.sh in .ci/run.)"""

import dataclasses
import re
import sys
import typing
from dataclasses import dataclass
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
DOCS = ROOT / "docs"
sys.path.insert(0, str(DOCS / "_ext"))

import scene_reference  # noqa: E402  (docs/_ext: the generator, kept outside the package)
import vfrs_docs  # noqa: E402

from vfrs.params import param, param_keys  # noqa: E402


def _field(cls, name):
    return {f.name: f for f in dataclasses.fields(cls)}[name]


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
                    assert f"| `{k}` |" in text, f"{kind} {name!r}: key {k!r} is not in the reference"
                    checked += 1
    for name in regs["schemes"]:
        assert f"| `{name}` |" in text
    from vfrs.enforcement.effect import ContactParams

    for key in param_keys(ContactParams):
        assert f"| `{key}` |" in text
    assert checked > 100  # the walk reached the registries' keys, not an empty page


def test_a_changed_default_changes_the_page(monkeypatch):
    from vfrs.enforcement import METHODS

    growth = _field(METHODS["augmented_lagrange"].Params, "growth")
    row = re.compile(r"^\| `growth` \| number \| `([^`]*)` \|", re.M)
    before = row.search(scene_reference.scene_reference())
    assert before and before.group(1) == f"{growth.default:g}"
    monkeypatch.setattr(growth, "default", 12.5)
    assert row.search(scene_reference.scene_reference()).group(1) == "12.5"
    # and a changed unit and range, from param()'s metadata
    monkeypatch.setattr(growth, "metadata", {**growth.metadata, "unit": "furlong", "low": 2.0})
    line = next(x for x in scene_reference.scene_reference().splitlines() if x.startswith("| `growth` |"))
    assert "| furlong | [2, 1e+06] |" in line


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
    assert "| `speed` | number | `2.5` | m/s | > 0 | wind speed |" in text
    assert "| `gust` | string | `\"none\"` |  | one of `none`, `some` | gusts |" in text
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


def test_ci_runs_the_readme_command_and_it_builds_the_site():
    readme = [line for line in (ROOT / "README.md").read_text().splitlines()
              if line.startswith('python -m pip install -e ".[')]
    ci = [line for line in (ROOT / ".ci" / "run").read_text().splitlines() if line.startswith("python -m pip")]
    assert len(readme) == 1 and ci == readme
    assert ".[test,docs]" in readme[0] and readme[0].endswith("&& scripts/build_docs.sh")
    assert (ROOT / "scripts" / "build_docs.sh").stat().st_mode & 0o111


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
    import vfrs.scene as scene

    keys = scene_reference.read_keys()
    body = {row[0] for row in keys["bodies"]}
    assert {"`damping.a0`", "`mass`", "`velocity`", "`fixed[].components`", "`loads[].type`", "`loads[].value`"} <= body
    assert {row[0] for row in keys["obstacles"]} == {"`type`", "`name`", "`point`", "`normal`"}
    original = scene._body

    def reads_more(t, base_dir):
        t.number("stiffness_scale", 1.0, positive=True, what=" (a new key)")
        return original(t, base_dir)

    monkeypatch.setattr(scene, "_body", reads_more)
    rows = scene_reference.read_keys()["bodies"]
    assert ("`stiffness_scale`", "number", "`1`", "", "> 0", "a new key") in rows
