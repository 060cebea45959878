"""``conformal.checks``, the argument checks every public name of ``conformal``, ``models`` and
``envs`` validates its input with, tested exhaustively once (issue 21, item 10).

The per-argument tests (``tests/test_adversarial_api.py``) then only have to show that each
public argument goes through one of these checks (a wrong type, NaN or infinity raises naming the
argument) and that its bounds are the documented ones; every kind of hostile value a check must
refuse is tried here: NaN, +-infinity, wrong types (str, bytes, None, complex, lists, dicts,
objects, arrays), bools, non-integral and huge values, numpy scalars and 0-d arrays, every dtype
kind, ragged nesting, wrong shapes and dimensions, and objects whose ``==`` raises.
"""

from __future__ import annotations

import math
import re
from fractions import Fraction

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from conformal import checks
from conformal.checks import InputTypeError

pytestmark = pytest.mark.adversarial

NAN, INF = float("nan"), float("inf")


def _repr(value) -> str:
    """A test id: ``repr`` without memory addresses (``<object object at 0x...>``), so that every
    pytest-xdist worker collects the same ids."""
    return re.sub(r" at 0x[0-9a-fA-F]+", "", repr(value))


class BadEq:
    """An object whose ``==`` raises (numpy arrays of it, pandas-like objects)."""

    def __eq__(self, other):
        raise RuntimeError("no comparison")

    __hash__ = object.__hash__


#: values of the wrong *type* for a number: InputTypeError (both a TypeError and a ValueError)
NOT_NUMBERS = ["1", b"1", None, 1j, complex(1, 0), [1], (1,), {1: 1}, object(), np.ones(2), np.array([1.0]),
               np.complex128(1), np.array(1j), np.str_("1"), True, False, np.True_, np.bool_(False), BadEq()]
#: values of the right type but no finite value: ValueError
NON_FINITE = [NAN, INF, -INF, np.float32(NAN), np.float64(INF), np.array(NAN), np.float16(-INF)]


def test_input_type_error_is_both_type_and_value_error():
    assert issubclass(InputTypeError, TypeError) and issubclass(InputTypeError, ValueError)
    assert set(checks.__all__) == {"InputTypeError", "integer", "real", "flag", "choice", "array", "callable_"}


# ---------------------------------------------------------------------- integer
@pytest.mark.parametrize("value", NOT_NUMBERS, ids=_repr)
def test_integer_refuses_wrong_types(value):
    with pytest.raises(InputTypeError, match=r"^count must be an integer.*; got .* of type"):
        checks.integer("count", value)


@pytest.mark.parametrize("value", NON_FINITE + [1.5, -0.5, 2.0000001, np.float32(7.5), np.array(7.5), 1e-300,
                                                Fraction(3, 2)], ids=_repr)
def test_integer_refuses_non_integral_and_non_finite_values(value):
    with pytest.raises(ValueError, match="^count must be an integer") as info:
        checks.integer("count", value)
    assert not isinstance(info.value, TypeError)  # a value error, not a type error: never truncated


@pytest.mark.parametrize("value, expected", [(3, 3), (3.0, 3), (-2.0, -2), (np.int8(5), 5), (np.uint64(2**63), 2**63),
                                              (np.float32(4), 4), (np.array(6), 6), (np.array(6.0), 6),
                                              (Fraction(4, 2), 2), (10**30, 10**30), (1e20, 10**20)], ids=_repr)
def test_integer_accepts_integral_numbers_of_any_kind(value, expected):
    out = checks.integer("count", value)
    assert type(out) is int and out == expected


@pytest.mark.parametrize("value, lo, hi", [(-1, 0, None), (11, None, 10), (0, 1, 10), (10**12, 0, 4096), (1e9, 0, 4096),
                                           (np.int64(-5), 0, 10), (2**63, 0, 2**63 - 1)])
def test_integer_refuses_values_out_of_bounds(value, lo, hi):
    with pytest.raises(ValueError, match=r"count must be an integer (in|>=|<=).*; got -?\d+$"):
        checks.integer("count", value, lo, hi)


