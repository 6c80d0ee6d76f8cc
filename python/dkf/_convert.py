"""Argument conversion for the extension modules (python/src/dkf_module.cpp).

An argument that is already a C-contiguous array of the module's real type
never comes here; anything else does, once per argument and call.
"""

from __future__ import annotations

import numpy as np


def as_real(obj: object, call: str, name: str, dtype: str) -> np.ndarray:
    """obj as a C-contiguous array of dtype; TypeError unless it holds reals.

    Integers and every floating dtype are converted (float64 to float32
    rounds); bool, complex, object and string data are refused, as is
    anything numpy does not read as an array of numbers.
    """
    try:
        a = np.asarray(obj)
    except ValueError as e:  # a ragged sequence: a shape error
        raise ValueError(f"{call}: {name}: {e}") from None
    except Exception as e:
        raise TypeError(f"{call}: {name} must be an array of real numbers: {e}") from None
    if a.dtype.kind not in "fiu":
        raise TypeError(
            f"{call}: {name} must be an array of real numbers, not of dtype {a.dtype}"
        )
    return np.ascontiguousarray(a, dtype=dtype)
