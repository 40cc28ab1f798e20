#!/usr/bin/env python3
"""Scores the Rust peers' fits (bench/rust-peers, written to $PEERS_WORK/out-rs) with the
peers' own `score()` and writes them as $PEERS_WORK/results_rs.json, in the layout of
peers.py's results (cases -> name -> methods -> method -> rel_rms, pole_err, time_s, ...).

Usage: score_rs.py PEERS_DIR   (PEERS_WORK must point at the cases and out-rs)
Prints one line per fit; a method that failed or was skipped keeps its reason.
"""
import json
import os
import sys

import numpy as np

sys.path.insert(0, sys.argv[1])
import peers  # noqa: E402  (the harness: load_case, score)

WORK = os.environ["PEERS_WORK"]
OUT = os.path.join(WORK, "out-rs")


def score_case(name):
    case = peers.load_case(name)
    out = json.load(open(os.path.join(OUT, name + ".json")))
    omega = np.asarray(out["omega"])
    if omega.size != case["omega"].size or not np.allclose(omega, case["omega"], rtol=1e-12):
        raise SystemExit(f"{name}: the Rust peers' grid differs from the case's")
    methods = {}
    for m, r in out["methods"].items():
        if "frf" not in r:
            methods[m] = {k: v for k, v in r.items()}
            continue
        g = np.array([complex(re, im) for re, im in r["frf"]])
        fit = {"eval": lambda w, g=g: g, "poles": [complex(re, im) for re, im in r["poles"]]}
        s = peers.score(case, fit)
        s.update({"time_s": r["time_s"], "times_s": r["times_s"], "info": r["info"]})
        methods[m] = s
    return methods


def main():
    names = sorted(f[:-5] for f in os.listdir(OUT) if f.endswith(".json"))
    results = {"n_runs": 5, "cases": {n: {"methods": score_case(n)} for n in names}}
    with open(os.path.join(WORK, "results_rs.json"), "w") as f:
        json.dump(results, f, indent=1)
    print(f"{'case':12s} {'method':14s} {'rel_rms':>9s} {'pole_err':>9s} {'time_ms':>9s}  info")
    for n in names:
        for m, r in results["cases"][n]["methods"].items():
            if "time_s" in r:
                print(f"{n:12s} {m:14s} {r['rel_rms']:9.2e} {r['pole_err']:9.2e} "
                      f"{1e3 * r['time_s']:9.2f}  {json.dumps(r['info'])}")
            else:
                why = r.get("error") or r.get("skipped")
                print(f"{n:12s} {m:14s} {'-':>9s} {'-':>9s} {'-':>9s}  {why}")


if __name__ == "__main__":
    main()
