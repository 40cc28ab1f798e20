#!/usr/bin/env python3
"""Scores fdid's fits of the peers' cases with the peers' own `score()` and prints one
table beside the peers' results (from the same machine, written by peers.py), and beside
the Rust peers' (written by score_rs.py) when $PEERS_WORK/results_rs.json exists.

Usage: score_fdid.py PEERS_DIR   (PEERS_WORK must point at the cases and results)
bench/perf_table.py imports it (with the same PEERS_DIR argument) for the README's table.
"""
import json
import os
import sys

import numpy as np

sys.path.insert(0, sys.argv[1])
import peers  # noqa: E402  (the harness: load_case, score)

WORK = os.environ["PEERS_WORK"]
OUT = os.path.join(WORK, "out-fdid")
PEER_RESULTS = os.path.join(WORK, "results_1thread.json")
RUST_RESULTS = os.path.join(WORK, "results_rs.json")


def fdid_result(name):
    case = peers.load_case(name)
    out = json.load(open(os.path.join(OUT, name + ".json")))
    omega = np.asarray(out["omega"])
    g = np.array([complex(re, im) for re, im in out["frf"]])
    if omega.size != case["omega"].size or not np.allclose(omega, case["omega"], rtol=1e-12):
        raise SystemExit(f"{name}: fdid's grid differs from the case's")
    fit = {"eval": lambda w: g, "poles": [complex(re, im) for re, im in out["poles"]]}
    r = peers.score(case, fit)
    r["time_s"] = out["time_s"]
    return r


def load_results(path):
    """The `cases` of a results file in peers.py's layout, {} when it does not exist."""
    return json.load(open(path))["cases"] if os.path.exists(path) else {}


def case_names():
    """The cases fdid fitted (examples/peer_cases.rs wrote one JSON each)."""
    return sorted(f[:-5] for f in os.listdir(OUT) if f.endswith(".json"))


def main():
    theirs, rust = load_results(PEER_RESULTS), load_results(RUST_RESULTS)
    names = case_names()
    print(f"{'case':12s} {'method':14s} {'rel_rms':>9s} {'pole_err':>9s} {'time_ms':>9s} {'fdid x':>7s}")
    for name in names:
        ours = fdid_result(name)
        rows = [("fdid", ours)] + [
            (m, r)
            for results in (theirs, rust)
            for m, r in results.get(name, {}).get("methods", {}).items()
            if "time_s" in r
        ]
        for m, r in rows:
            ratio = r["time_s"] / ours["time_s"]
            print(f"{name:12s} {m:14s} {r['rel_rms']:9.2e} {r['pole_err']:9.2e} "
                  f"{1e3 * r['time_s']:9.2f} {ratio:7.1f}")


if __name__ == "__main__":
    main()
