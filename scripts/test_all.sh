#!/usr/bin/env bash
# Installs vfrs with its test and documentation extras and runs every check: Rust format, lints
# (warnings are errors) and tests, mypy on the package, pytest with the slow physics checks, then
# the documentation site (scripts/build_docs.sh: warnings are errors, gallery run, links and
# layout checked). The README's test command ("Two commands"); .ci/run runs exactly this script.
# A green run is quiet: the install, cargo and documentation steps keep their output in
# target/test-logs/*.log (scripts/quietly.sh) and print it only when they fail; mypy says
# Success, pytest prints its dots and counts.
set -euo pipefail
cd "$(dirname "$0")/.."
q=scripts/quietly.sh
$q install python -m pip install -e ".[test,docs]"
cargo fmt --all -- --check
$q clippy cargo clippy --workspace --all-targets -- -D warnings
$q cargo-test cargo test
python -m mypy python/vfrs
python -m pytest -q --runslow
$q docs scripts/build_docs.sh