def test_integer_bounds_are_inclusive_and_messages_say_them():
    assert checks.integer("n", 0, 0, 10) == 0 and checks.integer("n", 10, 0, 10) == 10
    with pytest.raises(ValueError, match=r"n must be an integer in \[1, 4\] \(a hint\); got 5"):
        checks.integer("n", 5, 1, 4, hint="a hint")
    with pytest.raises(ValueError, match=r"n must be an integer >= 1; got 0"):
        checks.integer("n", 0, 1)
    with pytest.raises(ValueError, match=r"n must be an integer <= 1; got 2"):
        checks.integer("n", 2, None, 1)


@settings(max_examples=200, deadline=None)
@given(st.one_of(st.floats(), st.integers(-10**20, 10**20)))
def test_integers_are_never_truncated(x):
    try:
        n = checks.integer("n", x)
    except ValueError as exc:
        assert "n must be an integer" in str(exc)
        assert not (isinstance(x, int) or (np.isfinite(x) and float(x).is_integer()))
    else:
        assert type(n) is int and n == x


# ---------------------------------------------------------------------- real
@pytest.mark.parametrize("value", NOT_NUMBERS, ids=_repr)
def test_real_refuses_wrong_types(value):
    with pytest.raises(InputTypeError, match=r"^level must be a finite real number.*; got .* of type"):
        checks.real("level", value)


@pytest.mark.parametrize("value", NON_FINITE + [10**400, -(10**400)], ids=lambda v: repr(v)[:20])
def test_real_refuses_non_finite_and_overflowing_values(value):
    with pytest.raises(ValueError, match="^level must be a finite real number") as info:
        checks.real("level", value)
    assert not isinstance(info.value, TypeError)


@pytest.mark.parametrize("value, kw", [
    (-0.1, dict(lo=0.0)), (0.0, dict(lo=0.0, lo_open=True)), (1.0, dict(hi=1.0, hi_open=True)), (1.5, dict(hi=1.0)),
    (1e300, dict(lo=0.0, hi=1e6)), (-1e300, dict(lo=-5.0, hi=5.0)), (np.float32(2), dict(hi=1.0)),
    (5e-324, dict(lo=1e-300)), (np.nextafter(1.0, 2.0), dict(hi=1.0))])
def test_real_refuses_values_out_of_bounds(value, kw):
    with pytest.raises(ValueError, match=r"level must be a finite real number (in|>|<)"):
        checks.real("level", value, **kw)


def test_real_bounds_and_messages():
    assert checks.real("x", 0.0, 0.0, 1.0) == 0.0 and checks.real("x", 1.0, 0.0, 1.0) == 1.0
    with pytest.raises(ValueError, match=r"x must be a finite real number in \(0.0, 1.0\) \(why\); got 1.0"):
        checks.real("x", 1.0, 0.0, 1.0, lo_open=True, hi_open=True, hint="why")
    with pytest.raises(ValueError, match=r"x must be a finite real number > 0; got 0"):
        checks.real("x", 0, 0, lo_open=True)
    with pytest.raises(ValueError, match=r"x must be a finite real number <= 1; got 2"):
        checks.real("x", 2, None, 1)


@pytest.mark.parametrize("value", [3, -2.5, np.float16(0.5), np.int64(7), np.array(1.25), np.uint8(200), Fraction(1, 4),
                                   1e308, 10**300], ids=_repr)
def test_real_accepts_finite_reals_of_any_kind(value):
    out = checks.real("level", value)
    assert type(out) is float and out == float(value)


@settings(max_examples=200, deadline=None)
@given(st.floats(), st.floats(-1e6, 1e6), st.floats(0, 1e6))
def test_real_returns_a_finite_float_in_bounds_or_refuses(x, lo, width):
    hi = lo + width
    try:
        f = checks.real("x", x, lo, hi)
    except ValueError as exc:
        assert str(exc).startswith("x must be a finite real number")
        assert not (math.isfinite(x) and lo <= x <= hi)
    else:
        assert type(f) is float and math.isfinite(f) and lo <= f <= hi


