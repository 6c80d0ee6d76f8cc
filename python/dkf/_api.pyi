# The classes of dkf and dkf.float32, generic in the real type (a stub-only
# module: _dkf_double.pyi and _dkf_float.pyi instantiate it).
from typing import Any, Callable, Dict, Generic, List, Mapping, Optional, Sequence, Tuple, TypeVar

import numpy as np
import numpy.typing as npt

_D = TypeVar("_D", np.float32, np.float64)
_A = npt.ArrayLike
_O = Optional[npt.ArrayLike]
_Out = npt.NDArray[_D]

class KalmanFilterBase(Generic[_D]):
    """Linear Kalman filter, covariance form (dkf/kf.h).

    F (n, n), Q (n, n), H (m, n), R (m, m): one matrix, or a stack
    (T, ., .) of one per step for filter(). x0 (n,), P0 (n, n) SPD.
    """

    def __init__(
        self, F: _A, Q: _A, H: _A, R: _A, x0: _A, P0: _A, *, m_max: Optional[int] = None
    ) -> None: ...
    def predict(self, F: _O = None, Q: _O = None, u: _O = None) -> None:
        """x = F x + u, P = F P F^T + Q (the constructor's F, Q unless given)."""
    def update(self, y: _A, H: _O = None, R: _O = None) -> None:
        """The measurement update with y (m,); a NaN component is missing."""
    def filter(
        self, Y: _A, *, F: _O = None, Q: _O = None, H: _O = None, R: _O = None
    ) -> Tuple[_Out[_D], _Out[_D]]:
        """A predict and an update per row of Y (T, m), in one call without
        the GIL: the filtered X (T, n) and P (T, n, n)."""
    @property
    def x(self) -> _Out[_D]:
        """The state estimate (n,), a copy."""
    @property
    def P(self) -> _Out[_D]:
        """Its error covariance (n, n), a copy."""
    @property
    def n(self) -> int: ...
    @property
    def m_max(self) -> int: ...

class InformationFilterBase(Generic[_D]):
    """Linear information filter with exact multi-sensor fusion (dkf/info.h).

    F (n, n), Q (n, n): one matrix, or a stack (T, ., .) for filter().
    x0 (n,), P0 (n, n) SPD.
    """

    def __init__(self, F: _A, Q: _A, x0: _A, P0: _A) -> None: ...
    def predict(self, F: _O = None, Q: _O = None) -> None:
        """P = F P F^T + Q, x = F x; Y = P^-1, y = Y x."""
    def update(self, z: _A, H: _A, R: _A) -> None:
        """One sensor's measurement z (m,): its contribution, fused."""
    def fuse(self, i: _A, I: _A) -> None:
        """Contributions i (n,) or (L, n), I (n, n) or (L, n, n): Y += sum I, y += sum i."""
    def filter(
        self, Z: Sequence[_A], H: Sequence[_A], R: Sequence[_A], *, F: _O = None, Q: _O = None
    ) -> Tuple[_Out[_D], _Out[_D]]:
        """Per step t: a predict, each sensor j's contribution from Z[j][t]
        (T, m_j), one fuse, in one call without the GIL: X (T, n), P (T, n, n)."""
    @property
    def x(self) -> _Out[_D]: ...
    @property
    def P(self) -> _Out[_D]: ...
    @property
    def y(self) -> _Out[_D]: ...
    @property
    def Y(self) -> _Out[_D]: ...
    @property
    def n(self) -> int: ...

class _DkfEstimates(Generic[_D]):
    """A Difference KF's estimates and last step (copies): x_{k|k}, P_{k|k},
    x_{k+1|k}, P_{k+1|k}, x_{k|k-1}, z_k, dz_k, J_k, L_k, K_k."""

    xf: _Out[_D]
    Pf: _Out[_D]
    xn: _Out[_D]
    Pn: _Out[_D]
    xp: _Out[_D]
    z: _Out[_D]
    dz: _Out[_D]
    J: _Out[_D]
    L: _Out[_D]
    K: _Out[_D]

