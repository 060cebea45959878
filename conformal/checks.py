"""Argument checks shared by ``conformal``, ``models`` and ``envs``: one wording, one rule per kind.

Every public function of the three packages validates what it is given before it computes or
allocates anything, so bad input ends in a clear exception that names the argument, says what
was expected and what was received, instead of a silent NaN, a truncation, an internal
traceback (numba, MuJoCo, IndexError) or an unbounded allocation:

* a value of the wrong *type* (a string or ``None`` for a number, a complex number or array
  where a real one is expected, a bool where a number is expected, a number where a bool is
  expected, an object array) raises :class:`InputTypeError`;
* a value of the right type but a wrong *value* (NaN, infinity, out of range, a non-integral
  number for a count, a wrong shape) raises ``ValueError``.

:class:`InputTypeError` is both a ``TypeError`` and a ``ValueError``: code written against the
earlier contract (every bad input is a ``ValueError``) keeps working.

Sizes are bounded (see each function's docstring) so that no argument can make the library
allocate without limit; the bounds are far above any use in the paper or the experiments.
"""

from __future__ import annotations

import math
import numbers
import operator
from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["InputTypeError", "integer", "real", "flag", "choice", "array", "callable_"]


class InputTypeError(TypeError, ValueError):
    """An argument of the wrong type (also a ``ValueError``, the library's earlier contract)."""


def _show(value) -> str:
    """A short repr of a received value for messages."""
    if isinstance(value, np.ndarray):
        return f"an array of shape {value.shape} and dtype {value.dtype}"
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def _interval(lo, hi, lo_open: bool = False, hi_open: bool = False) -> str:
    if lo is None and hi is None:
        return ""
    if hi is None:
        return f" {'>' if lo_open else '>='} {lo}"
    if lo is None:
        return f" {'<' if hi_open else '<='} {hi}"
    return f" in {'(' if lo_open else '['}{lo}, {hi}{')' if hi_open else ']'}"


def _scalar(value):
    """A 0-d array or numpy scalar as a Python scalar; anything else unchanged."""
    if isinstance(value, np.ndarray) and value.ndim == 0:
        return value.item()
    if isinstance(value, np.generic):
        return value.item()
    return value


def _real_scalar(value, exact: type, what):
    """``value`` itself when its type is ``exact``, else as a Python scalar (numpy's unwrapped), which must
    be a real number and not a bool (else :class:`InputTypeError` with ``what()``, the check's demand)."""
    if type(value) is exact:
        return value
    v = _scalar(value)
    if type(v) is not exact and (isinstance(v, bool) or not isinstance(v, numbers.Real)):
        raise InputTypeError(f"{what()}; got {_show(value)} of type {type(value).__name__}")
    return v


def integer(name: str, value, lo: int | None = None, hi: int | None = None, *, hint: str = "") -> int:
    """``value`` as an ``int`` in [lo, hi] (either bound may be None).

    Accepts Python and numpy integers and integral floats (``128.0``); rejects non-integral
    numbers (``7.5``: ``ValueError``, never truncated), NaN and infinity (``ValueError``) and
    bools, strings, complex numbers and other types (:class:`InputTypeError`).
    """

    def what() -> str:  # the message is built only for a refusal (this check sits on hot paths)
        return f"{name} must be an integer{_interval(lo, hi)}{f' ({hint})' if hint else ''}"

    v = _real_scalar(value, int, what)
    if type(v) is int:
        i = v
    elif isinstance(v, numbers.Integral):
        i = operator.index(v)
    else:
        f = float(v)
        if not math.isfinite(f) or not f.is_integer():
            raise ValueError(f"{what()}; got {_show(value)}")
        i = int(f)
    if (lo is not None and i < lo) or (hi is not None and i > hi):
        raise ValueError(f"{what()}; got {i}")
    return i


def real(
    name: str,
    value,
    lo: float | None = None,
    hi: float | None = None,
    *,
    lo_open: bool = False,
    hi_open: bool = False,
    hint: str = "",
) -> float:
    """``value`` as a finite ``float`` in the interval given by ``lo``/``hi`` (closed unless
    ``lo_open``/``hi_open``; either bound may be None).

    Rejects NaN, infinity and values outside the interval (``ValueError``) and bools, strings,
    ``None``, complex numbers and other types (:class:`InputTypeError`).
    """

    def what() -> str:  # the message is built only for a refusal (this check sits on hot paths)
        return f"{name} must be a finite real number{_interval(lo, hi, lo_open, hi_open)}{f' ({hint})' if hint else ''}"

    v = _real_scalar(value, float, what)
    if type(v) is float:
        f = v
    else:
        try:
            f = float(v)
        except OverflowError:  # a huge int
            raise ValueError(f"{what()}; got {_show(value)}") from None
    bad = not math.isfinite(f)
    if lo is not None:
        bad |= f <= lo if lo_open else f < lo
    if hi is not None:
        bad |= f >= hi if hi_open else f > hi
    if bad:
        raise ValueError(f"{what()}; got {_show(value)}")
    return f


