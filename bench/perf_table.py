#!/usr/bin/env python3
"""The README's performance table: fdid beside the peers on the peers' cases, from the
results of one run of bench/peers_run.sh (the Python peers in $PEERS_WORK/results_1thread.json,
fdid's library fits in $PEERS_WORK/out-fdid, the Rust peers in $PEERS_WORK/results_rs.json
when they ran), plus fdid timed as a whole process: the release binary `fdid fit
CASE.fdid.csv ...` (start-up, CSV parse, fit, output) on each case, median of --runs runs
after a warm-up. fdid's fits are scored with the harness's score() through score_fdid.py.

Before timing a command it runs it once with --json and scores that fit too: the script
stops if its poles or its response are far from the library's fit of the same case.

With --peer-cases (the examples/peer_cases binary) it also times scipy `oe` and fdid's
library fit of each case in turn, --rounds times (each side the median of 5 fits after a
warm-up, as the harness times): both sides then meet the machine in the same state, and
the table gives the median and the range of the rounds' ratios beside the ratio of the
two separate runs.

Usage: perf_table.py PEERS_DIR FDID_BIN [--runs N] [--peer-cases BIN [--rounds R]]
       [--write README.md]
(PEERS_WORK must point at the cases and results; driven by bench/perf_table.sh)
"""
import argparse
import datetime
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import textwrap
import time

import numpy as np

BEGIN, END = "<!-- perf-table:begin -->", "<!-- perf-table:end -->"


def fail(msg):
    sys.exit(f"bench/perf_table.py: {msg}")


def parse_args():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("peers_dir", help="the peers' harness (peers.py)")
    p.add_argument("fdid", help="the fdid release binary")
    p.add_argument("--runs", type=int, default=11, help="timed whole-process runs per case")
    p.add_argument("--write", metavar="README", help="replace the table between the markers")
    p.add_argument("--peer-cases", metavar="BIN",
                   help="examples/peer_cases: time scipy oe and fdid's library fit in turn")
    p.add_argument("--rounds", type=int, default=5, help="rounds of the timing in turn")
    a = p.parse_args()
    if a.runs < 1:
        fail("--runs must be at least 1")
    if a.rounds < 1:
        fail("--rounds must be at least 1")
    return a


ARGS = parse_args()
if "PEERS_WORK" not in os.environ:
    fail("PEERS_WORK must point at the peers' cases and results (bench/perf_table.sh sets it)")
sys.path.insert(0, ARGS.peers_dir)
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import peers  # noqa: E402  (the harness: load_case, score)
import score_fdid  # noqa: E402  (fdid's library fits scored as compare.sh does)

CASES = os.path.join(score_fdid.WORK, "cases")


def fit_command(name, meta):
    """`fdid fit` on the case's fdid CSV with what examples/peer_cases.rs fits: the true
    orders; a time record averaged over its P periods on the band of its excited lines.
    The delay of a delayed case is estimated (--delay), where the library and the peers
    are given it."""
    args = [f"{name}.fdid.csv", "--domain", "s" if meta["domain"] == "ct" else "z"]
    if meta["domain"] == "dt" and meta["kind"] == "frf":
        args += ["--ts", f"{meta['Ts']:g}"]
    args += ["--na", str(meta["na"]), "--nb", str(meta["nb"])]
    if meta["kind"] == "time":
        n, ts = meta["N"], meta.get("Ts") or 1.0
        k0, k1 = meta["excited_lines"]
        args += ["--periods", str(meta["P"]),
                 "--band", f"{(k0 - 0.5) / (n * ts)!r}:{(k1 + 0.5) / (n * ts)!r}"]
    elif meta["kind"] != "frf":
        fail(f"{name}: unknown kind of case {meta['kind']!r}")
    if meta.get("delay_samples"):
        args.append("--delay")
    return args


