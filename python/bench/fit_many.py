"""Scaling of fdid.fit_many with the threads: 1 000 FRFs (second-order systems of
random resonance and damping, 400 lines, 40 dB SNR, ML of orders (2, 0)), fitted with
RAYON_NUM_THREADS = 1, 2, ... up to the machine's cores, each in a fresh process (the
pool's size is fixed when it starts); the median of 3 runs, and the same 1 000 fits one
by one with fdid.fit in a Python loop.

    python python/bench/fit_many.py
"""

import os
import subprocess
import sys

RUN = r"""
import statistics, time
import numpy as np
import fdid
rng = np.random.default_rng(0)
f = np.linspace(0.01, 2.0, 400)
s = 2j * np.pi * f
sets = []
for _ in range(1000):
    wn, zeta = rng.uniform(1.0, 9.0), rng.uniform(0.02, 0.3)
    g = wn**2 / (s**2 + 2 * zeta * wn * s + wn**2)
    sets.append((f, g + 0.01 * np.abs(g) * (rng.standard_normal(f.size) + 1j * rng.standard_normal(f.size))))
times = []
for _ in range(3):
    t = time.perf_counter()
    fits = fdid.fit_many(sets, domain="s", na=2, nb=0)
    times.append(time.perf_counter() - t)
loop = []
for _ in range(3):
    t = time.perf_counter()
    for fk, gk in sets:
        fdid.fit(fk, gk, domain="s", na=2, nb=0)
    loop.append(time.perf_counter() - t)
print(statistics.median(times), statistics.median(loop))
"""


def main():
    cores = os.cpu_count() or 1
    print("| threads | fit_many, 1 000 FRFs | speed-up | loop of fdid.fit |")
    print("| --- | --- | --- | --- |")
    base = None
    for threads in range(1, cores + 1):
        env = dict(os.environ, RAYON_NUM_THREADS=str(threads))
        out = subprocess.run([sys.executable, "-c", RUN], env=env, check=True, capture_output=True, text=True)
        many, loop = (float(v) for v in out.stdout.split())
        base = base or many
        print(f"| {threads} | {many:.3f} s | {base / many:.2f}× | {loop:.3f} s |")


if __name__ == "__main__":
    main()
