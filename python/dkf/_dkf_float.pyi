# dkf's classes over the core built in float (python/src/dkf_module.cpp).
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

class KalmanFilter(KalmanFilterBase[np.float32]): ...
class InformationFilter(InformationFilterBase[np.float32]): ...
class DifferenceKF(DifferenceKFBase[np.float32]): ...
class DiffKFFusionCentre(DiffKFFusionCentreBase[np.float32]): ...
class ASKF(ASKFBase[np.float32]): ...
class OTSKF(OTSKFBase[np.float32]): ...
class UIF(UIFBase[np.float32]): ...
class WeightedFusion(WeightedFusionBase[np.float32]): ...
class SelfTuning(SelfTuningBase[np.float32]): ...
class TWCentral(TWCentralBase[np.float32]): ...
class TWNetwork(TWNetworkBase[np.float32]): ...
class NLModel(NLModelBase[np.float32]): ...
class NERTS(NERTSBase[np.float32]): ...
class DFNERTS(DFNERTSBase[np.float32]): ...
class DFNERTSNode(DFNERTSNodeBase[np.float32]): ...

def info_contribution(
    z: npt.ArrayLike, H: npt.ArrayLike, R: npt.ArrayLike
) -> Tuple[npt.NDArray[np.float32], npt.NDArray[np.float32]]:
    """A sensor's (i, I) = (H^T R^-1 z, H^T R^-1 H); NaN components of z are missing."""

def dare(
    F: npt.ArrayLike, H: npt.ArrayLike, Q: npt.ArrayLike, R: npt.ArrayLike
) -> npt.NDArray[np.float32]:
    """The stabilising solution of the filtering DARE (dkf_mat_dare)."""

def stein(A: npt.ArrayLike, B: npt.ArrayLike, C: npt.ArrayLike) -> npt.NDArray[np.float32]:
    """The solution X of X = A X B^T + C (dkf_mat_stein)."""

def graph_weights_uniform(adjacency: npt.ArrayLike) -> npt.NDArray[np.float32]:
    """w_ij = 1 / |N_i| on the graph, (N, N) (dkf_graph_weights_uniform)."""

def graph_weights_metropolis(adjacency: npt.ArrayLike) -> npt.NDArray[np.float32]:
    """Metropolis-Hastings weights on the graph, (N, N) (dkf_graph_weights_metropolis)."""

def graph_weights_max_degree(adjacency: npt.ArrayLike) -> npt.NDArray[np.float32]:
    """Max-degree weights on the graph, (N, N) (dkf_graph_weights_max_degree)."""
