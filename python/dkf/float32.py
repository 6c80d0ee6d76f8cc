"""dkf's classes over the core built in float: float32 arrays in and out.

The same classes and errors (dkf.Error) as the package dkf; only the real
type differs. The float32 and float64 modules may be used in one process.
"""

from __future__ import annotations

from ._dkf_float import *  # noqa: F403 (the classes, dtype, MAX_DIM)
from ._dkf_float import NLModel as _NLModel
from ._dkf_float import __all__ as _core
from ._expr import for_module as _for_module

expr_model = _for_module(_NLModel)
__all__ = list(_core) + ["expr_model"]
