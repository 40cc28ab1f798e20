"""Fitting 10 000 frequency responses on a dask.distributed cluster.

The pattern for channel counts that outgrow one machine: the FRFs are split into
batches, each task loads its batch where it runs (here it simulates it from the batch's
seed; in practice it reads its files), fits it with ``fdid.fit_many`` (which uses every
core of its worker through fdid's thread pool, with the GIL released), and only the
numbers that matter travel back (here the poles and the cost test's p-value; a whole model is
``Fit.to_json()``, which ``fdid.load`` reads back). On one machine
``LocalCluster`` starts the workers; on a cluster, pass the scheduler's address to
``Client`` instead.

    pip install "dask[distributed]" ./python
    python python/examples/dask_many.py            # 10 000 FRFs
    python python/examples/dask_many.py 2000       # fewer
"""

import sys
import time

import numpy as np

import fdid


def make_frfs(count, lines=400, seed=0):
    """`count` noisy FRFs of second-order systems with random resonance and damping,
    with the truth (natural frequency in rad/s, damping) of each."""
    rng = np.random.default_rng(seed)
    f = np.linspace(0.01, 2.0, lines)
    s = 2j * np.pi * f
    truth = np.column_stack([rng.uniform(1.0, 9.0, count), rng.uniform(0.02, 0.3, count)])
    frfs = []
    for wn, zeta in truth:
        g = wn**2 / (s**2 + 2 * zeta * wn * s + wn**2)
        noise = 0.01 * np.abs(g) * (rng.standard_normal(lines) + 1j * rng.standard_normal(lines)) / np.sqrt(2)
        frfs.append((f, g + noise, (0.01 * np.abs(g)) ** 2))
    return frfs, truth


def fit_batch(seed, count):
    """One task: the poles and cost-test p-value of every FRF of batch `seed`."""
    batch, _ = make_frfs(count, seed=seed)
    fits = fdid.fit_many(batch, domain="s", na=2, nb=0, errors="none")
    return [
        (None, None) if fit is None else (fit.poles, fit.validation["cost_p"])
        for fit in fits
    ]


def main():
    from dask.distributed import Client, LocalCluster

    count = int(sys.argv[1]) if len(sys.argv) > 1 else 10_000
    batch = 250
    sizes = [min(batch, count - i) for i in range(0, count, batch)]
    seeds = list(range(len(sizes)))
    with LocalCluster(processes=True) as cluster, Client(cluster) as client:
        workers = len(cluster.workers)
        started = time.perf_counter()
        futures = client.map(fit_batch, seeds, sizes)
        results = [r for part in client.gather(futures) for r in part]
        seconds = time.perf_counter() - started
    truth = np.vstack([make_frfs(n, seed=k)[1] for k, n in zip(seeds, sizes)])
    failed = sum(p is None for p, _ in results)
    wn = np.array([np.abs(p[0]) if p is not None else np.nan for p, _ in results])
    zeta = np.array([-p[0].real / np.abs(p[0]) if p is not None else np.nan for p, _ in results])
    pvals = np.array([np.nan if p is None else p for _, p in results], dtype=float)
    print(f"{count} FRFs in {seconds:.2f} s on {workers} workers ({failed} failed)")
    print(f"median |error| of the natural frequency {np.nanmedian(np.abs(wn - truth[:, 0]) / truth[:, 0]):.2e} (relative)")
    print(f"median |error| of the damping {np.nanmedian(np.abs(zeta - truth[:, 1])):.2e}")
    print(f"cost test p < 0.01 in {np.mean(pvals < 0.01) * 100:.1f} % of the fits (1 % expected)")


if __name__ == "__main__":
    main()