def run(cmd, env):
    r = subprocess.run(cmd, cwd=CASES, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    if r.returncode != 0:
        fail(f"`{' '.join(cmd[1:])}` (in {CASES}) exited with {r.returncode}:\n"
             + r.stderr.decode(errors="replace"))
    return r.stdout


def check_whole_process(name, cmd, env, library):
    """Runs the command once with --json, scores its fit against the truth, and stops
    unless it is about as good as the library's fit of the case."""
    out = json.loads(run(cmd + ["--json"], env))
    case = peers.load_case(name)
    ts = case["meta"].get("Ts") or 1.0
    f = np.array([row[0] for row in out["frf"]])
    g = np.array([complex(row[1], row[2]) for row in out["frf"]])
    omega = 2 * np.pi * f * (ts if case["domain"] == "dt" else 1.0)
    if omega.size != case["omega"].size or not np.allclose(omega, case["omega"], rtol=1e-9):
        fail(f"{name}: `fdid fit` fitted {omega.size} lines, the case has {case['omega'].size}")
    if case["delay"]:  # score() applies the case's delay; the fitted response has its own
        g = g * np.exp(1j * case["omega"] * case["delay"])
    r = peers.score(case, {"eval": lambda w: g, "poles": [complex(*p) for p in out["poles"]]})
    bad = (r["rel_rms"] > 1.5 * library["rel_rms"]
           or r["pole_err"] > max(3 * library["pole_err"], 1e-3))
    print(f"{name}: whole process fit rel_rms {r['rel_rms']:.3e}, pole_err {r['pole_err']:.3e} "
          f"(library {library['rel_rms']:.3e}, {library['pole_err']:.3e})", file=sys.stderr)
    if bad:
        fail(f"{name}: the fit of `{' '.join(cmd[1:])}` is far from the library's")
    return r


def time_whole_process(cmd, env, runs):
    run(cmd, env)  # warm-up (page cache, binary loaded)
    times = []
    for _ in range(runs):
        t0 = time.perf_counter()
        r = subprocess.run(cmd, cwd=CASES, env=env, stdout=subprocess.DEVNULL,
                           stderr=subprocess.DEVNULL)
        times.append(time.perf_counter() - t0)
        if r.returncode != 0:
            fail(f"`{' '.join(cmd[1:])}` exited with {r.returncode} in a timed run")
    return statistics.median(times), times


def in_turn(names, peer_cases, rounds, env):
    """Each case's scipy `oe` fit (the harness's run_one: median of 5 after a warm-up) and
    fdid's library fit (peer_cases for that case: the same) timed one after the other,
    `rounds` times: the ratio oe / fdid of each round, per case."""
    out = tempfile.mkdtemp(prefix="fdid-in-turn-")
    ratios = {name: [] for name in names}
    try:
        for k in range(rounds):
            for name in names:
                oe = peers.run_one(peers.METHODS["oe"], peers.load_case(name))["time_s"]
                r = subprocess.run([peer_cases, CASES, out], env=dict(env, PEER_CASE=name),
                                   stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
                if r.returncode != 0:
                    fail(f"{peer_cases} on {name} exited with {r.returncode}:\n"
                         + r.stderr.decode(errors="replace"))
                lib = json.load(open(os.path.join(out, name + ".json")))["time_s"]
                ratios[name].append(oe / lib)
                print(f"{name}: round {k + 1}: oe {ms(oe)} ms, fdid {ms(lib)} ms, "
                      f"{oe / lib:.1f}×", file=sys.stderr)
    finally:
        shutil.rmtree(out, ignore_errors=True)
    return ratios


def ms(t):
    """Milliseconds to three significant figures, without an exponent."""
    x = 1e3 * t
    for limit, digits in ((1, 3), (10, 2), (100, 1)):
        if round(x, digits) < limit:
            return f"{x:.{digits}f}"
    return f"{round(x):,}".replace(",", " ")


def sci(x):
    """2.98·10⁻⁴"""
    mantissa, exp = f"{x:.2e}".split("e")
    sup = str.maketrans("-0123456789", "⁻⁰¹²³⁴⁵⁶⁷⁸⁹")
    return f"{mantissa}·10{str(int(exp)).translate(sup)}"


def grouped(n):
    return f"{n:,}".replace(",", " ")


def label(name, meta):
    if meta["kind"] == "time":
        return f"`{name}` (order {meta['na']}, {meta['P']} periods × {grouped(meta['N'])})"
    extra = ", delay given; estimated in the whole process" if meta.get("delay_samples") else ""
    return f"`{name}` (order {meta['na']}, {grouped(meta['n_lines'])} lines{extra})"


def main():
    if not os.access(ARGS.fdid, os.X_OK):
        fail(f"no fdid binary at {ARGS.fdid}")
    theirs = score_fdid.load_results(score_fdid.PEER_RESULTS)
    rust = score_fdid.load_results(score_fdid.RUST_RESULTS)
    if not theirs:
        fail(f"no peers' results at {score_fdid.PEER_RESULTS}: run bench/peers_run.sh")
    names = score_fdid.case_names()
    if not names:
        fail(f"no fdid fits in {score_fdid.OUT}: run bench/peers_run.sh")
    env = dict(os.environ, RAYON_NUM_THREADS="1")
    turns = None
    if ARGS.peer_cases:
        if not os.access(ARGS.peer_cases, os.X_OK):
            fail(f"no peer_cases binary at {ARGS.peer_cases}")
        turns = in_turn(names, ARGS.peer_cases, ARGS.rounds, env)
    rows, lib_runs = [], set()
    for name in names:
        meta = json.load(open(os.path.join(CASES, name + ".json")))
        lib = score_fdid.fdid_result(name)
        lib_runs.add(len(json.load(open(os.path.join(score_fdid.OUT, name + ".json")))["times_s"]))
        oe = theirs.get(name, {}).get("methods", {}).get("oe")
        if oe is None or "time_s" not in oe:
            why = (oe or {}).get("error", "not in the results")
            fail(f"{name}: the scipy oe peer has no result ({why})")
        cmd = [os.path.abspath(ARGS.fdid), "fit"] + fit_command(name, meta)
        check_whole_process(name, cmd, env, lib)
        whole, times = time_whole_process(cmd, env, ARGS.runs)
        print(f"{name}: `fdid {' '.join(cmd[1:])}` median {ms(whole)} ms of {ARGS.runs} runs "
              f"({ms(min(times))}–{ms(max(times))} ms)", file=sys.stderr)
        row = [label(name, meta), ms(lib["time_s"]), ms(whole), ms(oe["time_s"]),
               f"{oe['time_s'] / lib['time_s']:.1f}×"]
        if turns:
            rs = turns[name]
            row.append(f"{statistics.median(rs):.1f}× ({min(rs):.1f}–{max(rs):.1f}×)")
        if rust:
            sk = rust.get(name, {}).get("methods", {}).get("dsmc_sk", {})
            row.append(ms(sk["time_s"]) if "time_s" in sk else "–")
        row.append(f"{sci(lib['rel_rms'])} / {sci(oe['rel_rms'])}")
        rows.append(row)

    head = ["case", "fdid library (ms)", "fdid whole process (ms)", "scipy `oe` (ms)",
            "`oe` ÷ fdid library"] + ([f"`oe` ÷ fdid library in turn ({ARGS.rounds} rounds)"]
                                       if turns else []) \
        + (["`dsmc` SK (ms)"] if rust else []) + ["rel_rms fdid / oe"]
    peer_runs = json.load(open(score_fdid.PEER_RESULTS)).get("n_runs", "?")
    lib_n = "/".join(str(n) for n in sorted(lib_runs))
    rust_note = " and `dsmc`" if rust else ""
    intro = (f"Generated by `bash bench/perf_table.sh` on {datetime.date.today().isoformat()}, "
             f"{os.cpu_count()} cores, one thread per fit: medians of {lib_n} fits after a warm-up "
             f"for fdid's library, of {peer_runs} for scipy `oe`{rust_note}, "
             f"of {ARGS.runs} runs after a warm-up for the whole process."
             + (f" In turn: each case's `oe` and fdid library timings one after the other, "
                f"{ARGS.rounds} rounds; the median ratio and its range." if turns else ""))
    intro = textwrap.fill(intro, 88, break_on_hyphens=False, break_long_words=False)
    lines = [intro, "", "| " + " | ".join(head) + " |", "|" + " --- |" * len(head)]
    lines += ["| " + " | ".join(r) + " |" for r in rows]
    table = "\n".join(lines)
    print(table)

    if ARGS.write:
        text = open(ARGS.write, encoding="utf-8").read()
        if text.count(BEGIN) != 1 or text.count(END) != 1 or text.index(BEGIN) > text.index(END):
            fail(f"{ARGS.write} needs one {BEGIN} followed by one {END}")
        before, rest = text.split(BEGIN)
        after = rest.split(END)[1]
        tmp = ARGS.write + ".tmp"
        with open(tmp, "w", encoding="utf-8") as f:
            f.write(f"{before}{BEGIN}\n\n{table}\n\n{END}{after}")
        os.replace(tmp, ARGS.write)
        print(f"{ARGS.write}: table written", file=sys.stderr)


if __name__ == "__main__":
    main()
