#!/usr/bin/env bash
# Re-records every golden bag from bags/jobs/*.json. Run it ON PURPOSE, when a change
# is meant to move toolpaths; review `git diff --stat bags/` and the replay diffs first.
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release --bin toolpath
for job in bags/jobs/*.json; do
  name=$(basename "$job" .json)
  rm -rf "bags/$name"
  target/release/toolpath record "$job" -o "bags/$name"
done
