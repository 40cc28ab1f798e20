"""Call overhead of the Python package over the Rust fit.

For FRFs of 100, 1 000 and 10 000 lines (a second-order system, 40 dB SNR, ML of orders
(2, 0)), the median over 200 calls (20 for 10 000 lines) of the whole `fdid.fit` call
and of `Fit.fit_seconds`, the estimation inside it; the overhead is the median of the
per-call differences
(argument checks, numpy conversions, the data's own checks, building the `Fit`: its
poles, zeros and saved model).

    python python/bench/overhead.py
"""

import statistics
import time

import numpy as np

import fdid


def main():
    rng = np.random.default_rng(1)
    print("| lines | whole call | Rust fit | overhead |")
    print("| --- | --- | --- | --- |")
    for n, calls in [(100, 200), (1000, 200), (10000, 50)]:
        f = np.linspace(0.01, 2.0, n)
        s = 2j * np.pi * f
        g = 4.0 / (s**2 + 0.4 * s + 4.0)
        g = g + 0.01 * np.abs(g) * (rng.standard_normal(n) + 1j * rng.standard_normal(n))
        whole, inner = [], []
        fdid.fit(f, g, domain="s", na=2, nb=0)  # warm-up
        for _ in range(calls):
            t = time.perf_counter()
            fit = fdid.fit(f, g, domain="s", na=2, nb=0)
            whole.append(time.perf_counter() - t)
            inner.append(fit.fit_seconds)
        w, i = statistics.median(whole), statistics.median(inner)
        d = statistics.median(a - b for a, b in zip(whole, inner))
        print(f"| {n} | {w * 1e6:.0f} µs | {i * 1e6:.0f} µs | {d * 1e6:.0f} µs |")


if __name__ == "__main__":
    main()
