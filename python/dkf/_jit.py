"""dkf.jit_model: an NLModel of Python functions compiled to native code by
numba (docs/guide/python.md, "Native models"; docs/decisions.md item 72).

Each function fills its output array in place and returns nothing:

    f(x, d, u, x_next)     h(x, d, u, y)
    f_jac(x, d, u, Fx, Fd) h_jac(x, d, u, Hx, Hd)

x (n,), d (p,), u (q,) and the outputs are arrays of the module's dtype
over the filter's own memory. numba compiles each (nopython mode) into a C
callback of the core's type (`numba.cfunc`), which NLModel.native plugs in:
the filter's steps then call it directly, without Python or the GIL.
"""

from __future__ import annotations

from typing import Callable, Optional, Sequence


def _numba():
    try:
        import numba
    except ImportError as e:  # an optional dependency
        raise ImportError("dkf.jit_model needs numba: pip install numba "
                          "(or pip install dkf[jit])") from e
    return numba


def _compile(numba, real, fn: Callable, name: str, ins, outs):
    """fn(x, d, u, *outs) as a cfunc `int (void *ctx, size_t k, const real
    *x, const real *d, const real *u, real *out...)`; ins, outs the shapes."""
    types = numba.types
    carray = numba.carray
    try:
        body = numba.njit(fn)
    except Exception as e:  # noqa: BLE001 (numba's own error types vary)
        raise TypeError(f"jit_model: {name}: numba cannot compile it: {e}") from e
    ptr = types.CPointer(real)
    sx, sd, su = ins
    if len(outs) == 1:
        (so,) = outs
        sig = types.int32(types.voidptr, types.uintp, ptr, ptr, ptr, ptr)

        def one(ctx, k, x, d, u, o):
            body(carray(x, sx), carray(d, sd), carray(u, su), carray(o, so))
            return 0

        wrapper = one
    else:
        s1, s2 = outs
        sig = types.int32(types.voidptr, types.uintp, ptr, ptr, ptr, ptr, ptr)

        def two(ctx, k, x, d, u, o1, o2):
            body(carray(x, sx), carray(d, sd), carray(u, su), carray(o1, s1), carray(o2, s2))
            return 0

        wrapper = two
    try:
        return numba.cfunc(sig, nopython=True)(wrapper)
    except Exception as e:  # noqa: BLE001
        raise TypeError(f"jit_model: {name}: numba cannot compile it for arrays of "
                        f"{real}: {type(e).__name__}: {e}") from e


def for_module(NLModel, dtype: str):
    """dkf.jit_model (or dkf.float32.jit_model) over that module's NLModel."""

    def jit_model(f: Callable, h: Callable, *, n: int, m: int, p: int = 0, q: int = 0,
                  f_jac: Optional[Callable] = None, h_jac: Optional[Callable] = None,
                  angles: Sequence[int] = ()):
        """An NLModel whose f, h (and Jacobians) numba compiles to native code.

        f(x, d, u, x_next) writes x_next (n,); h(x, d, u, y) writes y (m,);
        f_jac(x, d, u, Fx, Fd) writes Fx (n, n), Fd (n, p); h_jac(x, d, u,
        Hx, Hd) writes Hx (m, n), Hd (m, p). None for a Jacobian: the core's
        forward differences. A function cannot fail except by writing a
        non-finite value, which the step reports as dkf.NonFiniteError.
        The model's f, h, f_jac, h_jac are the numba cfuncs.
        """
        numba = _numba()
        for v, name in ((n, "n"), (m, "m"), (p, "p"), (q, "q")):
            if not isinstance(v, int) or isinstance(v, bool) or v < 0:
                raise TypeError(f"jit_model: {name} must be an int >= 0")
        real = getattr(numba.types, dtype)
        ins = ((n,), (p,), (q,))
        cf = _compile(numba, real, f, "f", ins, [(n,)])
        ch = _compile(numba, real, h, "h", ins, [(m,)])
        cfj = None if f_jac is None else _compile(numba, real, f_jac, "f_jac", ins,
                                                  [(n, n), (n, p)])
        chj = None if h_jac is None else _compile(numba, real, h_jac, "h_jac", ins,
                                                  [(m, n), (m, p)])
        return NLModel.native(cf, ch, n=n, m=m, p=p, q=q, f_jac=cfj, h_jac=chj,
                              angles=list(angles))

    return jit_model
