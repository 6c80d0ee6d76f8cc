"""Expression models: an NLModel from strings in the syntax of a scenario's
`"expr"` model (docs/guide/nl-models.md), parsed by sympy and compiled to
numpy by sympy's lambdify (docs/decisions.md item 69).

The variables are x1..xn (n = len(f)) and d1..dp; the functions those of
the scenario's expressions: + - * / ^ (power), parentheses, sin cos tan
asin acos atan sinh cosh tanh exp log ln log10 log2 sqrt abs sign rint min
max sum avg atan2 hypot and the constant pi. Anything else, muparser's
comparisons and `c ? a : b` among them, is refused with a ValueError naming
the expression.
"""

from __future__ import annotations

import re
from typing import Callable, Optional, Sequence

import numpy as np

_FUNCS = ("sin", "cos", "tan", "asin", "acos", "atan", "sinh", "cosh", "tanh", "exp", "log",
          "ln", "log10", "log2", "sqrt", "abs", "sign", "rint", "min", "max", "sum", "avg",
          "atan2", "hypot")
_IDENT = re.compile(r"[A-Za-z_][A-Za-z_0-9]*")
_ALLOWED = re.compile(r"[A-Za-z_0-9\s+\-*/^(),.]*")


def _names(sympy):
    """The functions and constants an expression may use, as sympy objects;
    the ones numpy has under another name are sympy Functions that lambdify
    maps to numpy (_NUMPY)."""

    class hypot(sympy.Function):  # noqa: N801 (the expression's name)
        nargs = 2

    class rint(sympy.Function):  # noqa: N801
        nargs = 1

    class log10(sympy.Function):  # noqa: N801
        nargs = 1

    class log2(sympy.Function):  # noqa: N801
        nargs = 1

    return {
        "sin": sympy.sin, "cos": sympy.cos, "tan": sympy.tan, "asin": sympy.asin,
        "acos": sympy.acos, "atan": sympy.atan, "sinh": sympy.sinh, "cosh": sympy.cosh,
        "tanh": sympy.tanh, "exp": sympy.exp, "log": sympy.log, "ln": sympy.log,
        "sqrt": sympy.sqrt, "abs": sympy.Abs, "sign": sympy.sign, "min": sympy.Min,
        "max": sympy.Max, "sum": lambda *a: sympy.Add(*a),
        "avg": lambda *a: sympy.Add(*a) / len(a), "atan2": sympy.atan2, "pi": sympy.pi,
        "hypot": hypot, "rint": rint, "log10": log10, "log2": log2,
    }


_NUMPY = {"hypot": np.hypot, "rint": np.rint, "log10": np.log10, "log2": np.log2}


def _parse(sympy, text, where: str, local: dict):
    from sympy.parsing.sympy_parser import (convert_xor, parse_expr,
                                            standard_transformations)

    text = str(text)
    if not _ALLOWED.fullmatch(text):
        bad = next(c for c in text if not _ALLOWED.fullmatch(c))
        raise ValueError(f"{where}: {text!r}: {bad!r} is not supported (the operators are "
                         "+ - * / ^ and parentheses)")
    for name in _IDENT.findall(text):
        if name not in local:
            names = sorted(k for k in local if k not in _FUNCS and k != "pi")
            raise ValueError(f"{where}: {text!r}: unknown variable or function {name!r} "
                             f"(variables: {', '.join(names) or 'none'})")
    try:
        return parse_expr(text, local_dict=local,
                          transformations=standard_transformations + (convert_xor,))
    except Exception as e:  # sympy's syntax and type errors
        raise ValueError(f"{where}: {text!r}: {e}") from e


def _compile(sympy, rows, where, local, args):
    """A function of (x, d) giving the values of the expressions `rows` (a
    list of strings, or a list of lists of them: a matrix) as an array."""
    matrix = bool(rows) and not isinstance(rows[0], str) and isinstance(rows[0], Sequence)
    if matrix:
        exprs = [[_parse(sympy, e, f"{where}[{i}][{j}]", local) for j, e in enumerate(row)]
                 for i, row in enumerate(rows)]
    else:
        exprs = [_parse(sympy, e, f"{where}[{i}]", local) for i, e in enumerate(rows)]
    fn = sympy.lambdify(args, exprs, modules=[_NUMPY, "numpy"])
    # in double for either core, as dkf-run's muparser (numpy would keep float32)
    return lambda x, d: np.array(fn(np.asarray(x, dtype=np.float64),
                                    np.asarray(d, dtype=np.float64)), dtype=np.float64)


def build(NLModel, f: Sequence[str], g: Sequence[str], *, p: int,
          A: Optional[Sequence[Sequence[str]]] = None, G: Optional[Sequence[Sequence[str]]] = None,
          C: Optional[Sequence[Sequence[str]]] = None, H: Optional[Sequence[Sequence[str]]] = None,
          angles: Sequence[int] = ()):
    """The NLModel of the expressions f (n strings), g (m strings), with
    the Jacobians A = df/dx, G = df/dd, C = dg/dx, H = dg/dd as matrices of
    strings where given (A with G, C with H; with p = 0 A and C alone),
    else None (the core's forward differences)."""
    import sympy

    if isinstance(f, str) or isinstance(g, str):
        raise TypeError("expr_model: f and g are sequences of strings, one per component")
    n, m = len(f), len(g)
    xs = sympy.symbols(f"x1:{n + 1}") if n else ()
    ds = sympy.symbols(f"d1:{p + 1}") if p else ()
    local = dict(_names(sympy))
    local.update({str(s): s for s in (*xs, *ds)})
    args = (list(xs), list(ds))
    fx = _compile(sympy, list(f), "f", local, args)
    gx = _compile(sympy, list(g), "g", local, args)

    def jac(J, Jd, names, rows):
        if J is None and Jd is None:
            return None
        if J is None or (p and Jd is None) or (not p and Jd is not None):
            need = f"{names[0]} and {names[1]} together" if p else f"{names[0]} alone (p = 0)"
            raise ValueError(f"expr_model: give {need}, or neither")
        jx = _compile(sympy, [list(r) for r in J], names[0], local, args)
        jd = _compile(sympy, [list(r) for r in Jd], names[1], local, args) if p else None
        empty = np.zeros((rows, 0))
        return lambda x, d, u: (jx(x, d), jd(x, d) if p else empty)

    return NLModel(lambda x, d, u: fx(x, d), lambda x, d, u: gx(x, d), n=n, m=m, p=p,
                   f_jac=jac(A, G, ("A", "G"), n), h_jac=jac(C, H, ("C", "H"), m),
                   angles=list(angles))


def for_module(NLModel) -> Callable:
    """dkf.expr_model (or dkf.float32.expr_model) over that module's NLModel."""

    def expr_model(f, g, *, p, A=None, G=None, C=None, H=None, angles=()):
        return build(NLModel, f, g, p=p, A=A, G=G, C=C, H=H, angles=angles)

    expr_model.__doc__ = build.__doc__
    return expr_model
