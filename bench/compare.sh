#!/usr/bin/env bash
# Side-by-side comparison with the peers' harness (../shared/peers), in one run on one
# machine: sets up the peers' Python environment once, writes their seeded cases, fits
# them with every peer (single-threaded BLAS) and with fdid, and prints one table scored
# by the harness's own score(): relative RMS error against the noise-free truth, worst
# relative pole error, median fit time, and each peer's time as a multiple of fdid's.
#
#   bash bench/compare.sh            # PEERS_WORK defaults to $HOME/fdid-peers
#
# Not part of the test suite; needs network access to PyPI the first time.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
peers="${PEERS_DIR:-$here/../shared/peers}"
export PEERS_WORK="${PEERS_WORK:-$HOME/fdid-peers}"
mkdir -p "$PEERS_WORK"
py="$PEERS_WORK/.venv/bin/python"
[ -x "$py" ] || bash "$peers/setup.sh"
"$py" "$peers/make_cases.py" > /dev/null
OPENBLAS_NUM_THREADS=1 OMP_NUM_THREADS=1 "$py" "$peers/peers.py" -o results_1thread.json > /dev/null
cargo run --quiet --release --manifest-path "$here/Cargo.toml" --example peer_cases -- \
    "$PEERS_WORK/cases" "$PEERS_WORK/out-fdid"
"$py" "$here/bench/score_fdid.py" "$peers"
