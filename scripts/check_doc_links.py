#!/usr/bin/env python
"""Checks the internal links of the built documentation site, offline.

Every ``href`` and ``src`` in the HTML pages under the build folder (default
docs/_build/html) that is not an external address must name a file of the build, and an
``#anchor`` must be an ``id`` of the page it points into. Sphinx's ``-n`` checks the
cross-references and MyST the Markdown links between pages and their heading anchors while
the site is built; this catches what gets past them (raw HTML, gallery pages, theme links).
``linkcheck`` would need the network.

    python scripts/check_doc_links.py [BUILD_DIR]

Prints each broken link as ``page: target (why)`` and exits 1 if there is any.
"""

from __future__ import annotations

import sys
from html.parser import HTMLParser
from pathlib import Path
from urllib.parse import unquote, urlsplit


class _Page(HTMLParser):
    def __init__(self):
        super().__init__(convert_charrefs=True)
        self.ids: set = set()
        self.links: list = []

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if a.get("id"):
            self.ids.add(a["id"])
        if tag == "a" and a.get("name"):
            self.ids.add(a["name"])
        for key in ("href", "src"):
            if a.get(key) and not (tag == "link" and key == "href" and a.get("rel") == "preconnect"):
                self.links.append(a[key])


def _parse(path: Path) -> _Page:
    p = _Page()
    p.feed(path.read_text(encoding="utf-8", errors="replace"))
    return p


def broken_links(build: Path) -> list:
    """(page, link, why) for every internal link of ``build`` that does not resolve."""
    # _static holds the theme's templates (their links are Jinja), not pages
    pages = {p.resolve(): _parse(p) for p in build.rglob("*.html") if "_static" not in p.relative_to(build).parts}
    out = []
    for page, parsed in sorted(pages.items()):
        for link in parsed.links:
            parts = urlsplit(link)
            if parts.scheme or parts.netloc or link.startswith(("mailto:", "javascript:", "data:")):
                continue  # external: not checked offline
            target = page if not parts.path else (page.parent / unquote(parts.path)).resolve()
            if target.is_dir():
                target = target / "index.html"
            rel = page.relative_to(build.resolve())
            if not target.exists():
                out.append((str(rel), link, "no such file"))
                continue
            if parts.fragment and target.suffix == ".html":
                ids = pages[target].ids if target in pages else _parse(target).ids
                if unquote(parts.fragment) not in ids:
                    out.append((str(rel), link, "no such anchor"))
    return out


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    build = Path(argv[0] if argv else "docs/_build/html")
    if not (build / "index.html").exists():
        print(f"{build}: no built site (index.html missing); build it first", file=sys.stderr)
        return 2
    bad = broken_links(build)
    for page, link, why in bad:
        print(f"{page}: {link} ({why})")
    n = len([p for p in build.rglob("*.html") if "_static" not in p.relative_to(build).parts])
    print(f"checked the internal links of {n} pages: {len(bad)} broken", file=sys.stderr)
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
