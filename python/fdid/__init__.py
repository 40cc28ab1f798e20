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
from typing import List, Optional, Tuple, Union

import numpy as np

from ._fdid import CommonPoleFit, Fit, __version__, fit_frf, load_json
from ._fdid import fit_common_poles_py as _fit_common_poles
from ._fdid import diagnose as _diagnose
from ._fdid import fit_many as _fit_many
from ._fdid import fit_record as _fit_record
from ._fdid import fit_spectra as _fit_spectra
from ._fdid import ltv as _ltv

__all__ = [
    "Fit",
    "CommonPoleFit",
    "fit_common_poles",
    "fit",
    "fit_spectra",
    "fit_record",
    "fit_many",
    "diagnose",
    "ltv",
    "load",
    "from_network",
    "__version__",
]


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
    return fit_frf(f, frf, var, _band(band), _model(domain, na, nb, ts, delay, criterion, stable))


def fit_spectra(
    f,
    u,
    y,
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
    transient: bool = False,
    noise_order: Optional[int] = None,
) -> Fit:
    """Fits Y = G U (+ a transient term, + a noise model H = C/D) to input and output
    spectra U(f), Y(f) (errors in Y only).

    ``f`` (Hz), ``u`` and ``y`` (complex) have one value per line; ``var`` is the noise
    variance of each line of ``y``; ``transient`` adds the transient term of a
    non-periodic record (McKelvey eq. 4); ``noise_order`` fits a noise model of that
    order (discrete time). The other parameters are those of :func:`fit`.
    """
    f = _real_1d("f", f)
    u = _complex_1d("u", u)
    y = _complex_1d("y", y)
    if var is not None:
        var = _real_1d("var", var)
    model = _model(domain, na, nb, ts, delay, criterion, stable, transient, noise_order)
    return _fit_spectra(f, u, y, var, _band(band), model)


def fit_record(
    t,
    u,
    y,
    *,
    domain: str,
    na: int,
    nb: int,
    periods: Optional[int] = None,
    delay: bool = False,
    criterion: str = "ml",
    band: Optional[Tuple[float, float]] = None,
    stable: bool = False,
    transient: bool = False,
    noise_order: Optional[int] = None,
) -> Fit:
    """Fits a model to a sampled input/output record, as ``fdid fit`` does with a
    ``t,u,y`` file.

    ``t`` (s, uniformly spaced) gives the sample time (the model's for ``domain="z"``).
    With ``periods=P`` the record holds P periods of a periodic input, whose spectra are
    averaged (their sample variances weight the fit); without it the DFT of the whole
    record is fitted, usually with ``transient=True``. The lines the input excites are
    fitted (every line strictly between DC and Nyquist with ``noise_order``).
    """
    t = _real_1d("t", t)
    u = _real_1d("u", u)
    y = _real_1d("y", y)
    model = _model(domain, na, nb, None, delay, criterion, stable, transient, noise_order)
    periods = None if periods is None else int(periods)
    return _fit_record(t, u, y, periods, _band(band), model)


def fit_many(
    datasets,
    *,
    domain: str,
    na: int,
    nb: int,
    ts: Optional[float] = None,
    delay: bool = False,
    criterion: str = "ml",
    band: Optional[Tuple[float, float]] = None,
    stable: bool = False,
    errors: str = "raise",
) -> List[Optional[Fit]]:
    """Fits one model structure to many frequency responses in parallel.

    ``datasets`` is a sequence of ``(f, frf)`` or ``(f, frf, var)`` tuples, or of dicts
    with the keys ``f``, ``frf`` and optionally ``var``. The fits run on fdid's thread
    pool with the GIL released (``RAYON_NUM_THREADS`` sets its size). Returns one
    :class:`Fit` per data set, in order; a failed fit raises ``ValueError`` naming its
    index, or with ``errors="none"`` gives ``None`` in its place. The other parameters
    are those of :func:`fit`.
    """
    items = []
    for k, d in enumerate(datasets):
        if isinstance(d, dict):
            f, frf, var = d.get("f"), d.get("frf"), d.get("var")
        elif len(d) in (2, 3):
            f, frf, var = d[0], d[1], (d[2] if len(d) == 3 else None)
        else:
            raise ValueError(f"data set {k}: expected (f, frf) or (f, frf, var), got {len(d)} items")
        if f is None or frf is None:
            raise ValueError(f"data set {k}: needs f and frf")
        try:
            items.append(
                (
                    _real_1d("f", f),
                    _complex_1d("frf", frf),
                    None if var is None else _real_1d("var", var),
                )
            )
        except ValueError as e:
            raise ValueError(f"data set {k}: {e}") from None
    model = _model(domain, na, nb, ts, delay, criterion, stable)
    return _fit_many(items, _band(band), errors, model)