class DifferenceKFBase(_DkfEstimates[_D]):
    """The Difference Kalman filter with unknown inputs (dkf/diffkf.h).

    x0 (n,), P0 (n, n) SPD: (x_{0|0}, P_{0|0}), or the prior of time 1
    (start() without F0, Q0; filter(prior=True)). m, p: the measurement and
    unknown-input dimensions.
    """

    def __init__(self, x0: _A, P0: _A, *, m: int, p: int) -> None: ...
    def start(self, y1: _A, H: _A, D: _A, R: _A, *, F0: _O = None, Q0: _O = None) -> None:
        """x_{1|0} = F0 x0 (P likewise), and y_1 with its model (H, D, R at time 1)."""
    def step(
        self, y_next: _A, *, F: _A, Q: _A, B: _A, Rd: _A, H: _A, D: _A, R: _A
    ) -> None:
        """y_{k+1} with the dynamics at k and the model at k+1: x_{k|k}, x_{k+1|k}."""
    def filter(
        self, Y: _A, *, F: _A, Q: _A, B: _A, Rd: _A, H: _A, D: _A, R: _A, prior: bool = False
    ) -> Tuple[_Out[_D], _Out[_D], _Out[_D], _Out[_D]]:
        """start() with Y[0] = y_1, then step() per further row, in one call
        without the GIL: XF, PF (x_{k|k}) and XN, PN (x_{k+1|k}), k = 1..T-1."""
    k: int
    started: bool
    n: int
    m: int
    p: int
    def message(self) -> Tuple[int, _Out[_D], _Out[_D]]:
        """The node message (k, x_{k|k}, x_{k|k-1}) for DiffKFFusionCentre.step."""
    def set_steady(self, tol: float) -> None:
        """The steady gain of a time-invariant model: tol in [0, 1), 0 off."""
    def set_time(self, k: int) -> None:
        """The time k of xf (a filter restarted at k_start: set_time(k_start - 1))."""
    def save(self) -> _Out[_D]:
        """A checkpoint, a new 1-D array of the module's dtype."""
    def restore(self, buf: _Out[_D]) -> None:
        """Back to save()'s checkpoint buf; a refused buffer changes nothing."""
    steady: bool

class DiffKFFusionCentreBase(_DkfEstimates[_D]):
    """The distributed Difference KF's fusion centre (dkf/diffkf_fusion.h).

    x0 (n,), P0 (n, n): the central prior; m, p: each sensor's measurement
    and unknown-input dimensions; P0_local: each node's prior covariance
    (None: P0). A sensor is a dict of B, Rd, H, D, R; a message is a node's
    DifferenceKF.message().
    """

    def __init__(
        self,
        x0: _A,
        P0: _A,
        *,
        m: Sequence[int],
        p: Sequence[int],
        P0_local: Optional[Sequence[Optional[_A]]] = None,
    ) -> None: ...
    def start(self, F0: _A, Q0: _A, sensors: Sequence[Mapping[str, _A]]) -> None: ...
    def step(
        self,
        F: _A,
        Q: _A,
        sensors: Sequence[Mapping[str, _A]],
        messages: Sequence[Tuple[int, _A, _A]],
    ) -> None: ...
    def step_partial(
        self,
        F: _A,
        Q: _A,
        sensors: Sequence[Mapping[str, _A]],
        messages: Sequence[Optional[Tuple[int, _A, _A]]],
    ) -> List[bool]:
        """step() with messages[i] None for a missing message (the masked
        central gain); returns whether each node's z entered the estimate."""
    def restart_node(
        self, node: int, k_start: int, P_prior: _A, sensor: Mapping[str, _A]
    ) -> None:
        """Node `node` restarted at k_start = self.k + 1 from P_prior, with
        its H, D, R at k_start."""
    def set_steady(self, tol: float) -> None:
        """The steady gain of the central filter and every replica."""
    def save(self) -> _Out[_D]:
        """A checkpoint of the whole centre, a new 1-D array."""
    def restore(self, buf: _Out[_D]) -> None:
        """Back to save()'s checkpoint buf; a refused buffer changes nothing."""
    def recovered(self, node: int) -> Tuple[_Out[_D], _Out[_D]]: ...
    synced: List[bool]
    steady: bool
    k: int
    n: int
    l: int
    m: List[int]
    p: List[int]