# ---------------------------------------------------------------------- flag
@pytest.mark.parametrize("value", ["no", "False", "", "True", 1, 0, 1.0, 0.0, None, np.array([True]), np.int64(1), [True],
                                   np.array([True, False]), b"\x00", BadEq()], ids=_repr)
def test_flag_refuses_anything_but_bools(value):
    with pytest.raises(InputTypeError, match="^switch must be True or False; got"):
        checks.flag("switch", value)


@pytest.mark.parametrize("value", [True, False, np.True_, np.False_, np.bool_(1)], ids=_repr)
def test_flag_accepts_python_and_numpy_bools(value):
    out = checks.flag("switch", value)
    assert type(out) is bool and out == bool(value)


# ---------------------------------------------------------------------- choice
OPTS = ("red", "green")


@pytest.mark.parametrize("value, exc", [
    ("blue", ValueError), ("", ValueError), ("RED", ValueError), ("red ", ValueError), (np.str_("blue"), ValueError),
    (None, InputTypeError), (1, InputTypeError), (["red"], InputTypeError), (b"red", InputTypeError),
    (("red",), InputTypeError), (NAN, InputTypeError), (BadEq(), InputTypeError), (np.array(["red"]), InputTypeError)],
    ids=_repr)
def test_choice_refuses_values_not_listed(value, exc):
    with pytest.raises(exc, match=r"^colour must be one of 'red', 'green'; got"):
        checks.choice("colour", value, OPTS)


def test_choice_compares_only_like_types():
    assert checks.choice("c", "red", OPTS) == "red"
    assert checks.choice("c", np.str_("green"), OPTS) == "green"  # a str subclass
    assert checks.choice("c", None, OPTS, allow_none=True) is None
    with pytest.raises(InputTypeError, match="one of 1, 2, None"):
        checks.choice("c", True, (1, 2), allow_none=True)  # True == 1, but not the same type
    with pytest.raises(InputTypeError):
        checks.choice("c", 1.0, (1, 2))
    assert checks.choice("c", 2, (1, 2)) == 2


# ---------------------------------------------------------------------- array
GOOD = np.zeros((2, 3))


@pytest.mark.parametrize("value", ["abc", b"abc", None, np.array(["a", "b"]), np.array([object()] * 6).reshape(2, 3),
                                   np.zeros((2, 3), complex), np.zeros((2, 3), "datetime64[s]"),
                                   np.zeros((2, 3), np.longdouble), np.zeros((2, 3), "timedelta64[s]"),
                                   [[1j, 2, 3], [4, 5, 6]], {"a": 1}, object(), BadEq()],
                         ids=lambda v: type(v).__name__ + str(getattr(v, "dtype", "")))
def test_array_refuses_wrong_kinds(value):
    with pytest.raises(InputTypeError, match="^data must be"):
        checks.array("data", value, shape=(2, 3))


@pytest.mark.parametrize("value", [[[1.0, 2.0], [3.0]], [[1, 2, 3], [4, 5]], [np.zeros(3), np.zeros(2)]], ids=_repr)
def test_array_refuses_ragged_nesting(value):
    with pytest.raises(ValueError, match="^data must be a rectangular numeric array"):
        checks.array("data", value)


@pytest.mark.parametrize("value", [np.zeros((3, 2)), np.zeros((2, 3, 1)), np.zeros(6), np.zeros((0,)), 1.0, np.zeros((2, 4)),
                                   np.zeros((1, 2, 3))], ids=lambda v: str(np.shape(v)))
def test_array_refuses_wrong_shapes(value):
    with pytest.raises(ValueError, match=r"^data must have shape \(2, 3\); got"):
        checks.array("data", value, shape=(2, 3))


