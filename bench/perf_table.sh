#!/usr/bin/env bash
# The README's performance table, regenerated in one run on one machine: fdid and the
# peers side by side on the peers' seeded cases (../shared/peers), fdid both in the
# library (examples/peer_cases.rs, the fit alone, as the peers are timed) and as a whole
# process (the release binary `fdid fit CASE.fdid.csv ...`: start-up, CSV parse, fit,
# output; median of 11 runs after a warm-up). It runs bench/peers_run.sh (the peers'
# environment and cases, the Python peers single-threaded, fdid's library fits, the Rust
# peers unless RUST_PEERS=0), builds the fdid binary, then bench/perf_table.py, which
# scores fdid with the harness's score() (as bench/score_fdid.py does), times the whole
# process and prints one markdown table with a line giving the core count and the date.
#
#   bash bench/perf_table.sh                   # print the table
#   bash bench/perf_table.sh --write           # ... and replace it in README.md
#   RUST_PEERS=0 bash bench/perf_table.sh      # without the Rust peers (no `dsmc` column)
#
# --write replaces what lies between <!-- perf-table:begin --> and <!-- perf-table:end -->
# in README.md, only once every step has succeeded. PEERS_WORK (default $HOME/fdid-peers),
# PEERS_DIR and RUST_PEERS_TARGET_DIR as for bench/compare.sh; PERF_RUNS (default 11)
# timed whole-process runs per case; PERF_ROUNDS (default 5) rounds of scipy `oe` and
# fdid's library fit timed in turn (one after the other, case by case: both sides meet
# the machine in the same state). Not part of the test suite.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
peers="${PEERS_DIR:-$here/../shared/peers}"
export PEERS_WORK="${PEERS_WORK:-$HOME/fdid-peers}"

fail() { echo "bench/perf_table.sh: $*" >&2; exit 1; }
write=()
for arg in "$@"; do
    case "$arg" in
        --write) write=(--write "$here/README.md") ;;
        -h | --help) sed -n '2,21p' "${BASH_SOURCE[0]}" | sed 's/^# \{0,1\}//'; exit 0 ;;
        *) fail "unknown argument '$arg' (usage: bash bench/perf_table.sh [--write])" ;;
    esac
done
runs="${PERF_RUNS:-11}"
[[ "$runs" =~ ^[0-9]+$ ]] && [ "$runs" -ge 11 ] || fail "PERF_RUNS must be a whole number >= 11, not '$runs'"
if [ ${#write[@]} -gt 0 ]; then
    grep -q '<!-- perf-table:begin -->' "$here/README.md" && grep -q '<!-- perf-table:end -->' "$here/README.md" \
        || fail "README.md lacks the <!-- perf-table:begin --> / <!-- perf-table:end --> markers"
fi
command -v cargo > /dev/null || fail "cargo is not on PATH"

start=$SECONDS
bash "$here/bench/peers_run.sh"
py="$PEERS_WORK/.venv/bin/python"

cargo build --quiet --release --manifest-path "$here/Cargo.toml" --bin fdid
target="$(cargo metadata --format-version 1 --no-deps --manifest-path "$here/Cargo.toml" \
    | "$py" -c 'import json, sys; print(json.load(sys.stdin)["target_directory"])')"
fdid="$target/release/fdid"
[ -x "$fdid" ] || fail "no fdid binary at $fdid after cargo build --release"

# scipy `oe` and fdid's library fits timed in turn too (single-threaded BLAS, as
# bench/peers_run.sh times the Python peers)
OPENBLAS_NUM_THREADS=1 OMP_NUM_THREADS=1 "$py" "$here/bench/perf_table.py" "$peers" "$fdid" \
    --runs "$runs" --peer-cases "$target/release/examples/peer_cases" \
    --rounds "${PERF_ROUNDS:-5}" "${write[@]}"
echo "bench/perf_table.sh: $((SECONDS - start)) s" >&2
