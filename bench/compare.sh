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
# PyPI and crates.io the first time.
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
rm -f "$PEERS_WORK/results_rs.json"
if [ "${RUST_PEERS:-1}" != 0 ]; then
    rs="$here/bench/rust-peers"
    export RAYON_NUM_THREADS=1
    if CARGO_TARGET_DIR="${RUST_PEERS_TARGET_DIR:-$rs/target}" \
        cargo build --quiet --release --manifest-path "$rs/Cargo.toml"; then
        CARGO_TARGET_DIR="${RUST_PEERS_TARGET_DIR:-$rs/target}" \
            cargo run --quiet --release --manifest-path "$rs/Cargo.toml" 2> /dev/null
        # its own table (with the reasons of any failed or skipped fit) goes to a file
        "$py" "$here/bench/score_rs.py" "$peers" > "$PEERS_WORK/rust_peers.txt"
    else
        echo "bench/rust-peers does not build: the table leaves the Rust peers out" >&2
    fi
fi
"$py" "$here/bench/score_fdid.py" "$peers"
