# dkf's classes over the core built in float (python/src/dkf_module.cpp).
from typing import Tuple

import numpy as np
import numpy.typing as npt

from ._api import ASKFBase, DiffKFFusionCentreBase, DifferenceKFBase, InformationFilterBase
from ._api import KalmanFilterBase, OTSKFBase, UIFBase

dtype: str
MAX_DIM: int
JOSEPH: int

def _status_str(status: int) -> str: ...

class KalmanFilter(KalmanFilterBase[np.float32]): ...
class InformationFilter(InformationFilterBase[np.float32]): ...
class DifferenceKF(DifferenceKFBase[np.float32]): ...
class DiffKFFusionCentre(DiffKFFusionCentreBase[np.float32]): ...
class ASKF(ASKFBase[np.float32]): ...
class OTSKF(OTSKFBase[np.float32]): ...
class UIF(UIFBase[np.float32]): ...

def info_contribution(
    z: npt.ArrayLike, H: npt.ArrayLike, R: npt.ArrayLike
) -> Tuple[npt.NDArray[np.float32], npt.NDArray[np.float32]]:
    """A sensor's (i, I) = (H^T R^-1 z, H^T R^-1 H); NaN components of z are missing."""
