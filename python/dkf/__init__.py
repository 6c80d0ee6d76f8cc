"""dkf: distributed Kalman filtering with unknown inputs, over its C core.

The classes here run the core built in double and take and give float64
arrays; dkf.float32 has the same classes over the core built in float.
docs/guide/python.md is the guide.
"""

from __future__ import annotations

from importlib.metadata import PackageNotFoundError as _NotFound
from importlib.metadata import version as _version

from ._dkf_double import *  # noqa: F403 (the classes, dtype, MAX_DIM)
from ._dkf_double import __all__ as _core
from ._dkf_double import NLModel as _NLModel
from ._expr import for_module as _for_module
from ._jit import for_module as _jit_for_module
from ._nlm import for_module as _nlm_for_module
from . import _dkf_double as _this_core
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

expr_model = _for_module(_NLModel)
jit_model = _jit_for_module(_NLModel, "float64")
builtin_model = _nlm_for_module(_this_core)

try:
    __version__ = _version("dkf")  # the package's version: dkf/version.h's (pyproject.toml)
except _NotFound:  # imported from a source tree without installing
    __version__ = "unknown"

__all__ = list(_core) + [
    "expr_model",
    "jit_model",
    "builtin_model",
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
