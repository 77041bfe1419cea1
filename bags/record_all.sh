#!/usr/bin/env bash
# Re-records every golden bag from bags/jobs/*.json. Run it ON PURPOSE, when a
# change is meant to move toolpaths; review `git diff --stat bags/` and the
# replay diffs first (`toolpath replay bags/NAME --check` before re-recording).
# TOOLPATH_BIN=path/to/toolpath uses that binary instead of a release build.
# Every golden job must succeed: a job that fails is reported and the script
# exits non-zero (tests/golden_bags.rs checks it too). Jobs named executed_*
# are run through a node that executes them on a fake FollowJointTrajectory
# controller (`toolpath record --fake-execute`): the node's own recording.
set -euo pipefail
cd "$(dirname "$0")/.."
bin=${TOOLPATH_BIN:-}
if [ -z "$bin" ]; then
  cargo build --release --bin toolpath
  bin=target/release/toolpath
fi
failed=0
for job in bags/jobs/*.json; do
  name=$(basename "$job" .json)
  rm -rf "bags/$name"
  extra=()
  case "$name" in executed_*) extra=(--fake-execute) ;; esac
  if ! "$bin" record "$job" -o "bags/$name" --require-success "${extra[@]}"; then
    echo "error: golden job $name does not succeed: choose a feasible job or fix the planner" >&2
    failed=1
  fi
done
exit $failed
