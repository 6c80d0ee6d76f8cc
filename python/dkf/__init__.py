"""dkf: distributed Kalman filtering with unknown inputs, over its C core.

The classes here run the core built in double and take and give float64
arrays; dkf.float32 has the same classes over the core built in float.
docs/guide/python.md is the guide.
"""

from __future__ import annotations

from . import _dkf_double
from ._dkf_double import DifferenceKF, InformationFilter, KalmanFilter, info_contribution
from ._errors import (
    AliasError,
    ArgError,
    CapacityError,
    DimError,
    Error,
    GraphError,
    ModelError,
    NoConvergenceError,
    NonFiniteError,
    NotSPDError,
    NullError,
    RankError,
    SingularError,
    StateError,
    UnstableError,
    WeightsError,
)

dtype = _dkf_double.dtype
MAX_DIM: int = _dkf_double.MAX_DIM

__all__ = [
    "KalmanFilter",
    "InformationFilter",
    "DifferenceKF",
    "info_contribution",
    "Error",
    "NullError",
    "DimError",
    "CapacityError",
    "NonFiniteError",
    "NotSPDError",
    "SingularError",
    "RankError",
    "AliasError",
    "NoConvergenceError",
    "StateError",
    "ArgError",
    "GraphError",
    "WeightsError",
    "ModelError",
    "UnstableError",
    "dtype",
    "MAX_DIM",
]
