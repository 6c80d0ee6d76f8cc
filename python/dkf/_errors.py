"""dkf.Error and one subclass per dkf_status_t (include/dkf/status.h)."""

from __future__ import annotations

from typing import Dict, Optional, Type


class Error(Exception):
    """A dkf call failed; the object it was called on is as it was before.

    status: the dkf_status_t value (negative); call: the method, e.g.
    "KalmanFilter.update"; step: the step of filter() that failed (its row
    of Y, from 0) or None; matrix: the input the status concerns ("P0",
    "R", ...) or None; node: the sensor a fusion centre's failure names, or
    None.
    """

    status: int = 0

    def __init__(
        self,
        message: str,
        *,
        call: Optional[str] = None,
        step: Optional[int] = None,
        matrix: Optional[str] = None,
        node: Optional[int] = None,
    ) -> None:
        super().__init__(message)
        self.call = call
        self.step = step
        self.matrix = matrix
        self.node = node


class NullError(Error):
    """DKF_ERR_NULL: a required pointer argument is NULL."""

    status = -1


class DimError(Error):
    """DKF_ERR_DIM: dimensions of the arguments do not agree."""

    status = -2


class CapacityError(Error):
    """DKF_ERR_CAPACITY: larger than DKF_MAX_DIM or than the storage given."""

    status = -3


class NonFiniteError(Error):
    """DKF_ERR_NONFINITE: NaN or infinity in an input, or an overflow."""

    status = -4


class NotSPDError(Error):
    """DKF_ERR_NOT_SPD: a matrix must be symmetric positive definite."""

    status = -5


class SingularError(Error):
    """DKF_ERR_SINGULAR: a matrix is (numerically) singular."""

    status = -6


class RankError(Error):
    """DKF_ERR_RANK: a rank condition of the algorithm is violated."""

    status = -7


class AliasError(Error):
    """DKF_ERR_ALIAS: an output overlaps an input where that is not allowed."""

    status = -8


class NoConvergenceError(Error):
    """DKF_ERR_NO_CONVERGENCE: an iterative method hit its iteration limit."""

    status = -9


class StateError(Error):
    """DKF_ERR_STATE: a call out of sequence."""

    status = -10


class ArgError(Error):
    """DKF_ERR_ARG: an argument is outside its domain."""

    status = -11


class GraphError(Error):
    """DKF_ERR_GRAPH: a malformed graph, or a link that is not in it."""

    status = -12


class WeightsError(Error):
    """DKF_ERR_WEIGHTS: weights not (row/doubly) stochastic, or negative."""

    status = -13


class ModelError(Error):
    """DKF_ERR_MODEL: a user model callback reported failure."""

    status = -14


class UnstableError(Error):
    """DKF_ERR_UNSTABLE: no stabilising solution of a Riccati / Stein equation."""

    status = -15


BY_STATUS: Dict[int, Type[Error]] = {
    c.status: c
    for c in (
        NullError,
        DimError,
        CapacityError,
        NonFiniteError,
        NotSPDError,
        SingularError,
        RankError,
        AliasError,
        NoConvergenceError,
        StateError,
        ArgError,
        GraphError,
        WeightsError,
        ModelError,
        UnstableError,
    )
}


def _make(
    status: int,
    text: str,
    call: str,
    step: Optional[int],
    matrix: Optional[str],
    detail: str,
    node: Optional[int] = None,
) -> Error:
    """The exception the extension raises for a failed call (status < 0)."""
    cls = BY_STATUS.get(status, Error)
    where = call if step is None else f"{call}, step {step}"
    message = f"{where}: {text}" + (f": {detail}" if detail else "")
    e = cls(message, call=call, step=step, matrix=matrix, node=node)
    if cls is Error:
        e.status = status
    return e
