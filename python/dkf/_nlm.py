"""dkf.builtin_model: dkf-run's built-in nonlinear model families as native
models (docs/guide/nl-models.md, "Built-in families"; docs/decisions.md item 75).

The family's arithmetic is dkf-run's own C (ports/linux/nlm/nlm_family.c)
and so are the callbacks around it (nlm_model.c: the state converted to
double, the values back to the core's real and checked for finiteness),
compiled into the extension module as _NlmFamily; the model is
NLModel.native over their addresses, so its filters give dkf-run's numbers
bit for bit.
"""

from __future__ import annotations

from typing import Any, List, Optional, Sequence, Tuple

import numpy as np

FAMILIES: Tuple[str, ...] = ("lin_x_sin_d", "s1_radar", "s1_radar_stacked", "s1_ckf")


class _Fn:
    """A native function's address (NLModel.native reads `address`); holding
    the C model that owns it, which the NLModel keeps alive through it."""

    __slots__ = ("address", "owner")

    def __init__(self, address: int, owner: Any) -> None:
        self.address = address
        self.owner = owner

    def __repr__(self) -> str:
        return "<native function 0x%x of a built-in model>" % self.address


def _array(where: str, v: Any, ndim: Tuple[int, ...]) -> np.ndarray:
    try:
        a = np.asarray(v, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError("%s: expected numbers" % where) from None
    if a.ndim not in ndim:
        raise ValueError("%s: expected %s" % (where, " or ".join(
            ("a vector", "a matrix")[d - 1] for d in ndim)))
    if not np.all(np.isfinite(a)):
        raise ValueError("%s: not finite" % where)
    return a


def _shape(where: str, a: np.ndarray, shape: Tuple[int, ...]) -> List[float]:
    if a.shape != shape:
        raise ValueError("%s: expected shape %s, got %s" % (where, shape, a.shape))
    return a.reshape(-1).tolist()


def _number(where: str, v: Any) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not np.isfinite(v):
        raise ValueError("%s: expected a finite number, got %r" % (where, v))
    return float(v)


def build(core: Any, family: str, *, n: Optional[int] = None, p: Optional[int] = None,
          A: Any = None, b: Any = None, C: Any = None, H: Any = None, T: float = 1.0,
          phi_gain: float = 10.0, omega_fixed: Optional[float] = None, sensor_xy: Any = None,
          angles: Optional[Sequence[int]] = None, path: str = "model") -> Tuple[Any, Any]:
    """(NLModel, its _NlmFamily) of `family` over core's module; path names
    the model in messages."""
    w = "builtin_model(%r)" % family if path == "model" else path
    if family not in FAMILIES:
        raise ValueError("%s: unknown family (built-in: %s)" % (w, ", ".join(FAMILIES)))
    lin = family == "lin_x_sin_d"
    ckf = family == "s1_ckf"
    m = 0
    flat = {"A": [], "b": [], "C": [], "H": []}
    if lin:
        for key, v in (("A", A), ("b", b), ("C", C), ("H", H)):
            if v is None:
                raise ValueError("%s.%s: missing (lin_x_sin_d: A, b, C, H)" % (w, key))
        Aa = _array(w + ".A", A, (2,))
        ba = _array(w + ".b", b, (1, 2))
        n = Aa.shape[0] if n is None else n
        p = (1 if ba.ndim == 1 else ba.shape[1]) if p is None else p
        if p < 1:
            raise ValueError("%s: lin_x_sin_d needs an unknown input (p >= 1)" % w)
        if ba.ndim == 1 and p != 1:
            raise ValueError("%s.b: a vector b is for p = 1; give an n x p matrix (p = %d)"
                             % (w, p))
        Ca = _array(w + ".C", C, (2,))
        m = Ca.shape[0]
        flat["A"] = _shape(w + ".A", Aa, (n, n))
        flat["b"] = _shape(w + ".b", ba, (n,) if ba.ndim == 1 else (n, p))
        flat["C"] = _shape(w + ".C", Ca, (m, n))
        flat["H"] = _shape(w + ".H", _array(w + ".H", H, (2,)), (m, p))
    else:
        want_p = 0 if ckf else 1
        n = 4 if n is None else n
        p = want_p if p is None else p
        if n != 4 or p != want_p:
            raise ValueError("%s: family %s has n = 4 (xi, xi_dot, eta, eta_dot) and p = %d; "
                             "got n = %d, p = %d" % (w, family, want_p, n, p))
        if ckf and omega_fixed is None:
            raise ValueError("%s.omega_fixed: missing (s1_ckf's fixed turn rate)" % w)
        if sensor_xy is None:
            raise ValueError("%s.sensor_xy: missing" % w)
        xy = _array(w + ".sensor_xy", sensor_xy, (2,) if family == "s1_radar_stacked" else (1,))
        if xy.shape[-1] != 2 or xy.size == 0:
            raise ValueError("%s.sensor_xy: expected [x, y]%s" % (
                w, " per sensor" if xy.ndim == 2 else ""))
        sensor_xy = xy.reshape(-1).tolist()
    owner = core._NlmFamily(
        family, n=n, m=m, p=p, A=flat["A"], b=flat["b"], C=flat["C"], H=flat["H"],
        T=_number(w + ".T", T), phi_gain=_number(w + ".phi_gain", phi_gain),
        omega_fixed=_number(w + ".omega_fixed", 0.0 if omega_fixed is None else omega_fixed),
        sensor_xy=sensor_xy or [], angles=None if angles is None else list(angles), path=path)
    model = core.NLModel.native(
        _Fn(owner.f, owner), _Fn(owner.h, owner), n=n, m=owner.m, p=p,
        f_jac=_Fn(owner.f_jac, owner), h_jac=_Fn(owner.h_jac, owner), angles=owner.angles,
        ctx=owner.ctx)
    return model, owner


def for_module(core: Any):
    """dkf.builtin_model (or dkf.float32.builtin_model) over that module."""

    def builtin_model(family: str, *, n: Optional[int] = None, p: Optional[int] = None,
                      A: Any = None, b: Any = None, C: Any = None, H: Any = None,
                      T: float = 1.0, phi_gain: float = 10.0,
                      omega_fixed: Optional[float] = None, sensor_xy: Any = None,
                      angles: Optional[Sequence[int]] = None):
        """The NLModel of a dkf-run built-in family (lin_x_sin_d, s1_radar,
        s1_radar_stacked, s1_ckf) with the scenario keys' parameters: dkf-run's
        own C functions as a native model (docs/guide/nl-models.md)."""
        return build(core, family, n=n, p=p, A=A, b=b, C=C, H=H, T=T, phi_gain=phi_gain,
                     omega_fixed=omega_fixed, sensor_xy=sensor_xy, angles=angles)[0]

    return builtin_model