class _UiKFBase(Generic[_D]):
    """The calls of ASKF and OTSKF: x0 (n,), P0 (n, n), d0 (p,), Pd0 (p, p)
    the prior of x_0 and d_0; m the measurement dimension."""

    def predict(self, F: _A, Q: _A, B: _A, Rd: _A) -> None:
        """Time update with the dynamics at k - 1: x = F x + w, d = B d + wd."""
    def update(self, y: _A, H: _A, D: _A, R: _A) -> None:
        """y_k = H x + D d + v (m,), R = cov(v); an all-NaN y is no update."""
    def filter(
        self, Y: _A, *, F: _A, Q: _A, B: _A, Rd: _A, H: _A, D: _A, R: _A
    ) -> Tuple[_Out[_D], _Out[_D], _Out[_D], _Out[_D]]:
        """Per row t of Y (T, m): a predict with the dynamics at t, an update
        with Y[t] and the model at t + 1 (stacks: T + 1 entries, times 0..T),
        in one call without the GIL: X (T, n), P (T, n, n), D (T, p), Pd (T, p, p)."""
    x: _Out[_D]
    P: _Out[_D]
    d: _Out[_D]
    Pd: _Out[_D]
    n: int
    m: int
    p: int

class ASKFBase(_UiKFBase[_D]):
    """The augmented-state Kalman filter on [x; d] (dkf/askf.h)."""

    def __init__(self, x0: _A, P0: _A, d0: _A, Pd0: _A, *, m: int, Pxd0: _O = None) -> None: ...
    X: _Out[_D]
    PX: _Out[_D]

class OTSKFBase(_UiKFBase[_D]):
    """The optimal two-stage Kalman filter (dkf/otskf.h)."""

    def __init__(self, x0: _A, P0: _A, d0: _A, Pd0: _A, *, m: int) -> None: ...
    xt: _Out[_D]
    Px: _Out[_D]
    U: _Out[_D]
    V: _Out[_D]

class UIFBase(Generic[_D]):
    """Joint state and unknown-input filters (dkf/uif.h), kind "RTSF",
    "NRTSF_DF" or "NRTSF". x0 (n,), P0 (n, n): the prior of x_0 (RTSF,
    NRTSF_DF) or x_{0|0} (NRTSF); m measurements, p unknown inputs."""

    def __init__(self, x0: _A, P0: _A, *, m: int, p: int, kind: str) -> None: ...
    def step(
        self, y: _A, *, H: _A, R: _A, D: _O = None, F: _O = None, G: _O = None, Q: _O = None
    ) -> None:
        """y_k with the model at k (H, D, R; D None for the NRTSF) and the
        dynamics from k - 1 (F, G, Q; none at an RTSF / NRTSF_DF first step)."""
    def filter(
        self, Y: _A, *, F: _A, G: _A, Q: _A, H: _A, R: _A, D: _O = None
    ) -> Tuple[_Out[_D], _Out[_D], _Out[_D], _Out[_D]]:
        """The steps of times 0..T-1 (NRTSF: 1..T-1) with y_t = Y[t], stacks
        indexed by the time: X, Px, D, Pd, one row per step."""
    x: _Out[_D]
    Px: _Out[_D]
    d: _Out[_D]
    Pd: _Out[_D]
    Pxd: _Out[_D]
    x_pred: _Out[_D]
    P_pred: _Out[_D]
    Rtilde: _Out[_D]
    K: _Out[_D]
    L: _Out[_D]
    M: _Out[_D]
    proj: _Out[_D]
    rank: int
    estimable: List[int]
    bias_risk: bool
    bias_steps: int
    k: int
    kind: str
    n: int
    m: int
    p: int

