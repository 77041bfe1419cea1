#!/usr/bin/env bash
# The whole test suite: Rust unit, integration and doc tests, then the Python tests.
set -euo pipefail
cd "$(dirname "$0")/.."
cargo test --locked
if ls tests/python/test_*.py >/dev/null 2>&1; then
  cargo build --locked --release --bin toolpath
  python3 -m pytest -q tests/python
fi
