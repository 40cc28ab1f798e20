from typing import List, Optional, Sequence, Tuple, TypedDict

import numpy as np
import numpy.typing as npt

__version__: str

class Model(TypedDict):
    """The model structure and criterion the functions take (built by the package)."""

    domain: str
    ts: Optional[float]
    na: int
    nb: int
    delay: bool
    criterion: str
    stable: bool
    transient: bool
    noise_order: Optional[int]

class Fit:
    @property
    def poles(self) -> npt.NDArray[np.complex128]: ...
    @property
    def zeros(self) -> npt.NDArray[np.complex128]: ...
    @property
    def gain(self) -> float: ...
    @property
    def delay(self) -> Optional[float]: ...
    @property
    def domain(self) -> str: ...
    @property
    def ts(self) -> Optional[float]: ...
    @property
    def theta(self) -> npt.NDArray[np.float64]: ...
    @property
    def covariance(self) -> Optional[npt.NDArray[np.float64]]: ...
    @property
    def cost(self) -> float: ...
    @property
    def noise_variance(self) -> float: ...
    @property
    def lines(self) -> int: ...
    @property
    def stable(self) -> bool: ...
    @property
    def validation(self) -> Optional[dict]: ...
    @property
    def fit_seconds(self) -> Optional[float]: ...
    def frf(self, f: npt.NDArray[np.float64]) -> npt.NDArray[np.complex128]: ...
    def frf_std(self, f: npt.NDArray[np.float64]) -> Optional[npt.NDArray[np.float64]]: ...
    def bounds(self, f: npt.NDArray[np.float64], level: float = 0.95) -> Optional[dict]: ...
    def to_json(self) -> str: ...

def fit_frf(
    f: npt.NDArray[np.float64],
    frf: npt.NDArray[np.complex128],
    var: Optional[npt.NDArray[np.float64]],
    band: Optional[Tuple[float, float]],
    model: Model,
) -> Fit: ...
def load_json(text: str) -> Fit: ...
def fit_spectra(
    f: npt.NDArray[np.float64],
    u: npt.NDArray[np.complex128],
    y: npt.NDArray[np.complex128],
    var: Optional[npt.NDArray[np.float64]],
    band: Optional[Tuple[float, float]],
    model: Model,
) -> Fit: ...
def fit_record(
    t: npt.NDArray[np.float64],
    u: npt.NDArray[np.float64],
    y: npt.NDArray[np.float64],
    periods: Optional[int],
    band: Optional[Tuple[float, float]],
    model: Model,
) -> Fit: ...
def diagnose(
    f: Optional[npt.NDArray[np.float64]],
    frf: Optional[npt.NDArray[np.complex128]],
    var: Optional[npt.NDArray[np.float64]],
    t: Optional[npt.NDArray[np.float64]],
    u: Optional[npt.NDArray[np.float64]],
    y: Optional[npt.NDArray[np.float64]],
    periods: Optional[int],
    alpha: float,
    max_steps: int,
    model: Model,
) -> dict: ...
def fit_many(
    datasets: Sequence[
        Tuple[
            npt.NDArray[np.float64],
            npt.NDArray[np.complex128],
            Optional[npt.NDArray[np.float64]],
        ]
    ],
    band: Optional[Tuple[float, float]],
    errors: str,
    model: Model,
) -> List[Optional[Fit]]: ...
def ltv(
    t: npt.NDArray[np.float64],
    u: npt.NDArray[np.float64],
    y: npt.NDArray[np.float64],
    *,
    na: int,
    nb: int,
    np: int,
    ntr: Optional[int] = None,
    band: Optional[Tuple[float, float]] = None,
    basis: str = "legendre",
    at: Optional[npt.NDArray[np.float64]] = None,
) -> dict: ...
class CommonPoleFit:
    @property
    def poles(self) -> npt.NDArray[np.complex128]: ...
    @property
    def pole_slots(self) -> npt.NDArray[np.complex128]: ...
    @property
    def residues(self) -> npt.NDArray[np.complex128]: ...
    @property
    def direct(self) -> Optional[npt.NDArray[np.float64]]: ...
    @property
    def modes(self) -> list: ...
    @property
    def state_space(self) -> dict: ...
    @property
    def rms(self) -> float: ...
    @property
    def cost(self) -> float: ...
    @property
    def relocations(self) -> int: ...
    @property
    def ml(self) -> str: ...
    @property
    def stable(self) -> bool: ...
    def frf(self, f: npt.NDArray[np.float64]) -> npt.NDArray[np.complex128]: ...

def fit_common_poles_py(
    f: npt.NDArray[np.float64],
    frf: npt.NDArray[np.complex128],
    *,
    domain: str,
    order: int,
    ts: Optional[float] = None,
    var: Optional[npt.NDArray[np.float64]] = None,
    direct: bool = True,
    stable: bool = False,
    ml: bool = True,
    band: Optional[Tuple[float, float]] = None,
) -> CommonPoleFit: ...