class WeightedFusionBase(Generic[_D]):
    """Weighted fusion of local Kalman filters with their cross covariances
    (dkf/wfusion.h). x0 (n,), P0 (n, n): the common prior; Hs (n,) the
    signal row; m each sensor's measurement dimension."""

    def __init__(self, x0: _A, P0: _A, Hs: _A, *, m: Sequence[int]) -> None: ...
    def step(
        self, F: _A, Q: _A, H: Sequence[_A], R: Sequence[_A], y: Optional[Sequence[_A]] = None
    ) -> None:
        """Every local filter's step (y None: the gains alone), then the P_ij."""
    def steady(self, F: _A, Q: _A, H: Sequence[_A], R: Sequence[_A]) -> None:
        """Every local filter and P_ij at the steady state (DARE, Stein)."""
    def fuse_scalar(self, x: Optional[Sequence[Optional[_A]]] = None) -> Tuple[float, float]:
        """Scalar-weight fusion of s = Hs x over the sensors present: (s0, PS0)."""
    def fuse_matrix(
        self, x: Optional[Sequence[Optional[_A]]] = None
    ) -> Tuple[_Out[_D], _Out[_D]]:
        """Matrix-weight fusion of x over the sensors present: (xf, Pf)."""
    def filter(
        self, Y: Sequence[_A], *, F: _A, Q: _A, H: Sequence[_A], R: Sequence[_A]
    ) -> Tuple[_Out[_D], _Out[_D], _Out[_D], _Out[_D]]:
        """Per step: step(), fuse_scalar(), fuse_matrix(); XF, PF, S0, PS0."""
    K: List[_Out[_D]]
    x_local: _Out[_D]
    P_local: _Out[_D]
    Sigma_pred: _Out[_D]
    Psi: _Out[_D]
    J: _Out[_D]
    Pj: _Out[_D]
    Hs: _Out[_D]
    PS: _Out[_D]
    w: _Out[_D]
    A: _Out[_D]
    xf: _Out[_D]
    Pf: _Out[_D]
    s0: float
    PS0: float
    w_unique: bool
    A_unique: bool
    used: int
    t: int
    steady_state: bool
    n: int
    l: int
    m: List[int]

class SelfTuningBase(Generic[_D]):
    """Self-tuning identifier of seed 002's signal model (dkf/selftune.h)."""

    def __init__(
        self,
        *,
        L: int,
        sigma_v2: _A,
        p: _O = None,
        sigma_xi2: float = 0.0,
        na: int = 2,
        nc: int = 1,
        lags: int = 5,
        t_min: int = 50,
        root_max: float = 0.99,
        rho_max: float = 0.499,
        sigma_w2_min: float = 1e-3,
        a0: _O = None,
        c0: float = 0.0,
        sigma_w2_0: float = 1.0,
    ) -> None: ...
    def update(self, y: _A) -> None:
        """One time step with the L measurements y (L,)."""
    def filter(self, Y: _A) -> Tuple[_Out[_D], _Out[_D], _Out[_D]]:
        """An update per row of Y (T, L): the accepted a (T, na), c1, sigma_w2 (T,)."""
    def estimate(self) -> Dict[str, object]:
        """a, c1, sigma_w2, ready, guard, t, t_accepted and the raw estimate."""
    def autocov(self) -> _Out[_D]: ...
    def noise_autocov(self) -> _Out[_D]: ...
    def model(self) -> Tuple[_Out[_D], _Out[_D]]:
        """The observer-form (F, Q) of the accepted estimate."""
    L: int
    n: int

class _TWFields(Generic[_D]):
    """The estimates and the last step's intermediates of dkf/tw.h's node
    (the network's stacked (N, ...)), copies."""

    x: _Out[_D]
    P: _Out[_D]
    d: _Out[_D]
    phi: _Out[_D]
    Phi: _Out[_D]
    I: _Out[_D]
    i: _Out[_D]
    phi_post: _Out[_D]
    Phi_post: _Out[_D]
    S: _Out[_D]
    Gpost: _Out[_D]
    psi: _Out[_D]
    Ploc: _Out[_D]
    k: int

