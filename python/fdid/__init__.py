"""fdid: frequency-domain system identification.

Rational models in s or z, with a delay, fitted to a measured frequency response by
maximum likelihood (started by Levy and Sanathanan–Koerner iterations), with the
covariance of the estimate and the validation of the fit. The numerics run in Rust
(the ``fdid`` crate) with the GIL released.

    >>> import numpy as np, fdid
    >>> f = np.linspace(0.01, 2.0, 200)
    >>> s = 2j * np.pi * f
    >>> g = 4.0 / (s**2 + 0.4 * s + 4.0)
    >>> fit = fdid.fit(f, g, domain="s", na=2, nb=0)
    >>> np.sort_complex(fit.poles).round(6)
    array([-0.2-1.989975j, -0.2+1.989975j])
"""

from __future__ import annotations

import os
from typing import Optional, Tuple, Union

import numpy as np

from ._fdid import Fit, __version__, fit_frf, load_json

__all__ = ["Fit", "fit", "load", "from_network", "__version__"]


def _real_1d(name: str, a) -> np.ndarray:
    v = np.asarray(a)
    if v.ndim != 1:
        raise ValueError(f"{name} must be one-dimensional, got shape {v.shape}")
    if np.iscomplexobj(v):
        raise ValueError(f"{name} must be real, got dtype {v.dtype}")
    try:
        return np.ascontiguousarray(v, dtype=np.float64)
    except (TypeError, ValueError) as e:
        raise ValueError(f"{name} must be numbers: {e}") from None


def _complex_1d(name: str, a) -> np.ndarray:
    v = np.asarray(a)
    if v.ndim != 1:
        raise ValueError(f"{name} must be one-dimensional, got shape {v.shape}")
    try:
        return np.ascontiguousarray(v, dtype=np.complex128)
    except (TypeError, ValueError) as e:
        raise ValueError(f"{name} must be numbers: {e}") from None


def fit(
    f,
    frf,
    *,
    domain: str,
    na: int,
    nb: int,
    ts: Optional[float] = None,
    var=None,
    delay: bool = False,
    criterion: str = "ml",
    band: Optional[Tuple[float, float]] = None,
    stable: bool = False,
) -> Fit:
    """Fits G = B/A (times e^{-iωτ} with ``delay=True``) to a frequency response.

    Parameters
    ----------
    f : array_like, shape (N,)
        Frequencies (Hz), increasing.
    frf : array_like of complex, shape (N,)
        The measured frequency response G(f).
    domain : {"s", "z"}
        Continuous time (s) or discrete time (z, with ``ts``).
    na, nb : int
        Degrees of the denominator and numerator.
    ts : float, optional
        Sample time (s) of a discrete-time model.
    var : array_like, shape (N,), optional
        Noise variance of each line of ``frf``: the fit is weighted by it and its cost
        tested against it (``Fit.validation``).
    delay : bool
        Estimate a time delay τ jointly with G.
    criterion : {"ml", "levy", "sk", "tls"}
        Output-error maximum likelihood (started by Levy and SK), Levy's linear least
        squares, Sanathanan–Koerner iterations, or total least squares.
    band : (float, float), optional
        Fit only the lines with f in [lo, hi] Hz.
    stable : bool
        Constrain every pole to be stable.

    Returns
    -------
    Fit

    Raises
    ------
    ValueError
        Bad input (shapes, NaN or infinite values, too few lines for the orders, ...)
        or a fit that fails, with fdid's message.
    """
    f = _real_1d("f", f)
    frf = _complex_1d("frf", frf)
    if var is not None:
        var = _real_1d("var", var)
    if band is not None:
        band = (float(band[0]), float(band[1]))
    return fit_frf(
        f,
        frf,
        domain=domain,
        na=int(na),
        nb=int(nb),
        ts=None if ts is None else float(ts),
        var=var,
        delay=bool(delay),
        criterion=criterion,
        band=band,
        stable=bool(stable),
    )


def load(source: Union[str, os.PathLike]) -> Fit:
    """A model saved with ``Fit.to_json()`` or ``fdid fit --save``: a path to the file,
    or the JSON text itself."""
    text = os.fspath(source)
    if not text.lstrip().startswith("{"):
        with open(text, encoding="utf-8") as fh:
            text = fh.read()
    return load_json(text)


def from_network(network, port: Tuple[int, int] = (2, 1), **kwargs) -> Fit:
    """Fits one entry of a scikit-rf ``Network``: S[port] (1-based (output, input), as
    ``fdid fit --port 21``) against ``network.f`` (Hz). Keyword arguments go to
    :func:`fit`; the default is a continuous-time model."""
    i, j = port
    n = network.s.shape[1]
    if not (1 <= i <= n and 1 <= j <= n):
        raise ValueError(f"port {port} is outside the {n}-port network (1-based)")
    kwargs.setdefault("domain", "s")
    return fit(np.asarray(network.f), np.asarray(network.s[:, i - 1, j - 1]), **kwargs)
