#!/usr/bin/env bash
# The whole test suite: installs what the tests need (.ci/install, quick when
# it is all there), then Rust unit, integration and doc tests (the DDS Security test with the
# `security` feature), then the Python tests.
set -euo pipefail
cd "$(dirname "$0")/.."
bash .ci/install
cargo test --locked
if ls tests/python/test_*.py >/dev/null 2>&1; then
  # `cargo test` has just built target/debug/toolpath for the integration tests (dependencies
  # at opt-level 3, this crate at 1): the Python tests drive that binary, which spares CI a
  # second build of the stack (a plain `cargo build` resolves other dependency features).
  TOOLPATH_BIN="${TOOLPATH_BIN:-$PWD/target/debug/toolpath}" "$(bash .ci/python)" -m pytest -q tests/python
fi
# DDS Security through the node (tests/node_secure.rs) needs the `security` feature, which
# rebuilds RustDDS, ros2-client and this crate once more with the security plugins (OpenSSL).
# Last: it rebuilds target/debug/toolpath with security, and the Python tests above drive the
# default build.
cargo test --locked --features security --test node_secure
