#!/usr/bin/env python3
"""Multiport common-pole fits: fdid against scikit-rf's VectorFitting, one run, one machine.

Two synthetic n-ports with poles shared by every entry (seeded, identical on every run):

  four   4 ports (16 entries), 50 poles (25 resonances), 200 log-spaced lines
  eight  8 ports (64 entries), 40 poles (20 resonances), 5 000 evenly spaced lines

Each is written as a version 1 Touchstone file (S, RI) with complex Gaussian noise of
standard deviation 1e-4 on every entry. scikit-rf fits it with VectorFitting (the same
number of poles, a constant term, its default initial poles and iterations); fdid runs as
a whole process, `fdid fit FILE --domain s --na N --nb N --json` (file reading, relaxed
vector fitting with the fast block solution, maximum likelihood, output). Both are scored
by the RMS error of the model against the data over every entry and line, and against the
noise-free truth. Times: the median of 3 runs (fdid: wall clock of the process;
scikit-rf: vector_fit() only, single-threaded BLAS). When the Python package is
installed in the same environment (`pip install ./python`), a second table times the
same fit as a library call, `fdid.fit_common_poles` on the arrays in memory, as
scikit-rf's fit alone is timed.

    ~/fdid-peers/.venv/bin/python bench/multiport.py      # after ../shared/peers/setup.sh
"""
import json
import os
import subprocess
import sys
import tempfile
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")
import numpy as np  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
FDID = os.environ.get("FDID", os.path.join(HERE, "..", "target", "release", "fdid"))
NOISE = 1e-4


def system(ports, pairs, f_lo, f_hi, seed):
    """Poles (one per pair) and residue matrices of a stable n-port."""
    rng = np.random.default_rng(seed)
    fn = np.exp(np.linspace(np.log(f_lo), np.log(f_hi), pairs)) * (1 + 0.1 * rng.uniform(-1, 1, pairs))
    zeta = rng.uniform(0.01, 0.08, pairs)
    w = 2 * np.pi * fn
    poles = -zeta * w + 1j * w * np.sqrt(1 - zeta**2)
    res = []
    for p in poles:
        r = rng.normal(size=(ports, ports)) + 1j * rng.normal(size=(ports, ports))
        r = 0.5 * (r + r.T)  # reciprocal
        res.append(r * abs(p.real) * 0.3 / ports)
    d = 0.1 * rng.normal(size=(ports, ports))
    return poles, res, 0.5 * (d + d.T)


def response(poles, res, d, f):
    s = 2j * np.pi * f
    g = np.repeat(d[None, :, :].astype(complex), len(f), axis=0)
    for p, r in zip(poles, res):
        g += r[None] / (s - p)[:, None, None] + r.conj()[None] / (s - p.conj())[:, None, None]
    return g


def write_touchstone(path, f, s):
    n = s.shape[1]
    with open(path, "w") as out:
        out.write("! synthetic %d-port with common poles\n# Hz S RI R 50\n" % n)
        for k, fk in enumerate(f):
            out.write("%.12e" % fk)
            for i in range(n):
                for j in range(n):
                    out.write(" %.15e %.15e" % (s[k, i, j].real, s[k, i, j].imag))
                    if n > 2 and (j + 1) % 4 == 0 and j + 1 < n:
                        out.write("\n")
                out.write("\n")


def rms(a, b):
    return float(np.sqrt(np.mean(np.abs(a - b) ** 2)))


def skrf_fit(path, f, s_noisy, s_true, n_pairs):
    import skrf
    from skrf.vectorFitting import VectorFitting

    nw = skrf.Network(path)
    times, fitted = [], None
    for _ in range(3):
        vf = VectorFitting(nw)
        t0 = time.perf_counter()
        vf.vector_fit(n_poles_real=0, n_poles_cmplx=n_pairs, fit_constant=True, fit_proportional=False)
        times.append(time.perf_counter() - t0)
        fitted = vf
    n = s_noisy.shape[1]
    model = np.zeros_like(s_noisy)
    for i in range(n):
        for j in range(n):
            model[:, i, j] = fitted.get_model_response(i, j, freqs=f)
    return float(np.median(times)), rms(model, s_noisy), rms(model, s_true)


