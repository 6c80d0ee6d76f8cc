# The classes of dkf and dkf.float32, generic in the real type (a stub-only
# module: _dkf_double.pyi and _dkf_float.pyi instantiate it).
from typing import Generic, Optional, Sequence, Tuple, TypeVar

import numpy as np
import numpy.typing as npt

_D = TypeVar("_D", np.float32, np.float64)

class KalmanFilterBase(Generic[_D]):
    """Linear Kalman filter, covariance form (dkf/kf.h).

    F (n, n), Q (n, n), H (m, n), R (m, m): one matrix, or a stack
    (T, ., .) of one per step for filter(). x0 (n,), P0 (n, n) SPD.
    """

    def __init__(
        self,
        F: npt.ArrayLike,
        Q: npt.ArrayLike,
        H: npt.ArrayLike,
        R: npt.ArrayLike,
        x0: npt.ArrayLike,
        P0: npt.ArrayLike,
        *,
        m_max: Optional[int] = None,
    ) -> None: ...
    def predict(
        self,
        F: Optional[npt.ArrayLike] = None,
        Q: Optional[npt.ArrayLike] = None,
        u: Optional[npt.ArrayLike] = None,
    ) -> None:
        """x = F x + u, P = F P F^T + Q (the constructor's F, Q unless given)."""
    def update(
        self,
        y: npt.ArrayLike,
        H: Optional[npt.ArrayLike] = None,
        R: Optional[npt.ArrayLike] = None,
    ) -> None:
        """The measurement update with y (m,); a NaN component is missing."""
    def filter(
        self,
        Y: npt.ArrayLike,
        *,
        F: Optional[npt.ArrayLike] = None,
        Q: Optional[npt.ArrayLike] = None,
        H: Optional[npt.ArrayLike] = None,
        R: Optional[npt.ArrayLike] = None,
    ) -> Tuple[npt.NDArray[_D], npt.NDArray[_D]]:
        """A predict and an update per row of Y (T, m), in one call without
        the GIL: the filtered X (T, n) and P (T, n, n)."""
    @property
    def x(self) -> npt.NDArray[_D]:
        """The state estimate (n,), a copy."""
    @property
    def P(self) -> npt.NDArray[_D]:
        """Its error covariance (n, n), a copy."""
    @property
    def n(self) -> int: ...
    @property
    def m_max(self) -> int: ...

class InformationFilterBase(Generic[_D]):
    """Linear information filter with exact multi-sensor fusion (dkf/info.h).

    F (n, n), Q (n, n): one matrix, or a stack (T, ., .) for filter().
    x0 (n,), P0 (n, n) SPD.
    """

    def __init__(
        self, F: npt.ArrayLike, Q: npt.ArrayLike, x0: npt.ArrayLike, P0: npt.ArrayLike
    ) -> None: ...
    def predict(
        self, F: Optional[npt.ArrayLike] = None, Q: Optional[npt.ArrayLike] = None
    ) -> None:
        """P = F P F^T + Q, x = F x; Y = P^-1, y = Y x."""
    def update(self, z: npt.ArrayLike, H: npt.ArrayLike, R: npt.ArrayLike) -> None:
        """One sensor's measurement z (m,): its contribution, fused."""
    def fuse(self, i: npt.ArrayLike, I: npt.ArrayLike) -> None:
        """Contributions i (n,) or (L, n), I (n, n) or (L, n, n): Y += sum I, y += sum i."""
    def filter(
        self,
        Z: Sequence[npt.ArrayLike],
        H: Sequence[npt.ArrayLike],
        R: Sequence[npt.ArrayLike],
        *,
        F: Optional[npt.ArrayLike] = None,
        Q: Optional[npt.ArrayLike] = None,
    ) -> Tuple[npt.NDArray[_D], npt.NDArray[_D]]:
        """Per step t: a predict, each sensor j's contribution from Z[j][t]
        (T, m_j), one fuse, in one call without the GIL: X (T, n), P (T, n, n)."""
    @property
    def x(self) -> npt.NDArray[_D]: ...
    @property
    def P(self) -> npt.NDArray[_D]: ...
    @property
    def y(self) -> npt.NDArray[_D]: ...
    @property
    def Y(self) -> npt.NDArray[_D]: ...
    @property
    def n(self) -> int: ...
