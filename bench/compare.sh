#!/usr/bin/env bash
# Side-by-side comparison with the peers' harness (../shared/peers), in one run on one
# machine: sets up the peers' Python environment once, writes their seeded cases, fits
# them with every peer (single-threaded BLAS) and with fdid, and prints one table scored
# by the harness's own score(): relative RMS error against the noise-free truth, worst
# relative pole error, median fit time, and each peer's time as a multiple of fdid's.
#
#   bash bench/compare.sh            # PEERS_WORK defaults to $HOME/fdid-peers
#   RUST_PEERS=0 bash bench/compare.sh   # without the Rust peers (bench/rust-peers)
#
# The Rust peers (the crates dsmc and vecfit, in the separate cargo project
# bench/rust-peers, one thread) are fitted too unless RUST_PEERS=0, when that project
# builds (the first build takes a few minutes; its target dir is RUST_PEERS_TARGET_DIR,
# default bench/rust-peers/target). Not part of the test suite; needs network access to
# PyPI and crates.io the first time. The runs are bench/peers_run.sh's, which
# bench/perf_table.sh shares (it prints the README's performance table).
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
peers="${PEERS_DIR:-$here/../shared/peers}"
export PEERS_WORK="${PEERS_WORK:-$HOME/fdid-peers}"
bash "$here/bench/peers_run.sh"   # environment, cases, peers, fdid (library), Rust peers
py="$PEERS_WORK/.venv/bin/python"
"$py" "$here/bench/score_fdid.py" "$peers"
