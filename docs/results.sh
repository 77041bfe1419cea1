#!/usr/bin/env bash
# Re-runs the commands of docs/results.md and prints their output, section by
# section: `bash docs/results.sh` for every section that runs without root, or
# `bash docs/results.sh SECTION...` for chosen ones (the names are listed by
# `bash docs/results.sh --list`). It builds the release binary, writes the
# sample jobs to out/ (ignored by git) and changes nothing else. Compare wall
# times only on an idle machine; lengths, scallops and gouges do not depend on
# the load.
set -euo pipefail
cd "$(dirname "$0")/.."

SECTIONS=(suite heights candidates wing_mould acceptance trimmed step simulator mpec pockets belt surface_eval node ipc)
BIN=target/release/toolpath

if [ "${1:-}" = "--list" ]; then
  printf '%s\n' "${SECTIONS[@]}" dds_interfaces
  exit 0
fi

heading() { printf '\n## %s\n\n' "$*"; }
run() { printf '$ %s\n' "$*"; "$@"; }
timed() { # timed N CMD...: N runs of CMD under /usr/bin/time (wall, user, sys)
  local n=$1; shift
  printf '$ %s   (%s runs)\n' "$*" "$n"
  for _ in $(seq "$n"); do
    /usr/bin/time -f '%e s wall, %U s user, %S s sys' "$@" >/dev/null
  done
}

setup() {
  cargo build --release --bin toolpath
  mkdir -p out
  "$BIN" sample wing_mould --job -o out/wing.json
  "$BIN" sample leaf_pocket --job -o out/leaf.json
  "$BIN" sample die_saddle --job -o out/die.json
}

suite() {
  heading "Flat-end strategy suite"
  run "$BIN" compare --suite
}
heights() {
  heading "Other scallop heights"
  for h in 0.04 0.045 0.05 0.055 0.06; do
    run "$BIN" compare --suite --scallop "$h"
  done
}
candidates() {
  heading "Candidate plans over the suite"
  run cargo run --release --example suite_candidates -- \
    partitioned_as_traced,partitioned,whole_field,edge_offset_u
}
wing_mould() {
  heading "wing_mould"
  run "$BIN" compare --suite --only wing_mould
  timed 5 "$BIN" plan out/wing.json --no-verify --no-timing -o /dev/null
  timed 3 "$BIN" plan out/wing.json --no-timing -o out/wing_result.json
}
acceptance() {
  heading "Flat-end planners on other surfaces"
  run cargo test --release --test wing_mould -- --nocapture
}
trimmed() {
  heading "Trimmed faces"
  run cargo test --test trimmed_faces -- --nocapture
}
step() {
  heading "STEP samples"
  run python3 tests/python/step_sample_results.py "$BIN"
  run cargo test --test step_import mpec_plans -- --nocapture
}
simulator() {
  heading "Scallop simulator"
  "$BIN" plan out/wing.json --no-verify --no-timing -o out/wing_plan.json
  timed 5 "$BIN" verify out/wing.json out/wing_plan.json
  run cargo test --release --test scallop_accuracy -- --nocapture
}
mpec() {
  heading "MPEC"
  run "$BIN" plan out/die.json -o out/die_result.json
  run "$BIN" verify out/die.json out/die_result.json
  run "$BIN" compare out/die.json
  run cargo test -p toolpath_pipeline die_saddle_touches_its_band_within_the_slack -- --nocapture
  run cargo test --test poles mpec -- --nocapture
  run cargo bench --bench mpec
}
pockets() {
  heading "Pockets"
  run "$BIN" compare out/leaf.json
  run cargo test --test pocket_medial_axis -- --nocapture
  printf '$ %s   (7 runs, compute_ms)\n' "$BIN plan out/leaf.json --no-verify -o out/leaf_result.json"
  for _ in $(seq 7); do
    "$BIN" plan out/leaf.json --no-verify -o out/leaf_result.json
    python3 -c 'import json, sys; print(json.load(open(sys.argv[1]))["stats"]["compute_ms"], "ms")' out/leaf_result.json
  done
  if command -v perf >/dev/null; then
    run perf stat -r 10 -e task-clock "$BIN" plan out/leaf.json --no-verify --no-timing -o /dev/null
  fi
  run cargo bench --bench pocket_mat
}
belt() {
  heading "Belt grinding"
  run cargo test --test belt blade -- --nocapture
  run cargo test --test poles belt -- --nocapture
  run cargo bench --bench belt
}
surface_eval() {
  heading "Surface evaluation"
  run cargo bench --bench surface_eval
}
node() {
  heading "Node"
  run "$BIN" bench-node --jobs 200 --burst 100
  run "$BIN" bench-node --jobs 0 --burst 200 --bursts 5
  run cargo test --test node_soak -- --nocapture
}
ipc() {
  heading "Toolpath delivery: iceoryx2 against DDS"
  run cargo bench --bench ipc_vs_dds -- --quick
}
dds_interfaces() {
  heading "DDS on loopback, seen from a LAN peer (root)"
  run cargo test --test dds_interfaces -- --nocapture
}

chosen=("$@")
if [ ${#chosen[@]} -eq 0 ]; then
  chosen=("${SECTIONS[@]}")
fi
for s in "${chosen[@]}"; do
  case " ${SECTIONS[*]} dds_interfaces " in
    *" $s "*) ;;
    *) echo "unknown section: $s (bash docs/results.sh --list)" >&2; exit 2 ;;
  esac
done
setup
for s in "${chosen[@]}"; do
  "$s"
done
