"""dkf: distributed Kalman filtering with unknown inputs, over its C core.

The classes here run the core built in double and take and give float64
arrays; dkf.float32 has the same classes over the core built in float.
docs/guide/python.md is the guide.
"""

from __future__ import annotations

from ._dkf_double import *  # noqa: F403 (the classes, dtype, MAX_DIM)
from ._dkf_double import __all__ as _core
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
from ._scenario import SUPPORTED_FILTERS, run_scenario
from ._simulate import simulate

__all__ = list(_core) + [
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
    "run_scenario",
    "SUPPORTED_FILTERS",
    "simulate",
]
