# dkf's classes over the core built in double (python/src/dkf_module.cpp).
import numpy as np

from ._api import KalmanFilterBase

dtype: str
MAX_DIM: int
JOSEPH: int

def _status_str(status: int) -> str: ...

class KalmanFilter(KalmanFilterBase[np.float64]): ...