class TWCentralBase(_TWFields[_D]):
    """The centralised two-stage filter with unknown inputs, Algorithm 1 of
    dkf/tw.h (seed 003). x0 (n,), P0 (n, n): x_{0|0}, P_{0|0}; each sensor
    measures at most m_max values; p unknown inputs."""

    def __init__(self, x0: _A, P0: _A, *, m_max: int, p: int) -> None: ...
    def step(
        self, y: Sequence[_A], *, F: _A, G: _A, Q: _A, H: Sequence[_A], R: Sequence[_A]
    ) -> None:
        """y_k of every sensor with its H, R and the dynamics from k - 1; a
        NaN component of y is missing, an all-NaN sensor adds nothing."""
    def filter(
        self, Y: Sequence[_A], *, F: _A, G: _A, Q: _A, H: Sequence[_A], R: Sequence[_A]
    ) -> Tuple[_Out[_D], _Out[_D], _Out[_D]]:
        """Steps 1..T-1 with y_t = Y[l][t] (Y[l] (T, m_l); row 0 not read),
        stacks indexed by the time: X (T-1, n), P (T-1, n, n), D (T-1, p)."""
    n: int
    m_max: int
    p: int

class TWNetworkBase(_TWFields[_D]):
    """The diffusion (Algorithm 2) and consensus (Algorithm 3) two-stage
    filters with unknown inputs of dkf/tw.h over one graph: adjacency
    (N, N) symmetric, nonzero for a link; weights dense (N, N), zero off
    the graph. Every field is every node's, stacked (N, ...)."""

    def __init__(self, x0: _A, P0: _A, *, adjacency: _A, m_max: int, p: int) -> None: ...
    def diffusion_step(
        self, y: Sequence[_A], *, alpha: _A, F: _A, G: _A, Q: _A, H: Sequence[_A],
        R: Sequence[_A]
    ) -> None:
        """Algorithm 2's step; alpha row-stochastic and >= 0 on the graph."""
    def consensus_step(
        self, y: Sequence[_A], *, W: _A, eta: int, F: _A, G: _A, Q: _A, H: Sequence[_A],
        R: Sequence[_A]
    ) -> None:
        """Algorithm 3's step; W doubly stochastic and >= 0, eta iterations."""
    def filter(
        self, Y: Sequence[_A], *, F: _A, G: _A, Q: _A, H: Sequence[_A], R: Sequence[_A],
        alpha: _O = None, W: _O = None, eta: Optional[int] = None
    ) -> Tuple[_Out[_D], _Out[_D], _Out[_D]]:
        """Steps 1..T-1 of the diffusion (alpha) or the consensus (W, eta):
        X (T-1, N, n), P (T-1, N, n, n), D (T-1, N, p)."""
    adjacency: _Out[_D]
    N: int
    n: int
    m_max: int
    p: int
    reals_sent: int
    broadcasts: int
    steps: int

