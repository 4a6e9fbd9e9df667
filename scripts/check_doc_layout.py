"""Checks that the built site's pages fit a 1280 px window (issue 43): what made the scene
reference's tables overflow, read from the built HTML without a browser.

    python scripts/check_doc_layout.py docs/_build/html            # scripts/build_docs.sh runs this
    python scripts/check_doc_layout.py --browser docs/_build/html [page.html ...]

Without a browser it checks the two causes found with headless Chromium at 1280 px:
- an empty left sidebar ("Section Navigation" with no link) kept 25 % of the width, leaving the
  article 645 px: a page whose primary sidebar has no navigation link must have it hidden;
- the scene reference listed its keys in six-column tables of code that does not wrap (the
  description one word wide, the table scrolling): its keys are definition lists, no table, and
  no code literal longer than ``LONGEST_CODE`` characters (about 590 px in the theme's code font,
  under the narrowest article, 613 px).
``--browser`` measures instead: every table that scrolls sideways in Chromium
(``chromium --headless``, Debian's ``chromium`` package) at 1280 x 2000, page by page
(default: the scene reference). Prints nothing and exits 0 when everything fits.
"""

from __future__ import annotations

import html
import json
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

SCENE_PAGE = "reference/scene.html"
LONGEST_CODE = 70
SIDEBAR = re.compile(r'<div id="pst-primary-sidebar" class="([^"]*)">(.*?)<main ', re.S)


def sidebar_problem(page: str) -> str | None:
    """Why the page's primary sidebar wastes width (shown with no navigation link), or None."""
    m = SIDEBAR.search(page)
    if m is None or "hide-on-wide" in m.group(1):
        return None
    nav = m.group(2)
    if "bd-docs-nav" in nav and "<a " not in nav.split("bd-docs-nav", 1)[1]:
        return "an empty left sidebar (Section Navigation with no link) takes a quarter of the width"
    return None


def reference_problems(page: str) -> list:
    """What in the scene reference page would overflow: tables, or code literals too long to fit."""
    out = []
    article = page.split('<article class="bd-article"', 1)[-1].split("</article>", 1)[0]
    tables = article.count("<table")
    if tables:
        out.append(f"{tables} tables (the keys are definition lists: scene_reference.key_entry)")
    for code in re.findall(r'<code class="[^"]*literal[^"]*">(.*?)</code>', article, re.S):
        text = html.unescape(re.sub(r"<[^>]+>", "", code))
        if len(max(text.split() or [""], key=len)) > LONGEST_CODE:
            out.append(f"a code literal of {len(text)} characters without a space: {text[:50]}...")
    return out


def static_check(site: Path) -> list:
    """The browser-free check of every built page: lines ``page: problem``."""
    problems = []
    for path in sorted(site.rglob("*.html")):
        rel = path.relative_to(site).as_posix()
        if rel.startswith(("_static/", "_modules/", "_sources/")):
            continue
        page = path.read_text(encoding="utf-8")
        found = [sidebar_problem(page)] + (reference_problems(page) if rel == SCENE_PAGE else [])
        problems += [f"{rel}: {p}" for p in found if p]
    if not (site / SCENE_PAGE).is_file():
        problems.append(f"{SCENE_PAGE}: not built")
    return problems


MEASURE = """<script>window.addEventListener('load', () => {
  const r = [];
  document.querySelectorAll('.pst-scrollable-table-container').forEach(c => {
    if (c.scrollWidth > c.clientWidth + 1) r.push([c.scrollWidth - c.clientWidth, c.clientWidth,
      c.querySelector('tr') ? c.querySelector('tr').innerText.replace(/\\s+/g, ' ').slice(0, 60) : '']);
  });
  const out = document.createElement('pre'); out.id = 'VFRS_LAYOUT'; out.textContent = JSON.stringify(r);
  document.body.appendChild(out);
});</script>"""


def browser_check(site: Path, pages: list) -> list:
    """Tables that scroll sideways in headless Chromium at 1280 px, measured on copies of ``pages``."""
    chromium = shutil.which("chromium") or shutil.which("chromium-browser")
    if chromium is None:
        return ["--browser needs chromium (Debian: apt-get install chromium)"]
    problems = []
    with tempfile.TemporaryDirectory() as tmp:
        copy = Path(tmp) / "html"
        shutil.copytree(site, copy)
        for rel in pages:
            page = copy / rel
            page.write_text(page.read_text(encoding="utf-8").replace("</body>", MEASURE + "</body>"), encoding="utf-8")
            dom = subprocess.run([chromium, "--headless", "--no-sandbox", "--disable-gpu", "--window-size=1280,2000",
                                  "--virtual-time-budget=3000", "--dump-dom", page.as_uri()],
                                 capture_output=True, text=True, timeout=120).stdout
            m = re.search(r'<pre id="VFRS_LAYOUT"[^>]*>(.*?)</pre>', dom, re.S)
            if m is None:
                problems.append(f"{rel}: chromium gave no measurement")
                continue
            problems += [f"{rel}: a table {over} px wider than its {width} px column ({head})"
                         for over, width, head in json.loads(html.unescape(m.group(1)))]
    return problems


def main(argv: list) -> int:
    browser = "--browser" in argv
    args = [a for a in argv if a != "--browser"]
    site = Path(args[0]) if args else Path("docs/_build/html")
    problems = browser_check(site, args[1:] or [SCENE_PAGE]) if browser else static_check(site)
    for p in problems:
        print(f"layout: {p}", file=sys.stderr)
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
