#!/usr/bin/env bash
# Every test of the repository, in one command on a fresh machine:
#   1. the Rust workspace's tests (`cargo test --workspace`: the core
#      library, the command line and the GPU back end; the Python crate is
#      selected only so that features resolve as in step 2, it has no Rust
#      tests);
#   2. the Python package's (python/): a virtual environment in .venv/
#      (created on first use; ignored by git) gets maturin, pytest, numpy,
#      trimesh and rtree, the extension is built into it with
#      `maturin develop` (the dev profile, equal to the test profile:
#      optimized, with debug assertions and overflow checks; it reuses every
#      artifact of step 1, see Cargo.toml and python/Cargo.toml) and pytest
#      runs python/tests.
# Environment: PYTHON picks the interpreter for the environment (python3).
set -euo pipefail
cd "$(dirname "$0")"

cargo test --workspace

PYTHON="${PYTHON:-python3}"
if [ ! -x .venv/bin/python ]; then
    "$PYTHON" -m venv .venv
fi
.venv/bin/python -m pip install -q --disable-pip-version-check -r python/requirements-test.txt
VIRTUAL_ENV="$PWD/.venv" PATH="$PWD/.venv/bin:$PATH" \
    .venv/bin/maturin develop -q -m python/Cargo.toml --profile dev
.venv/bin/python -m pytest -q python/tests