def flag(name: str, value) -> bool:
    """``value`` as a ``bool``: only ``True``/``False`` (and numpy bools) are accepted; strings such
    as ``"no"``, numbers and ``None`` raise :class:`InputTypeError` (``bool("no")`` is True)."""
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    raise InputTypeError(f"{name} must be True or False; got {_show(value)} of type {type(value).__name__}")


def choice(name: str, value, options: Sequence, *, allow_none: bool = False):
    """``value`` if it is one of ``options`` (strings compare only to strings, other options only to
    values of their own type, so ``1`` never matches ``True`` nor ``"1"``)."""
    if value is None and allow_none:
        return None
    listed = ", ".join(repr(o) for o in options) + (", None" if allow_none else "")

    def same_kind(o) -> bool:
        return isinstance(value, str) and isinstance(o, str) or type(value) is type(o)

    try:
        ok = any(same_kind(o) and value == o for o in options)
    except Exception:  # an object whose == misbehaves
        ok = False
    if not ok:
        exc = ValueError if isinstance(value, str) else InputTypeError
        raise exc(f"{name} must be one of {listed}; got {_show(value)}")
    return value


def _kind_words(kinds: str) -> str:
    """'a real (bool, integer or float) array' and the like, for messages."""
    named = {
        "biufc": "a numeric",
        "biuf": "a real (bool, integer or float)",
        "iuf": "an integer or float",
        "uf": "an unsigned integer or float",
        "f": "a float",
        "b": "a bool",
        "fc": "a float or complex",
    }
    return named.get(kinds, f"a numeric (dtype kind {', '.join(kinds)})")


def array(
    name: str, a: ArrayLike, *, kinds: str = "biuf", shape: tuple | None = None, ndim=None, finite: bool = True
) -> NDArray:
    """``a`` as a numpy array (no copy when it already is one) with checked dtype kind, shape and values.

    ``kinds``: the accepted numpy dtype kinds ("b" bool, "i"/"u" integers, "f" float, "c" complex);
    another kind (complex where real is expected, strings, objects) raises :class:`InputTypeError`.
    ``shape``: the exact shape, ``None`` entries matching any length; ``ndim``: an int or a tuple of
    accepted numbers of dimensions. ``finite``: reject NaN and infinity. Ragged nested sequences
    raise ``ValueError``.
    """
    if isinstance(a, (str, bytes)) or a is None:
        raise InputTypeError(f"{name} must be a numeric array; got {_show(a)} of type {type(a).__name__}")
    try:
        x = np.asarray(a)
    except (ValueError, TypeError) as exc:  # ragged nesting, objects numpy cannot hold
        raise ValueError(f"{name} must be a rectangular numeric array; got {_show(a)} ({exc})") from None
    extended = (x.dtype.kind == "f" and x.dtype.itemsize > 8) or (x.dtype.kind == "c" and x.dtype.itemsize > 16)
    if x.dtype.kind not in kinds or extended:
        extra = " (extended precision is not supported: convert to float64 or complex128)" if extended else ""
        raise InputTypeError(f"{name} must be {_kind_words(kinds)} array; got dtype {x.dtype}{extra}")
    if ndim is not None:
        allowed = (ndim,) if isinstance(ndim, int) else tuple(ndim)
        if x.ndim not in allowed:
            raise ValueError(f"{name} must have {' or '.join(map(str, allowed))} dimensions; got shape {x.shape}")
    if shape is not None and (x.ndim != len(shape) or any(s is not None and s != d for s, d in zip(shape, x.shape))):
        want = "(" + ", ".join("any" if s is None else str(s) for s in shape) + ("," if len(shape) == 1 else "") + ")"
        raise ValueError(f"{name} must have shape {want}; got {x.shape}")
    if finite and x.dtype.kind in "fc" and not np.isfinite(x).all():
        raise ValueError(f"{name} contains NaN or infinite values")
    return x


def callable_(name: str, value) -> None:
    """Raise :class:`InputTypeError` unless ``value`` is callable."""
    if not callable(value):
        raise InputTypeError(f"{name} must be callable; got {_show(value)} of type {type(value).__name__}")
