from typing import List, Optional, Sequence, Tuple

import numpy as np
import numpy.typing as npt

__version__: str

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
    *,
    domain: str,
    na: int,
    nb: int,
    ts: Optional[float] = None,
    var: Optional[npt.NDArray[np.float64]] = None,
    delay: bool = False,
    criterion: str = "ml",
    band: Optional[Tuple[float, float]] = None,
    stable: bool = False,
) -> Fit: ...
def load_json(text: str) -> Fit: ...
def fit_spectra(
    f: npt.NDArray[np.float64],
    u: npt.NDArray[np.complex128],
    y: npt.NDArray[np.complex128],
    *,
    domain: str,
    na: int,
    nb: int,
    ts: Optional[float] = None,
    var: Optional[npt.NDArray[np.float64]] = None,
    delay: bool = False,
    criterion: str = "ml",
    band: Optional[Tuple[float, float]] = None,
    stable: bool = False,
    transient: bool = False,
    noise_order: Optional[int] = None,
) -> Fit: ...
def fit_record(
    t: npt.NDArray[np.float64],
    u: npt.NDArray[np.float64],
    y: npt.NDArray[np.float64],
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
) -> Fit: ...
def diagnose(
    *,
    domain: str,
    na: int,
    nb: int,
    f: Optional[npt.NDArray[np.float64]] = None,
    frf: Optional[npt.NDArray[np.complex128]] = None,
    var: Optional[npt.NDArray[np.float64]] = None,
    t: Optional[npt.NDArray[np.float64]] = None,
    u: Optional[npt.NDArray[np.float64]] = None,
    y: Optional[npt.NDArray[np.float64]] = None,
    periods: Optional[int] = None,
    ts: Optional[float] = None,
    alpha: float = 0.01,
    max_steps: int = 4,
) -> dict: ...
def fit_many(
    datasets: Sequence[
        Tuple[
            npt.NDArray[np.float64],
            npt.NDArray[np.complex128],
            Optional[npt.NDArray[np.float64]],
        ]
    ],
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
