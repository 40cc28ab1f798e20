#!/usr/bin/env bash
# The runs that bench/compare.sh and bench/perf_table.sh share, on one machine in one go:
# sets up the peers' Python environment once (../shared/peers/setup.sh into $PEERS_WORK),
# writes their seeded cases, fits them with every Python peer (single-threaded BLAS:
# $PEERS_WORK/results_1thread.json), fits them with fdid in the library
# (examples/peer_cases.rs: $PEERS_WORK/out-fdid) and, unless RUST_PEERS=0, with the Rust
# peers of bench/rust-peers (one thread: $PEERS_WORK/results_rs.json, their own table in
# $PEERS_WORK/rust_peers.txt). Prints nothing on stdout but the example's timings (stderr).
#
#   bash bench/peers_run.sh          # PEERS_WORK defaults to $HOME/fdid-peers
#
# PEERS_DIR (default ../shared/peers beside this repository) holds the harness;
# RUST_PEERS_TARGET_DIR (default bench/rust-peers/target) the Rust peers' build.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
peers="${PEERS_DIR:-$here/../shared/peers}"
export PEERS_WORK="${PEERS_WORK:-$HOME/fdid-peers}"

fail() { echo "bench/peers_run.sh: $*" >&2; exit 1; }
command -v cargo > /dev/null || fail "cargo is not on PATH"
for f in setup.sh make_cases.py peers.py; do
    [ -f "$peers/$f" ] || fail "the peers' harness is missing: no $peers/$f (set PEERS_DIR)"
done

mkdir -p "$PEERS_WORK"
py="$PEERS_WORK/.venv/bin/python"
if [ ! -x "$py" ]; then
    command -v python3 > /dev/null || fail "python3 is not on PATH: cannot create $PEERS_WORK/.venv"
    bash "$peers/setup.sh" || fail "$peers/setup.sh failed (it needs network access to PyPI)"
fi
[ -x "$py" ] || fail "no Python environment at $PEERS_WORK/.venv after $peers/setup.sh"
"$py" -c "import numpy, scipy" 2> /dev/null \
    || fail "$py lacks numpy or scipy: remove $PEERS_WORK/.venv and run again"

"$py" "$peers/make_cases.py" > /dev/null
OPENBLAS_NUM_THREADS=1 OMP_NUM_THREADS=1 "$py" "$peers/peers.py" -o results_1thread.json > /dev/null
[ -s "$PEERS_WORK/results_1thread.json" ] || fail "peers.py wrote no $PEERS_WORK/results_1thread.json"
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