def diagnose(
    *,
    domain: str,
    na: int,
    nb: int,
    f=None,
    frf=None,
    var=None,
    t=None,
    u=None,
    y=None,
    periods: Optional[int] = None,
    ts: Optional[float] = None,
    alpha: float = 0.01,
    max_steps: int = 4,
) -> dict:
    """The discrepancy workflow of ``fdid diagnose``: from G = B/A of orders (na, nb) it
    tests where model and data disagree, names the missing effect (time delay, missing
    resonance, pole or zero, transient, coloured noise, ...), adds it, checks that the gap
    shrank, and repeats until the residuals are consistent with the noise.

    Give a frequency response (``f`` in Hz, complex ``frf``, optional ``var``; ``ts`` for
    ``domain="z"``) or a time record (``t``, ``u``, ``y``, optional ``periods``).

    Returns a dict: ``steps`` (each ``effect``, ``p_value``, ``lr_p``, ``cost_before``,
    ``cost_after``), ``effects`` (named and added), ``unmodelled`` (named, not added),
    ``consistent`` (the verdict at level ``alpha``), ``final_spec`` (``na``, ``nb``,
    ``delay``, ``transient``, ``noise_order``), ``cost_initial``, ``cost_final`` and
    ``fit`` (the final :class:`Fit`).
    """
    if (f is None) != (frf is None):
        raise ValueError("give both f and frf (a frequency response)")
    arrays = {"f": None, "frf": None, "var": None, "t": None, "u": None, "y": None}
    if f is not None:
        arrays["f"] = _real_1d("f", f)
        arrays["frf"] = _complex_1d("frf", frf)
        if var is not None:
            arrays["var"] = _real_1d("var", var)
    for name, value in (("t", t), ("u", u), ("y", y)):
        if value is not None:
            arrays[name] = _real_1d(name, value)
    return _diagnose(
        *arrays.values(),
        None if periods is None else int(periods),
        float(alpha),
        int(max_steps),
        _model(domain, na, nb, ts),
    )


def ltv(
    t,
    u,
    y,
    *,
    na: int,
    nb: int,
    np: int,
    ntr: Optional[int] = None,
    band: Optional[Tuple[float, float]] = None,
    basis: str = "legendre",
    at=None,
) -> dict:
    """Fits the continuous-time time-varying ODE of ``fdid ltv`` (Lataire and Pintelon):
    Σ_n a_n(t) y^(n)(t) = Σ_n b_n(t) u^(n)(t) with a_n, b_n polynomials in t of degree
    ``np``, by total least squares on the DFT lines of one record (``band`` in Hz, all
    lines up to Nyquist by default), with the transient + alias polynomial of degree
    ``ntr`` (default max(na, nb)) and Legendre (default) or monomial bases.

    Returns a dict: ``theta`` (the null vector of the regression, in the bases),
    ``singular_values`` (ascending, the smallest is the fit's), ``lines`` (number
    fitted), ``transient`` (its coefficients), ``times`` (``at``, default five instants
    over the record, in the units of ``t``) and ``poles`` (the instantaneous poles at each
    of them, rad/s).
    """
    t = _real_1d("t", t)
    u = _real_1d("u", u)
    y = _real_1d("y", y)
    return _ltv(
        t,
        u,
        y,
        na=int(na),
        nb=int(nb),
        np=int(np),
        ntr=None if ntr is None else int(ntr),
        band=_band(band),
        basis=basis,
        at=None if at is None else _real_1d("at", at),
    )


