# dkf's classes over the core built in double (python/src/dkf_module.cpp).
from typing import Tuple

import numpy as np
import numpy.typing as npt

from ._api import ASKFBase, DiffKFFusionCentreBase, DifferenceKFBase, InformationFilterBase
from ._api import KalmanFilterBase, OTSKFBase, SelfTuningBase, UIFBase, WeightedFusionBase
from ._api import DFNERTSBase, DFNERTSNodeBase, NERTSBase, NLModelBase, TWCentralBase
from ._api import TWNetworkBase

dtype: str
MAX_DIM: int
JOSEPH: int

def _status_str(status: int) -> str: ...

class KalmanFilter(KalmanFilterBase[np.float64]): ...
class InformationFilter(InformationFilterBase[np.float64]): ...
class DifferenceKF(DifferenceKFBase[np.float64]): ...
class DiffKFFusionCentre(DiffKFFusionCentreBase[np.float64]): ...
class ASKF(ASKFBase[np.float64]): ...
class OTSKF(OTSKFBase[np.float64]): ...
class UIF(UIFBase[np.float64]): ...
class WeightedFusion(WeightedFusionBase[np.float64]): ...
class SelfTuning(SelfTuningBase[np.float64]): ...
class TWCentral(TWCentralBase[np.float64]): ...
class TWNetwork(TWNetworkBase[np.float64]): ...
class NLModel(NLModelBase[np.float64]): ...
class NERTS(NERTSBase[np.float64]): ...
class DFNERTS(DFNERTSBase[np.float64]): ...
class DFNERTSNode(DFNERTSNodeBase[np.float64]): ...

def info_contribution(
    z: npt.ArrayLike, H: npt.ArrayLike, R: npt.ArrayLike
) -> Tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """A sensor's (i, I) = (H^T R^-1 z, H^T R^-1 H); NaN components of z are missing."""

def dare(
    F: npt.ArrayLike, H: npt.ArrayLike, Q: npt.ArrayLike, R: npt.ArrayLike
) -> npt.NDArray[np.float64]:
    """The stabilising solution of the filtering DARE (dkf_mat_dare)."""

def stein(A: npt.ArrayLike, B: npt.ArrayLike, C: npt.ArrayLike) -> npt.NDArray[np.float64]:
    """The solution X of X = A X B^T + C (dkf_mat_stein)."""

def graph_weights_uniform(adjacency: npt.ArrayLike) -> npt.NDArray[np.float64]:
    """w_ij = 1 / |N_i| on the graph, (N, N) (dkf_graph_weights_uniform)."""

def graph_weights_metropolis(adjacency: npt.ArrayLike) -> npt.NDArray[np.float64]:
    """Metropolis-Hastings weights on the graph, (N, N) (dkf_graph_weights_metropolis)."""

def graph_weights_max_degree(adjacency: npt.ArrayLike) -> npt.NDArray[np.float64]:
    """Max-degree weights on the graph, (N, N) (dkf_graph_weights_max_degree)."""