class NLModelBase(Generic[_D]):
    """A nonlinear model with unknown inputs (dkf/nl_model.h) of Python
    callables: x' = f(x, d, u), y = h(x, d, u), each taking arrays (n,),
    (p,), (q,) and returning (n,) or (m,); f_jac -> (Fx (n, n), Fd (n, p)),
    h_jac -> (Hx (m, n), Hd (m, p)), or None (forward differences in the
    core). angles: the channels of y that are bearings (innovations
    wrapped into [-pi, pi)). An exception in a callable fails the step
    with dkf.ModelError, the exception its __cause__."""

    def __init__(
        self, f: Callable[..., _A], h: Callable[..., _A], *, n: int, m: int, p: int, q: int = 0,
        f_jac: Optional[Callable[..., Tuple[_A, _A]]] = None,
        h_jac: Optional[Callable[..., Tuple[_A, _A]]] = None, angles: Sequence[int] = ()
    ) -> None: ...
    @staticmethod
    def native(
        f: Any, h: Any, *, n: int, m: int, p: int, q: int = 0, f_jac: Any = None,
        h_jac: Any = None, angles: Sequence[int] = (), ctx: Optional[int] = None
    ) -> Any:
        """The model of native functions of the core's callback types
        (dkf/nl_model.h): `int f(void *ctx, size_t k, const real *x, const
        real *d, const real *u, real *x_next)`, h likewise, the Jacobians
        with two outputs (Fx, Fd / Hx, Hd). Each an address (int), an object
        with `address` (a numba cfunc) or a ctypes function; they run
        without the GIL; a non-zero return fails the step with
        dkf.ModelError ("model.h returned 7")."""
    native_model: bool
    n: int
    m: int
    p: int
    q: int
    angles: List[int]
    f: Any
    h: Any
    f_jac: Any
    h_jac: Any

class _NertsFields(Generic[_D]):
    """dkf/nerts.h's views, copies (DFNERTS: every node's, stacked (N, ...);
    the ones whose size depends on m a list, one array per node)."""

    x: _Out[_D]
    Px: _Out[_D]
    x_pred: _Out[_D]
    P_pred: _Out[_D]
    d: _Out[_D]
    Pd: _Out[_D]
    Pxd: _Out[_D]
    Y_pred: _Out[_D]
    y_pred: _Out[_D]
    Fx: _Out[_D]
    Fd: _Out[_D]
    z_hat: Any
    nu: Any
    h_c: Any
    Hx: Any
    R_tilde: Any
    Pzz: Any
    Pxz: Any
    Hd: Any
    C: Any
    Rbar: Any
    Rbar_inv: Any
    M: Any
    d_loc: _Out[_D]
    Pd_loc: _Out[_D]
    Pxd_loc: _Out[_D]
    i: _Out[_D]
    I: _Out[_D]
    Y: _Out[_D]
    y: _Out[_D]
    k: int

class NERTSBase(_NertsFields[_D]):
    """Seed 001's single-node joint state and unknown-input filters
    (dkf/nerts.h), kind "NERTSF", "NERTSIF" (EKF), "DNERTSF" or "DNERTSIF"
    (cubature). x0 (n,), P0 (n, n), d0 (p,), Pd0 (p, p), Pxd0 (n, p; None:
    0): x_{0|0} and the input's prior (all None with p = 0)."""

    def __init__(
        self, model: Any, x0: _A, P0: _A, *, kind: str, d0: _O = None, Pd0: _O = None,
        Pxd0: _O = None
    ) -> None: ...
    def predict(self, *, Q: _A, u: _O = None) -> None:
        """Phase 1: the time update with Q and the known input u_{k-1}."""
    def local(self, z: _A, *, R: _A, u: _O = None) -> None:
        """Phase 2: the local statistics of z_k."""
    def update(self) -> None:
        """Phase 3: the filter's own measurement update."""
    def commit_info(self, Y: _A, y: _A) -> None:
        """Phase 3 with a given information pair (information kinds)."""
    def step(self, z: _A, *, Q: _A, R: _A, u_prev: _O = None, u: _O = None) -> None:
        """The three phases in one call."""
    def filter(
        self, Z: _A, *, Q: _A, R: _A, U: _O = None
    ) -> Tuple[_Out[_D], _Out[_D], _Out[_D], _Out[_D]]:
        """Steps 1..T-1 with z_t = Z[t] (Z[0] not read), Q[t - 1], R[t]
        (one matrix or a stack indexed by the time): X, Px, D, Pd."""
    phase: int
    kind: str
    model: Any
    n: int
    m: int
    p: int

