"""dkf's classes over the core built in float: float32 arrays in and out.

The same classes and errors (dkf.Error) as the package dkf; only the real
type differs. The float32 and float64 modules may be used in one process.
"""

from __future__ import annotations

import os
from typing import Any, Dict, Optional, Sequence, Union

from ._dkf_float import *  # noqa: F403 (the classes, dtype, MAX_DIM)
from ._dkf_float import NLModel as _NLModel
from ._dkf_float import __all__ as _core
from ._expr import for_module as _for_module
from ._jit import for_module as _jit_for_module
from ._nlm import for_module as _nlm_for_module
from . import _dkf_float as _this_core

expr_model = _for_module(_NLModel)
jit_model = _jit_for_module(_NLModel, "float32")
builtin_model = _nlm_for_module(_this_core)
__all__ = list(_core) + ["expr_model", "jit_model", "builtin_model", "run_scenario"]


def run_scenario(scenario: Union[str, "os.PathLike[str]", Dict[str, Any]], filter: str,
                 run: int = 0, *, d00: Optional[Sequence[float]] = None,
                 Pd00_scale: Optional[float] = None, case: Union[int, str, None] = None,
                 name: Optional[str] = None, eta: Optional[int] = None,
                 metrics_only: bool = False) -> Dict[str, Any]:
    """dkf.run_scenario over the core built in float: the document of a float dkf-run
    ("real": "float"), every number that build's."""
    from . import _dkf_float
    from ._scenario import run_with

    return run_with(_dkf_float, scenario, filter, run, d00=d00, Pd00_scale=Pd00_scale,
                    case=case, name=name, eta=eta, metrics_only=metrics_only)
