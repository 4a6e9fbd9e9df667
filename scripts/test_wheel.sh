#!/usr/bin/env bash
# Builds the wheel a package index accepts (manylinux2014 = glibc 2.17+, abi3 = one wheel for
# CPython 3.10 and later), installs it into a fresh virtual environment with no Rust toolchain
# on PATH, and runs the main job on the coarse mesh there.
#
#   scripts/test_wheel.sh                     # build with this python, test with it too
#   TEST_PYTHON=python3.12 scripts/test_wheel.sh   # test the abi3 wheel on another CPython
#
# Environment: PYTHON (builds; default python3), TEST_PYTHON (the fresh venv; default
# $PYTHON), CARGO_TARGET_DIR (default /tmp/vfrs-wheel-target: apart from the editable build),
# WHEEL_DIR (default dist/), WORK (scratch folder; default a new temporary one).
#
# The build needs cargo (rustup) and downloads maturin, ziglang and auditwheel into a build
# venv; zig links against glibc 2.17 symbols so the wheel runs on any manylinux2014 system.
set -euo pipefail
cd "$(dirname "$0")/.."
ROOT=$PWD
PYTHON=${PYTHON:-python3}
TEST_PYTHON=${TEST_PYTHON:-$PYTHON}
export CARGO_TARGET_DIR=${CARGO_TARGET_DIR:-/tmp/vfrs-wheel-target}
WHEEL_DIR=${WHEEL_DIR:-$ROOT/dist}
WORK=${WORK:-$(mktemp -d /tmp/vfrs-wheel-test.XXXXXX)}
mkdir -p "$WHEEL_DIR" "$WORK"

echo "== build venv: maturin, ziglang, auditwheel"
"$PYTHON" -m venv "$WORK/build-venv"
"$WORK/build-venv/bin/python" -m pip install -q --upgrade pip
"$WORK/build-venv/bin/python" -m pip install -q "maturin>=1.9.4,<2" ziglang auditwheel

echo "== maturin build --release --zig --compatibility manylinux2014"
rm -f "$WHEEL_DIR"/vfrs-*.whl
# maturin runs zig as `python -m ziglang`: the build venv's python first on PATH
PATH="$WORK/build-venv/bin:$PATH" maturin build --release --zig --compatibility manylinux2014 --out "$WHEEL_DIR"
WHEEL=$(ls "$WHEEL_DIR"/vfrs-*.whl)
echo "wheel: $(basename "$WHEEL")"
case "$(basename "$WHEEL")" in
  *-cp310-abi3-manylinux*_x86_64*.whl) ;;
  *) echo "not a manylinux abi3 wheel: $WHEEL" >&2; exit 1 ;;
esac

echo "== auditwheel show"
"$WORK/build-venv/bin/auditwheel" show "$WHEEL"

echo "== fresh venv ($("$TEST_PYTHON" --version)), no Rust toolchain on PATH"
"$TEST_PYTHON" -m venv "$WORK/test-venv"
CLEAN_PATH="$WORK/test-venv/bin:/usr/local/bin:/usr/bin:/bin"
# the environment as it is (pip's settings), minus Rust, PYTHONPATH and the build's PATH
env -u CARGO_TARGET_DIR -u CARGO_HOME -u RUSTUP_HOME -u RUSTUP_TOOLCHAIN -u PYTHONPATH -u VIRTUAL_ENV \
  PATH="$CLEAN_PATH" bash -c '
  set -euo pipefail
  if command -v cargo >/dev/null || command -v rustc >/dev/null; then echo "a Rust toolchain is on PATH" >&2; exit 1; fi
  echo "cargo: not on PATH; rustc: not on PATH"
  python -m pip install -q --upgrade pip
  python -m pip install -q "$1"
  cd "$2"   # away from the source tree: the installed package is what runs
  python -c "import vfrs, vfrs._core; print(\"vfrs from\", vfrs.__file__)"
  vfrs run "$3/examples/m5_collision.toml" --no-progress -o out \
    --set "bodies[0].mesh.resolution=\"coarse\"" --set "bodies[1].mesh.resolution=\"coarse\""
  vfrs plot out
  python -c "
import json
s = json.load(open(\"out/summary.json\"))
c = s[\"contact\"]
assert c[\"first_contact\"][\"value\"] is not None and c[\"peak_force.right\"][\"value\"] > 1e-3, c
assert abs(c[\"peak_force.right\"][\"value\"] - c[\"peak_force.left\"][\"value\"]) <= 1e-9 * c[\"peak_force.right\"][\"value\"]
print(\"wheel test passed: the folds collide (first contact %.2f ms, peak force %.1f mN, peak contact pressure %.2f kPa)\" % (
    c[\"first_contact\"][\"value\"] * 1e3, c[\"peak_force.right\"][\"value\"] * 1e3, c[\"peak_contact_pressure\"][\"value\"] * 1e-3))
"
' _ "$WHEEL" "$WORK" "$ROOT"