class DFNERTSBase(_NertsFields[_D]):
    """Seed 001's consensus network (dkf/dfnerts.h): DF-DNERTSIF (kind
    "DNERTSIF"), its EKF form ("NERTSIF"), DF-CKF (models with p = 0);
    variant "paper" (Algorithm 3) or "joint". models: one NLModel per
    node; the prior one for all nodes or one per node."""

    def __init__(
        self, models: Sequence[Any], x0: Any, P0: Any, *, adjacency: _A, kind: str = "DNERTSIF",
        variant: str = "paper", d0: Any = None, Pd0: Any = None, Pxd0: Any = None
    ) -> None: ...
    def step(
        self, z: Sequence[_A], *, Q: Any, R: Sequence[_A], W: _A, Tp: int, scale: float = 1.0,
        u_prev: _O = None, u: _O = None
    ) -> None:
        """Every node's local step, Tp consensus rounds with W (N, N),
        commit; Q one matrix for all nodes or one per node."""
    def filter(
        self, Z: Sequence[_A], *, Q: Any, R: Sequence[_A], W: _A, Tp: int, scale: float = 1.0,
        U: _O = None
    ) -> Tuple[_Out[_D], _Out[_D], _Out[_D], _Out[_D]]:
        """Steps 1..T-1 with z_t = Z[l][t]: X (T-1, N, n), Px, D, Pd."""
    adjacency: _Out[_D]
    N: int
    n: int
    m: List[int]
    p: int
    kind: str
    variant: str
    models: List[Any]
    reals_sent: int
    broadcasts: int

class DFNERTSNodeBase(_NertsFields[_D]):
    """One node of seed 001's consensus network (dkf/dfnerts.h's node API):
    its own NLModel and prior; its packets in and out as arrays."""

    def __init__(
        self, model: Any, x0: _A, P0: _A, *, kind: str = "DNERTSIF", variant: str = "paper",
        d0: _O = None, Pd0: _O = None, Pxd0: _O = None
    ) -> None: ...
    def local(
        self, z: _A, *, Q: _A, R: _A, scale: float = 1.0, u_prev: _O = None, u: _O = None
    ) -> _Out[_D]:
        """Time update and local statistics of z; returns the tau = 0 packet."""
    def mix(self, pkts: Sequence[_A], w: _A) -> _Out[_D]:
        """One round over the neighbourhood's packets (its own among them)
        with the weights w; returns the next packet."""
    def commit(self) -> None:
        """The posterior from the current packet."""
    def cancel(self) -> None:
        """Drops the pending step."""
    def restart(
        self, k: int, x0: _A, P0: _A, *, d0: _O = None, Pd0: _O = None, Pxd0: _O = None
    ) -> None:
        """A new prior, the posterior at step k."""
    def rejoin(self, k: int, pkt: _A, *, d0: _O = None, Pd0: _O = None) -> None:
        """The prior from a neighbour's packet, the posterior at step k."""
    pkt: _Out[_D]
    pkt_len: int
    q: int
    tau: int
    pending: bool
    scale: float
    k: int
    n: int
    m: int
    p: int
    kind: str
    variant: str
    model: Any
class NlmFamilyBase:
    """A built-in model family's C model (dkf-run's nlm_family.c and the
    callbacks of nlm_model.c); dkf.builtin_model wraps it in NLModel.native."""

    def __init__(
        self,
        family: str,
        *,
        n: int,
        m: int,
        p: int,
        A: Sequence[float],
        b: Sequence[float],
        C: Sequence[float],
        H: Sequence[float],
        T: float,
        phi_gain: float,
        omega_fixed: float,
        sensor_xy: Sequence[float],
        angles: Optional[Sequence[int]],
        path: str,
    ) -> None: ...
    def eval_f(self, x: Sequence[float], d: Sequence[float]) -> List[float]: ...
    m: int
    angles: List[int]
    R_default: List[float]
    failure: str
    ctx: int
    f: int
    h: int
    f_jac: int
    h_jac: int

class NlmStackBase:
    """The nodes' built-in C models stacked (dkf_nerts_stack)."""

    def __init__(self, families: List[NlmFamilyBase]) -> None: ...
    ctx: int
    f: int
    h: int
    f_jac: int
    h_jac: int
