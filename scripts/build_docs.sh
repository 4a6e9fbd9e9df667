#!/usr/bin/env bash
# Builds the documentation site into docs/_build/html: every Sphinx warning is an error, every
# cross-reference is checked (-n), the gallery scripts run (docs/gallery/plot_*.py), then the
# internal links and anchors of the built pages are checked offline (scripts/check_doc_links.py),
# and what made pages overflow a 1280 px window (scripts/check_doc_layout.py, no browser needed).
# Extra arguments go to sphinx-build, e.g. `scripts/build_docs.sh -D plot_gallery=0` (no gallery).
# Needs the docs extra: python -m pip install -e ".[docs]"
set -euo pipefail
cd "$(dirname "$0")/.."
python -m sphinx -W --keep-going -n -b html "$@" docs docs/_build/html
python scripts/check_doc_links.py docs/_build/html
python scripts/check_doc_layout.py docs/_build/html