def _model(
    domain,
    na,
    nb,
    ts=None,
    delay=False,
    criterion="ml",
    stable=False,
    transient=False,
    noise_order=None,
) -> dict:
    """The model structure and criterion, as the extension takes them."""
    return {
        "domain": domain,
        "ts": None if ts is None else float(ts),
        "na": int(na),
        "nb": int(nb),
        "delay": bool(delay),
        "criterion": criterion,
        "stable": bool(stable),
        "transient": bool(transient),
        "noise_order": None if noise_order is None else int(noise_order),
    }


def _band(band) -> Optional[Tuple[float, float]]:
    return None if band is None else (float(band[0]), float(band[1]))


def fit_common_poles(
    f,
    frf,
    *,
    domain: str,
    order: int,
    ts: Optional[float] = None,
    var=None,
    direct: bool = True,
    stable: bool = False,
    ml: bool = True,
    band: Optional[Tuple[float, float]] = None,
) -> CommonPoleFit:
    """Fits poles shared by every entry of a frequency response matrix, as ``fdid fit``
    does with every entry of a multi-port file: G(x) = D + Σ_m R_m/(x − p_m), one
    residue matrix per pole, by relaxed vector fitting with the fast block solution, then
    maximum likelihood (``ml``) weighted by ``var`` when given.

    Parameters
    ----------
    f : array_like, shape (N,)
        Frequencies (Hz).
    frf : array_like of complex, shape (N, ny, nu)
        G(f) for output i and input j at ``frf[:, i, j]`` (for S-parameters ``S[:, i, j]``,
        as scikit-rf's ``Network.s``).
    domain, ts : as in :func:`fit`.
    order : int
        Number of poles (complex pairs count twice).
    var : array_like, shape (N, ny, nu), optional
        Noise variance of each value.
    direct : bool
        Estimate the direct term D.
    stable, band : as in :func:`fit`.

    Returns
    -------
    CommonPoleFit
        ``poles``, ``pole_slots``, ``residues`` (slots × ny × nu), ``direct``, ``modes``
        (natural frequency, damping, mode shape), ``state_space`` (a, b, c, d), ``rms``,
        ``cost``, ``relocations``, ``ml``, ``stable``, and ``frf(f)`` (N × ny × nu).
    """
    f = _real_1d("f", f)
    frf = np.asarray(frf)
    if frf.ndim != 3:
        raise ValueError(f"frf must be (lines, outputs, inputs), got shape {frf.shape}")
    frf = np.ascontiguousarray(frf, dtype=np.complex128)
    if var is not None:
        var = np.ascontiguousarray(np.asarray(var), dtype=np.float64)
        if var.ndim != 3:
            raise ValueError(f"var must be (lines, outputs, inputs), got shape {var.shape}")
    return _fit_common_poles(
        f,
        frf,
        domain=domain,
        order=int(order),
        ts=None if ts is None else float(ts),
        var=var,
        direct=bool(direct),
        stable=bool(stable),
        ml=bool(ml),
        band=_band(band),
    )


def load(source: Union[str, os.PathLike]) -> Fit:
    """A model saved with ``Fit.to_json()`` or ``fdid fit --save``: a path to the file,
    or the JSON text itself."""
    text = os.fspath(source)
    if not text.lstrip().startswith("{"):
        with open(text, encoding="utf-8") as fh:
            text = fh.read()
    return load_json(text)


def from_network(network, port: Optional[Tuple[int, int]] = (2, 1), **kwargs):
    """Fits a scikit-rf ``Network`` against ``network.f`` (Hz).

    With ``port=(i, j)`` (1-based (output, input), as ``fdid fit --port ij``) the entry
    S[i, j] is fitted by :func:`fit` (keyword arguments go to it; the default domain is
    "s"). With ``port=None`` every entry is fitted with common poles by
    :func:`fit_common_poles` (pass ``order=``).
    """
    kwargs.setdefault("domain", "s")
    s = np.asarray(network.s)
    if port is None:
        return fit_common_poles(np.asarray(network.f), s, **kwargs)
    i, j = port
    n = s.shape[1]
    if not (1 <= i <= n and 1 <= j <= n):
        raise ValueError(f"port {port} is outside the {n}-port network (1-based)")
    return fit(np.asarray(network.f), s[:, i - 1, j - 1], **kwargs)