def fdid_fit(path, f, s_noisy, s_true, order):
    times, out = [], None
    for _ in range(3):
        t0 = time.perf_counter()
        run = subprocess.run(
            [FDID, "fit", path, "--domain", "s", "--na", str(order), "--nb", str(order), "--json"],
            capture_output=True,
            text=True,
        )
        times.append(time.perf_counter() - t0)
        if run.returncode != 0:
            sys.exit("fdid failed: " + run.stderr)
        out = json.loads(run.stdout)
    n = s_noisy.shape[1]
    model = np.zeros_like(s_noisy)
    for e in out["entries"]:
        i, j = e["output"] - 1, e["input"] - 1
        frf = np.array(e["frf"])
        model[:, i, j] = frf[:, 1] + 1j * frf[:, 2]
    return float(np.median(times)), rms(model, s_noisy), rms(model, s_true)


def fdid_library_fit(f, s_noisy, s_true, order):
    """The same fit as a library call of the Python package on the arrays in memory (as
    scikit-rf is timed: the fit alone), or None when the package is not installed."""
    try:
        import fdid
    except ImportError:
        return None
    times, fit = [], None
    for _ in range(3):
        t0 = time.perf_counter()
        fit = fdid.fit_common_poles(f, s_noisy, domain="s", order=order, direct=True)
        times.append(time.perf_counter() - t0)
    model = fit.frf(f)
    return float(np.median(times)), rms(model, s_noisy), rms(model, s_true)


def main():
    cases = [
        ("four", 4, 25, 200, np.exp(np.linspace(np.log(1e7), np.log(2e10), 200)), 1),
        ("eight", 8, 20, 5000, np.linspace(1e7, 1.2e10, 5000), 2),
    ]
    rows, libraries = [], []
    with tempfile.TemporaryDirectory() as tmp:
        for name, ports, pairs, _lines, f, seed in cases:
            poles, res, d = system(ports, pairs, 1e8, 1e10, seed)
            s_true = response(poles, res, d, f)
            rng = np.random.default_rng(100 + seed)
            s_noisy = s_true + NOISE / np.sqrt(2) * (
                rng.normal(size=s_true.shape) + 1j * rng.normal(size=s_true.shape)
            )
            path = os.path.join(tmp, "%s.s%dp" % (name, ports))
            write_touchstone(path, f, s_noisy)
            t_f, e_f, t_f_true = fdid_fit(path, f, s_noisy, s_true, 2 * pairs)
            t_s, e_s, t_s_true = skrf_fit(path, f, s_noisy, s_true, pairs)
            library = fdid_library_fit(f, s_noisy, s_true, 2 * pairs)
            rows.append((name, ports * ports, 2 * pairs, len(f), t_f, e_f, t_f_true, t_s, e_s, t_s_true))
            if library is not None:
                libraries.append((name, *library, t_s))
    print("| case | entries | poles | lines | fdid s | fdid rms (data / truth) | skrf s | skrf rms (data / truth) | skrf / fdid time |")
    print("|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        print(
            "| %s | %d | %d | %d | %.3f | %.3e / %.3e | %.3f | %.3e / %.3e | %.1f× |"
            % (r[0], r[1], r[2], r[3], r[4], r[5], r[6], r[7], r[8], r[9], r[7] / r[4])
        )
    if libraries:
        print()
        print("| case | fdid library call (Python package) s | rms (data / truth) | skrf / fdid library time |")
        print("|---|---|---|---|")
        for name, t, e, e_true, t_s in libraries:
            print("| %s | %.4f | %.3e / %.3e | %.1f× |" % (name, t, e, e_true, t_s / t))
    print("noise standard deviation per entry: %.1e (a model at the noise floor has rms ≈ %.1e against the data)" % (NOISE, NOISE))


if __name__ == "__main__":
    main()
