"""dkf's classes over the core built in float: float32 arrays in and out.

The same classes and errors (dkf.Error) as the package dkf; only the real
type differs. The float32 and float64 modules may be used in one process.
"""

from __future__ import annotations

from . import _dkf_float
from ._dkf_float import DifferenceKF, InformationFilter, KalmanFilter, info_contribution

dtype = _dkf_float.dtype
MAX_DIM: int = _dkf_float.MAX_DIM

__all__ = ["KalmanFilter", "InformationFilter", "DifferenceKF", "info_contribution", "dtype", "MAX_DIM"]