def test_array_shape_wildcards_and_ndim():
    assert checks.array("d", np.zeros((7, 3)), shape=(None, 3)).shape == (7, 3)
    with pytest.raises(ValueError, match=r"d must have shape \(any, 3\); got \(7, 2\)"):
        checks.array("d", np.zeros((7, 2)), shape=(None, 3))
    with pytest.raises(ValueError, match=r"d must have shape \(3,\)"):
        checks.array("d", np.zeros(2), shape=(3,))
    assert checks.array("d", np.zeros((2, 2)), ndim=(1, 2)).ndim == 2
    with pytest.raises(ValueError, match="d must have 1 or 2 dimensions; got shape"):
        checks.array("d", np.zeros((2, 2, 2)), ndim=(1, 2))
    with pytest.raises(ValueError, match="d must have 2 dimensions"):
        checks.array("d", 1.0, ndim=2)


@pytest.mark.parametrize("bad", [NAN, INF, -INF])
@pytest.mark.parametrize("dtype", [np.float16, np.float32, np.float64, ">f8", np.complex64, np.complex128])
def test_array_refuses_non_finite_entries_of_every_float_dtype(bad, dtype):
    a = np.zeros((2, 3), dtype)
    a[1, 2] = bad
    kinds = "biufc"
    with pytest.raises(ValueError, match="^data contains NaN or infinite values"):
        checks.array("data", a, kinds=kinds, shape=(2, 3))
    assert checks.array("data", a, kinds=kinds, shape=(2, 3), finite=False) is a  # allowed when asked


@pytest.mark.parametrize("dtype", [bool, np.int8, np.uint16, np.int64, np.uint64, np.float16, np.float32, ">f8", np.float64])
def test_array_accepts_real_dtypes_without_copying(dtype):
    a = np.zeros((2, 3), dtype)
    assert checks.array("data", a, shape=(2, 3)) is a
    noncontiguous = np.zeros((4, 6), dtype)[::2, ::2]
    assert checks.array("data", noncontiguous, shape=(2, 3)) is noncontiguous


def test_array_kinds_and_nested_lists():
    assert checks.array("d", [[1, 2, 3], [4, 5, 6]], shape=(2, 3)).dtype.kind == "i"
    assert checks.array("d", [1j, 2], kinds="fc").dtype.kind == "c"
    with pytest.raises(InputTypeError, match="d must be a float array; got dtype int64"):
        checks.array("d", np.zeros(2, np.int64), kinds="f")
    with pytest.raises(InputTypeError, match="d must be a bool array"):
        checks.array("d", np.zeros(2), kinds="b")
    with pytest.raises(InputTypeError, match="extended precision"):
        checks.array("d", np.zeros(2, np.clongdouble), kinds="fc")


# ---------------------------------------------------------------------- callable_
@pytest.mark.parametrize("value", [3, "f", None, [abs], np.zeros(2), object()], ids=_repr)
def test_callable_refuses_non_callables(value):
    with pytest.raises(InputTypeError, match="^point_map must be callable; got"):
        checks.callable_("point_map", value)


def test_callable_accepts_callables():
    for f in (abs, lambda z: z, np.sin, BadEq, type("C", (), {"__call__": lambda self: 0})()):
        assert checks.callable_("f", f) is None


# ---------------------------------------------------------------------- messages
@pytest.mark.parametrize("check, args", [
    (checks.integer, ("x" * 500,)), (checks.real, ("x" * 500,)), (checks.flag, ("x" * 500,)),
    (checks.choice, ("x" * 500, OPTS)), (checks.callable_, ("x" * 500,))])
def test_messages_show_a_short_repr_of_what_was_received(check, args):
    with pytest.raises(ValueError) as info:
        check("arg", *args)
    assert len(str(info.value)) < 200 and "..." in str(info.value)


def test_messages_show_arrays_by_shape_and_dtype():
    with pytest.raises(InputTypeError, match=r"got an array of shape \(1000, 1000\) and dtype float64"):
        checks.real("x", np.zeros((1000, 1000)))
