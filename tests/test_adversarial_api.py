"""Hostile input to every public name of ``conformal``, ``models`` and ``envs`` (issue 11, item 5).

Each case is one test item marked ``adversarial`` (``tests/conftest.py`` counts them): a public
function, constructor, method or env action is called with NaN, infinity, a wrong type, a wrong
shape, zero, a negative, a huge or a non-integral value, and must raise a ``ValueError`` or
``TypeError`` (``conformal.checks.InputTypeError`` is both) whose message names the argument,
never a silent NaN, a truncation, an internal traceback (numba, IndexError, LinAlgError), a hang
or an unbounded allocation. A few cases check what must keep working at the edges (integral
floats, float16 and big-endian images, numpy scalars), and hypothesis properties check that any
finite valid input gives a finite result. ``test_fork_after_render_raises_naming_spawn`` checks
that an ``AsyncVectorEnv`` forked after the parent rendered fails fast instead of deadlocking.
"""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import textwrap
from dataclasses import dataclass
from functools import cached_property
from typing import Any, Callable

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import conformal as C
import envs
import models
from conformal.checks import InputTypeError

pytestmark = pytest.mark.adversarial

NAN, INF = float("nan"), float("inf")
HANG_S = 30  # a case running this long is a hang


@pytest.fixture(autouse=True)
def _no_hang():
    """Fail a case that runs longer than HANG_S seconds (a hang), instead of blocking the suite."""

    def timeout(signum, frame):
        raise TimeoutError(f"hung for {HANG_S} s")

    old = signal.signal(signal.SIGALRM, timeout)
    signal.alarm(HANG_S)
    yield
    signal.alarm(0)
    signal.signal(signal.SIGALRM, old)


# ---------------------------------------------------------------------- shared objects
class World:
    """Objects the cases act on, built on first use and shared by the module's cases."""

    def __init__(self):
        self.rng = np.random.default_rng(0)

    @cached_property
    def grid(self):  # M = 8 rings, N = 16 sectors (divisible by 4), 13 foveal samples
        return C.RetinaGrid.from_field_of_view(1.0, 0.05, 16)

    @cached_property
    def grid_odd(self):  # N = 18: no vertical-meridian split
        return C.RetinaGrid.from_field_of_view(1.0, 0.05, 18)

    @cached_property
    def samples(self):
        return self.rng.uniform(size=(self.grid.M, self.grid.N))

    @cached_property
    def coeffs(self):
        return C.dpft(self.samples, self.grid)

    @cached_property
    def fovea(self):
        return self.rng.uniform(size=self.grid.n_fovea)

    @cached_property
    def retina(self):
        return C.Retina(self.grid, (40, 40), 20.0)

    @cached_property
    def retina_samples(self):
        return self.retina.sample(self.rng.uniform(size=(40, 40)))

    @cached_property
    def evaluator(self):
        return C.OffGridEvaluator(self.grid, self.grid.points * 1.01)

    @cached_property
    def plan(self):
        return C.RemapPlan(self.grid)

    @cached_property
    def plan_args(self):
        F = np.stack([self.coeffs[..., None]] * 2)
        fv = np.stack([self.fovea[:, None]] * 2)
        maps = [[C.homography_map(np.eye(3))], [C.homography_map(np.eye(3))]]
        return F, fv, maps

    @cached_property
    def head(self):
        return models.Head("dots", image_size=32, seed=0)

    @cached_property
    def saccade(self):
        """A planned (not started) saccade of ``head``."""
        self.head.reset()
        return self.head.plan_saccade(0.1, 0.0)

    @cached_property
    def frame(self):
        return self.head.render()

    @cached_property
    def renderer(self):
        return models.EyeRenderer(self.head.model, 16)

    @cached_property
    def env(self):
        e = envs.BinocularSaccadeEnv(image_size=32, fixation_ms=10)
        e.reset(seed=0)
        return e

    @cached_property
    def cell_env(self):
        e = envs.BinocularSaccadeEnv(image_size=32, fixation_ms=10, action_mode="cell")
        e.reset(seed=0)
        return e

    @cached_property
    def vergence_env(self):
        e = envs.BinocularSaccadeEnv(image_size=32, fixation_ms=10, vergence=True)
        e.reset(seed=0)
        return e

    @cached_property
    def fresh_env(self):  # never reset
        return envs.BinocularSaccadeEnv(image_size=32, fixation_ms=10, render_mode="rgb_array")

    @cached_property
    def vision(self):
        return envs.Vision((32, 32), 22.85)

    @cached_property
    def views(self):
        img = (self.rng.uniform(size=(32, 32, 3)) * 255).astype(np.uint8)
        return self.vision.see_eyes((img, img))

    @cached_property
    def predictions(self):
        return self.vision.predict_eyes(self.views, ("homography",), [np.eye(3)] * 2)

    def close(self):
        for name in ("env", "cell_env", "vergence_env", "fresh_env"):
            if name in self.__dict__:
                self.__dict__[name].close()
        if "renderer" in self.__dict__:
            self.renderer.close()
        if "head" in self.__dict__:
            self.head.close()


@pytest.fixture(scope="module")
def o():
    w = World()
    yield w
    w.close()


# ---------------------------------------------------------------------- value families
def reals(lo=None, hi=None, *, lo_open=False, hi_open=False, nan=True) -> dict[str, Any]:
    """Bad values for a finite real number in the given interval."""
    out = {"inf": INF, "-inf": -INF, "str": "1.0", "none": None, "complex": 1 + 1j, "bool": True,
           "list": [1.0], "array2": np.ones(2)}
    if nan:
        out["nan"] = NAN
    if lo is not None:
        out["below"] = lo - max(1.0, abs(lo))
        if lo_open:
            out["at_lo"] = lo
    if hi is not None:
        out["above"] = hi + max(1.0, abs(hi))
        out["huge"] = 1e300
        if hi_open:
            out["at_hi"] = hi
    return out


def ints(lo=None, hi=None) -> dict[str, Any]:
    """Bad values for an integer in [lo, hi]: never truncated, never coerced from another type."""
    base = lo if lo is not None else 0
    out = {"nan": NAN, "inf": INF, "frac": base + 1.5 if hi is None or base + 2 <= hi else base + 0.5, "str": "8",
           "none": None, "bool": True, "complex": 8 + 0j, "list": [8]}
    if lo is not None:
        out["below"] = lo - 1
        out["negative"] = min(lo - 1, -1)
    if hi is not None:
        out["above"] = hi + 1
        out["huge"] = 10**12
        out["huge_float"] = 1e9 if hi < 1e9 else 1e15
    return out


FLAGS = {"str_no": "no", "str_false": "False", "int1": 1, "int0": 0, "none": None, "float": 1.0, "array": np.array([True])}


def choices(valid: tuple[str, ...], none_ok: bool = False) -> dict[str, Any]:
    out = {"unknown": "nonsense", "empty": "", "int": 1, "upper": valid[0].upper(), "list": [valid[0]],
           "bytes": valid[0].encode()}
    if not none_ok:
        out["none"] = None
    return out


def arrays(good: np.ndarray, *, complex_ok: bool = False, nan: bool = True, batch: bool = False) -> dict[str, Any]:
    """Bad versions of a valid array ``good`` (``batch``: its first axis may have any length)."""
    good = np.asarray(good)
    out = {"str": "abc", "none": None, "object": np.array([object()] * max(good.size, 1)).reshape(good.shape or (1,)),
           "ragged": [[1.0, 2.0], [3.0]], "empty": np.zeros((0,)),
           "extra_dims": good[..., None, None] if good.ndim else np.ones((2, 2)),
           "scalar": 1.0 if good.ndim else np.ones(5)}
    if good.ndim >= 1 and not batch:
        out["short"] = np.take(good, np.arange(max(good.shape[0] - 1, 0)), axis=0)
    if nan:
        bad = good.astype(complex if good.dtype.kind == "c" else float)
        flat = bad.reshape(-1)
        if flat.size:
            flat[0] = NAN
            out["nan"] = bad.copy()
            flat[0] = INF
            out["inf"] = bad.copy()
    if not complex_ok:
        out["complex"] = good.astype(complex) + 1j
    return out


@dataclass
class Case:
    id: str
    call: Callable[[World], Any]
    match: str  # a regex the message must contain (the argument's name)
    types: tuple = (ValueError, TypeError, InputTypeError, models.OculomotorRangeError)


CASES: list[Case] = []


class Lazy:
    """A bad value that depends on the shared objects: ``Lazy(lambda o: ...)``."""

    def __init__(self, make: Callable[[World], Any]):
        self.make = make


def sweep(prefix: str, call: Callable[[World, Any], Any], values: dict[str, Any], match: str,
          types: tuple | None = None) -> None:
    """One case per bad value: ``call(o, value)`` must raise naming ``match``."""
    for label, v in values.items():
        case = Case(f"{prefix}-{label}", (lambda o, v=v: call(o, v.make(o) if isinstance(v, Lazy) else v)), match)
        if types is not None:
            case.types = types
        CASES.append(case)


def case(id: str, call: Callable[[World], Any], match: str, types: tuple | None = None) -> None:
    c = Case(id, call, match)
    if types is not None:
        c.types = types
    CASES.append(c)


# ---------------------------------------------------------------------- conformal: geometry
G_OK = np.eye(2, dtype=complex)
R_OK = np.eye(3)
Z_OK = np.array([0.1 + 0.2j, -0.3j])

sweep("act-g", lambda o, v: C.act(v, Z_OK), {**arrays(G_OK, complex_ok=True), "det2": np.diag([2.0, 1.0]),
      "singular": np.zeros((2, 2)), "3x3": np.eye(3), "4x4": np.eye(4)}, r"\bg\b")
sweep("act-z", lambda o, v: C.act(G_OK, v), {k: v for k, v in arrays(Z_OK, complex_ok=True).items()
                                             if k not in ("extra_dims", "scalar", "short", "empty")}, r"\bz\b")
case("act-overflow", lambda o: C.act(np.diag([0.5, 2.0]), 1e308), "floating-point range")
sweep("apply_homography-H", lambda o, v: C.apply_homography(v, Z_OK),
      {**arrays(R_OK), "4x4": np.eye(4), "2x2": np.eye(2), "3x4": np.ones((3, 4)), "singular": np.zeros((3, 3)),
       "rank1": np.ones((3, 3))}, r"\bH\b")
sweep("apply_homography-z", lambda o, v: C.apply_homography(R_OK, v),
      {"nan": [NAN], "inf": [INF], "str": "z", "none": None, "object": np.array([object()])}, r"\bz\b")
case("apply_homography-pole", lambda o: C.apply_homography(np.array([[1, 0, 0], [0, 1, 0], [1, 0, 1.0]]), [-1.0]),
     "infinity")
sweep("check_sl2-tol", lambda o, v: C.check_sl2(G_OK, tol=v), reals(0.0, 0.01, lo_open=True), "tol")
sweep("check_sl2-name", lambda o, v: C.check_sl2(G_OK, name=v), {"int": 3, "none": None, "list": ["g"]}, "name")
sweep("check_rotation-R", lambda o, v: C.check_rotation(v), {**arrays(R_OK), "reflection": np.diag([1, 1, -1.0]),
      "scaled": 2 * np.eye(3), "2x2": np.eye(2)}, r"\bR\b")
sweep("compose-g", lambda o, v: C.compose(G_OK, v), {**arrays(G_OK, complex_ok=True), "det3": 3 * np.eye(2)}, "g2")
case("compose-overflow", lambda o: C.compose(*[np.diag([1e100, 1e-100])] * 4), "overflow")
sweep("cortical_map-samples", lambda o, v: C.cortical_map(v, o.grid), arrays(np.zeros((8, 16)), complex_ok=True),
      "samples")
sweep("cortical_map-grid", lambda o, v: C.cortical_map(np.zeros((8, 16)), v),
      {"str": "grid", "none": None, "tuple": (8, 16), "dict": {"M": 8}}, "grid")
case("cortical_map-N-not-divisible-by-4", lambda o: C.cortical_map(np.zeros((o.grid_odd.M, 18)), o.grid_odd),
     "divisible by 4")
sweep("hemifields-samples", lambda o, v: C.hemifields(v, o.grid), arrays(np.zeros((8, 16, 3)), complex_ok=True),
      "samples")
sweep("hemifields-grid", lambda o, v: C.hemifields(np.zeros((8, 16)), v), {"str": "grid", "none": None}, "grid")
sweep("binocular_cortex-left", lambda o, v: C.binocular_cortex(v, o.samples, o.grid),
      arrays(np.zeros((8, 16)), complex_ok=True), "left_eye")
sweep("binocular_cortex-right", lambda o, v: C.binocular_cortex(o.samples, v, o.grid),
      arrays(np.zeros((8, 16)), complex_ok=True), "right_eye")
case("binocular_cortex-channels-differ",
     lambda o: C.binocular_cortex(np.zeros((8, 16, 3)), np.zeros((8, 16, 1)), o.grid), "same shape")
sweep("BinocularCortex-left", lambda o, v: C.BinocularCortex(v, np.zeros((2, 8, 8))),
      {**arrays(np.zeros((2, 8, 8)), complex_ok=True), "one_eye": np.zeros((1, 8, 8))}, "hemisphere")
case("BinocularCortex-shapes-differ", lambda o: C.BinocularCortex(np.zeros((2, 8, 8)), np.zeros((2, 8, 4))),
     "shape")
for fn in ("k_matrix", "euler_rotation"):
    for i, arg in enumerate(("psi", "phi", "psi2")):
        sweep(f"{fn}-{arg}", lambda o, v, fn=fn, i=i: getattr(C, fn)(*[v if j == i else 0.1 for j in range(3)]),
              reals(), arg)
for i, arg in enumerate(("b1", "b2", "b3")):
    sweep(f"h_matrix-{arg}", lambda o, v, i=i: C.h_matrix(*[v if j == i else 0.1 for j in range(3)]), reals(), arg)
case("h_matrix-b2=-1", lambda o: C.h_matrix(0.0, -1.0, 0.0), "b2 = -1")
sweep("inverse-g", lambda o, v: C.inverse(v), arrays(G_OK, complex_ok=True), r"\bg\b")
sweep("lift_to_sphere-z", lambda o, v: C.lift_to_sphere(v),
      {"nan": [NAN], "inf": [1j * INF], "str": "z", "none": None, "object": np.array([object()])}, r"\bz\b")
sweep("mobius_from_points-z", lambda o, v: C.mobius_from_points(v, [0, 1, 1j]),
      {"nan": [NAN, 1, 2], "two": [0, 1], "repeated": [0, 0, 1], "str": "abc", "none": None}, r"\bz\b|three points")
sweep("mobius_from_points-w", lambda o, v: C.mobius_from_points([0, 1, 1j], v),
      {"inf": [INF, 1, 2], "four": [0, 1, 2, 3], "repeated": [1j, 1j, 1], "object": np.array([object()] * 3)},
      r"\bw\b|three points")
sweep("project-points", lambda o, v: C.project(v), {**arrays(np.array([[0.0, 1.0, 0.0]]), batch=True), "x2=0": [1.0, 0.0, 2.0],
      "2d": [1.0, 2.0]}, "points|x2 = 0")
case("project-overflow", lambda o: C.project([1e308, 1e-10, 1e308]), "floating-point range")
sweep("rotation_from_su2-k", lambda o, v: C.rotation_from_su2(v),
      {**arrays(G_OK, complex_ok=True), "not_unitary": np.array([[1, 1], [0, 1.0]])}, r"\bk\b")
for fn in ("su2_from_rotation", "rotation_homography", "homography_map", "mobius_map", "mobius_for_rotation"):
    sweep(f"{fn}-R", lambda o, v, fn=fn: getattr(C, fn)(v), {**arrays(R_OK), "reflection": np.diag([1, 1, -1.0])},
          r"\bR\b")
sweep("rotation_matrix-axis", lambda o, v: C.rotation_matrix(v, 0.1), {**arrays(np.array([0.0, 0.0, 1.0])),
      "zero": np.zeros(3), "3x3": np.eye(3)}, "axis")
sweep("rotation_matrix-angle", lambda o, v: C.rotation_matrix([0, 0, 1.0], v), reals(), "angle")
sweep("schwartz_map-a", lambda o, v: C.schwartz_map(Z_OK, v), reals(0.0, lo_open=True), r"\ba\b")
sweep("schwartz_map-z", lambda o, v: C.schwartz_map(v, 1.0), {"nan": [NAN], "inf": [INF], "str": "z", "none": None},
      r"\bz\b")
sweep("transform_image-f", lambda o, v: C.transform_image(v, G_OK), {"int": 3, "none": None, "str": "f"}, r"\bf\b")
sweep("transform_image-g", lambda o, v: C.transform_image(abs, v), arrays(G_OK, complex_ok=True), r"\bg\b")
case("SPHERE_CENTRE-read-only", lambda o: C.SPHERE_CENTRE.__setitem__(0, 5.0), "read-only")

# ---------------------------------------------------------------------- conformal: grid
GRID_KW = dict(r0=0.05, delta=0.3, M=8, N=16, fovea_spacing=0.04, n_fovea=13)
for arg, values in (("r0", reals(0.0, 1e6, lo_open=True)), ("delta", reals(0.0, 100.0, lo_open=True)),
                    ("fovea_spacing", reals(0.0, 1e6, lo_open=True)), ("M", ints(2, 4096)), ("N", ints(2, 8192)),
                    ("n_fovea", ints(1, 2**20))):
    sweep(f"RetinaGrid-{arg}", lambda o, v, arg=arg: C.RetinaGrid(**{**GRID_KW, arg: v}), values, arg)
case("RetinaGrid-M=1e9", lambda o: C.RetinaGrid(**{**GRID_KW, "M": 1e9}), r"\bM\b")
case("RetinaGrid-M*N-too-many", lambda o: C.RetinaGrid(**{**GRID_KW, "M": 4096, "N": 4096, "delta": 0.01}), "M \\* N")
case("RetinaGrid-period-too-long", lambda o: C.RetinaGrid(**{**GRID_KW, "M": 4000, "delta": 50.0}), "period")
FP = dict(width=64, height=64, dots_per_unit=4.0, foveal_pixels=64)
for arg, values in (("width", ints(1, 65536)), ("height", ints(1, 65536)), ("foveal_pixels", ints(1, 2**20)),
                    ("dots_per_unit", reals(0.0, 1e9, lo_open=True))):
    sweep(f"RetinaGrid.from_picture-{arg}", lambda o, v, arg=arg: C.RetinaGrid.from_picture(**{**FP, arg: v}), values,
          arg)
sweep("RetinaGrid.from_picture-extent", lambda o, v: C.RetinaGrid.from_picture(**FP, extent=v),
      choices(("diagonal", "inscribed")), "extent")
sweep("RetinaGrid.from_picture-r0_decimals", lambda o, v: C.RetinaGrid.from_picture(**FP, r0_decimals=v),
      {k: x for k, x in ints(0, 15).items() if k != "none"}, "r0_decimals")
for arg, values in (("rb", reals(0.0, lo_open=True)), ("r0", reals(0.0, 1e6, lo_open=True)),
                    ("n_sectors", {**ints(4, 8192), "100000": 100000, "36.5": 36.5})):
    sweep(f"RetinaGrid.from_field_of_view-{arg}",
          lambda o, v, arg=arg: C.RetinaGrid.from_field_of_view(**{**dict(rb=1.0, r0=0.05, n_sectors=16), arg: v}),
          values, arg)
case("RetinaGrid.from_field_of_view-tiny-r0-huge-rb", lambda o: C.RetinaGrid.from_field_of_view(1e300, 1e-300, 64),
     "M|period|n_fovea")
for arg, values in (("field_deg", reals(0.0, 90.0, lo_open=True, hi_open=True)),
                    ("fovea_deg", reals(0.0, 90.0, lo_open=True, hi_open=True)), ("n_sectors", ints(4, 8192))):
    sweep(f"RetinaGrid.from_angles-{arg}",
          lambda o, v, arg=arg: C.RetinaGrid.from_angles(**{**dict(field_deg=40.0, fovea_deg=1.0), arg: v}), values, arg)
sweep("RetinaGrid.locate-z", lambda o, v: o.grid.locate(v), {"nan_inf": [NAN, INF], "nan": NAN, "inf": 1j * INF,
      "str": "z", "none": None, "object": np.array([object()])}, r"\bz\b")

# ---------------------------------------------------------------------- conformal: DPFT, fovea, shift
for fn in ("dpft", "dpft_direct"):
    sweep(f"{fn}-samples", lambda o, v, fn=fn: getattr(C, fn)(v, o.grid),
          {**arrays(np.zeros((8, 16))), "longdouble": np.zeros((8, 16), np.longdouble)}, "samples")
    sweep(f"{fn}-grid", lambda o, v, fn=fn: getattr(C, fn)(np.zeros((8, 16)), v), {"str": "grid", "none": None},
          "grid")
for fn in ("idpft", "idpft_direct"):
    sweep(f"{fn}-coeffs", lambda o, v, fn=fn: getattr(C, fn)(v, o.grid), arrays(np.zeros((8, 16), complex),
          complex_ok=True), "coeffs")
sweep("idpft-real", lambda o, v: C.idpft(o.coeffs, o.grid, real=v), FLAGS, "real")
case("dpft_direct-too-large", lambda o: C.dpft_direct(np.zeros((60, 64)), C.RetinaGrid(**{**GRID_KW, "M": 60,
     "N": 64})), "direct sum")
case("idpft_direct-too-large", lambda o: C.idpft_direct(np.zeros((60, 64)), C.RetinaGrid(**{**GRID_KW, "M": 60,
     "N": 64})), "direct sum")
sweep("pft_frequencies-grid", lambda o, v: C.pft_frequencies(v), {"str": "grid", "none": None, "int": 3}, "grid")
for fn in ("evaluate", "evaluate_direct"):
    sweep(f"{fn}-points", lambda o, v, fn=fn: getattr(C, fn)(o.coeffs, o.grid, v),
          {"nan": [NAN], "inf": [INF], "zero": [0j], "str": "z", "none": None, "object": np.array([object()])},
          "points|z = 0")
    sweep(f"{fn}-extension", lambda o, v, fn=fn: getattr(C, fn)(o.coeffs, o.grid, [0.3], extension=v),
          choices(("mirror", "paper")), "extension")
    sweep(f"{fn}-real", lambda o, v, fn=fn: getattr(C, fn)(o.coeffs, o.grid, [0.3], real=v), FLAGS, "real")
    sweep(f"{fn}-coeffs", lambda o, v, fn=fn: getattr(C, fn)(v, o.grid, [0.3]),
          arrays(np.zeros((8, 16), complex), complex_ok=True), "coeffs")
OG = "OffGridEvaluator"
sweep(f"{OG}-eps", lambda o, v: C.OffGridEvaluator(o.grid, [0.3], eps=v), {**reals(1e-15, 1e-2), "ten": 10.0}, "eps")
sweep(f"{OG}-method", lambda o, v: C.OffGridEvaluator(o.grid, [0.3], method=v), choices(("auto", "nufft", "matrix")),
      "method")
sweep(f"{OG}-dtype", lambda o, v: C.OffGridEvaluator(o.grid, [0.3], dtype=v),
      {"float16": np.float16, "complex": complex, "int": int, "none": None, "str": "fast", "longdouble": np.longdouble},
      "dtype")
sweep(f"{OG}-grid", lambda o, v: C.OffGridEvaluator(v, [0.3]), {"str": "grid", "none": None}, "grid")
sweep(f"{OG}-points", lambda o, v: C.OffGridEvaluator(o.grid, v), {"nan": [NAN], "zero": [0.0], "str": "p"}, "points")
sweep(f"{OG}.__call__-coeffs", lambda o, v: o.evaluator(v), arrays(np.zeros((8, 16), complex), complex_ok=True),
      "coeffs")
sweep(f"{OG}.__call__-real", lambda o, v: o.evaluator(o.coeffs, real=v), FLAGS, "real")
sweep("transform-g", lambda o, v: C.transform(o.coeffs, o.grid, v), {**arrays(G_OK, complex_ok=True),
      "det2": 2 * np.eye(2)}, r"\bg\b")
sweep("warp-point_map", lambda o, v: C.warp(o.coeffs, o.grid, v), {
    "not_callable": 3, "none": None, "wrong_shape": lambda z: z.ravel(), "scalar": lambda z: 0.3 + 0j,
    "nan": lambda z: z * NAN, "strings": lambda z: np.full(z.shape, "x"), "behind_eye": C.homography_map(
        C.rotation_matrix([0, 0, 1.0], np.radians(120)))}, "point_map")
sweep("warp-coeffs", lambda o, v: C.warp(v, o.grid, lambda z: z), arrays(np.zeros((8, 16), complex), complex_ok=True),
      "coeffs")
sweep("fovea_indices-grid", lambda o, v: C.fovea_indices(v), {"str": "grid", "none": None, "list": [1, 2]}, "grid")
sweep("fovea_image-fovea", lambda o, v: C.fovea_image(v, o.grid), arrays(np.zeros(13), complex_ok=True), "fovea")
sweep("fovea_image-outside", lambda o, v: C.fovea_image(o.fovea, o.grid, outside=v),
      {k: x for k, x in reals().items() if k != "nan"}, "outside")
sweep("fovea_image-grid", lambda o, v: C.fovea_image(o.fovea, v), {"str": "grid", "none": None}, "grid")
sweep("fovea_dft-fovea", lambda o, v: C.fovea_dft(v, o.grid), arrays(np.zeros(13), complex_ok=True), "fovea")
sweep("fovea_idft-coeffs", lambda o, v: C.fovea_idft(v, o.grid), arrays(np.zeros((6, 6), complex), complex_ok=True),
      "coeffs|foveal coefficients")
sweep("fovea_idft-real", lambda o, v: C.fovea_idft(np.zeros((6, 6)), o.grid, real=v), FLAGS, "real")
sweep("log_radius_shift-shift", lambda o, v: C.log_radius_shift(o.samples, o.grid, v), reals(), "shift")
sweep("log_radius_shift-wrapped-shift", lambda o, v: C.log_radius_shift(o.samples, o.grid, v, wrap=True),
      reals(-32, 32), "shift")
sweep("log_radius_shift-wrap", lambda o, v: C.log_radius_shift(o.samples, o.grid, 0.5, wrap=v), FLAGS, "wrap")
sweep("log_radius_shift-samples", lambda o, v: C.log_radius_shift(v, o.grid, 0.5), arrays(np.zeros((8, 16))),
      "samples")

# ---------------------------------------------------------------------- conformal: sampling
sweep("pixel_points-shape", lambda o, v: C.pixel_points(v, 10.0), {
    "zero": (0, 5), "negative": (-1, 5), "frac": (7.5, 8), "huge": (10**9, 10**9), "huge_float": (1e9, 1e9),
    "str": "ab", "none": None, "one": (5,), "three": (4, 4, 4), "nan": (NAN, 4), "bool": (True, 4)}, "shape")
sweep("pixel_points-pixels_per_unit", lambda o, v: C.pixel_points((4, 4), v), reals(0.0, 1e9, lo_open=True),
      "pixels_per_unit")
RET_KW = dict(image_shape=(40, 40), pixels_per_unit=20.0)
for arg, values in (("image_shape", {"zero": (0, 40), "frac": (40.5, 40), "huge": (10**6, 10**6), "str": "40x40",
                                     "none": None, "one": (40,), "four": (4, 4, 3, 1), "channels": (4, 4, 10**6),
                                     "nan": (NAN, 40)}),
                    ("pixels_per_unit", reals(0.0, 1e9, lo_open=True)), ("mode", choices(("pool", "bilinear"))),
                    ("supersample", ints(1, 16)), ("min_coverage", reals(0.0, 1.0, lo_open=True)),
                    ("fill", reals())):
    sweep(f"Retina-{arg}", lambda o, v, arg=arg: C.Retina(o.grid, **{**RET_KW, arg: v}), values, arg)
sweep("Retina-grid", lambda o, v: C.Retina(v, (40, 40), 20.0), {"str": "grid", "none": None}, "grid")
case("Retina-too-many-subpixels", lambda o: C.Retina(o.grid, (8192, 8192), 20.0, supersample=16), "subpixels")
IMG = np.zeros((40, 40))
sweep("Retina.sample-image", lambda o, v: o.retina.sample(v), {
    **arrays(IMG), "longdouble": IMG.astype(np.longdouble),
    "complex64": IMG.astype(np.complex64), "datetime": IMG.astype("datetime64[s]"), "rgb": np.zeros((40, 40, 3)),
    "transposed_shape": np.zeros((40, 41)), "float16_nan": np.full((40, 40), NAN, np.float16),
    "bigendian_inf": np.full((40, 40), INF, ">f8")}, "image")
sweep("Retina.sample_many-images", lambda o, v: o.retina.sample_many(v), {"one_picture": IMG, "int": 3, "none": None,
      "str": "images", "bad_member": [IMG, np.zeros((3, 3))]}, "image")
sweep("Retina.sample_many-scale", lambda o, v: o.retina.sample_many([IMG], scale=v), reals(), "scale")
sweep("Retina.render-samples", lambda o, v: o.retina.render(v), {"none": None, "dict": {"fovea": 0},
      "array": np.zeros((8, 16))}, "samples")
sweep("Retina.render-background", lambda o, v: o.retina.render(o.retina_samples, background=v), reals(), "background")
case("Retina.render-nan-samples", lambda o: o.retina.render(C.RetinaSamples(
    np.full(13, NAN), np.zeros((8, 16)), np.ones((8, 16), bool), np.ones(13, bool))), "samples")
case("Retina.render-other-grid", lambda o: o.retina.render(C.RetinaSamples(
    np.zeros(13), np.zeros((8, 12)), np.ones((8, 12), bool), np.ones(13, bool))), "grid")
RS = dict(fovea=np.zeros(13), periphery=np.zeros((8, 16)), mask=np.ones((8, 16), bool), fovea_mask=np.ones(13, bool))
for arg, values in (("fovea", {"str": "f", "complex": np.zeros(13, complex), "3d": np.zeros((13, 1, 1))}),
                    ("periphery", {"none": None, "1d": np.zeros(5), "channels": np.zeros((8, 16, 2))}),
                    ("mask", {"float": np.ones((8, 16)), "shape": np.ones((8, 15), bool)}),
                    ("fovea_mask", {"int": np.ones(13, int), "shape": np.ones(12, bool)})):
    sweep(f"RetinaSamples-{arg}", lambda o, v, arg=arg: C.RetinaSamples(**{**RS, arg: v}), values,
          arg if arg != "periphery" else "periphery|channels")

# ---------------------------------------------------------------------- conformal: remapping
sweep("ProjectiveMap-H", lambda o, v: C.ProjectiveMap(v), {**arrays(R_OK), "2x2": np.eye(2), "4x4": np.eye(4),
      "singular": np.zeros((3, 3))}, r"\bH\b")
sweep("MobiusMap-g", lambda o, v: C.MobiusMap(v), {**arrays(G_OK, complex_ok=True), "singular": np.ones((2, 2)),
      "3x3": np.eye(3)}, r"\bg\b")
sweep("ProjectiveMap.__call__-z", lambda o, v: C.ProjectiveMap(R_OK)(v), {"nan": [NAN], "inf": [INF], "str": "z",
      "none": None}, r"\bz\b")
sweep("MobiusMap.__call__-z", lambda o, v: C.MobiusMap(G_OK)(v), {"nan": [NAN], "inf": [INF], "str": "z"}, r"\bz\b")
for arg, values in (("z_target", {"nan": NAN, "inf": complex(0, INF), "str": "0.1", "none": None, "list": [0.1, 0.2]}),
                    ("shift", reals()), ("delta", reals(0.0, 100.0, lo_open=True))):
    sweep(f"target_shift_map-{arg}",
          lambda o, v, arg=arg: C.target_shift_map(**{**dict(z_target=0.1, shift=1.0, delta=0.1), arg: v}), values, arg)
case("target_shift_map-scale-overflow", lambda o: C.target_shift_map(0.1, 1e6, 1.0), "shift \\* delta")
sweep("predict-point_map", lambda o, v: C.predict(o.coeffs, o.fovea, o.grid, v), {
    "not_callable": 3, "none": None, "wrong_shape": lambda z: z[:3], "strings": lambda z: np.full(z.shape, "x")},
      "point map")
sweep("predict-fovea", lambda o, v: C.predict(o.coeffs, v, o.grid, lambda z: z),
      {**arrays(np.zeros(13)), "channels": np.zeros((13, 3))}, "fovea")
sweep("predict-coeffs", lambda o, v: C.predict(v, o.fovea, o.grid, lambda z: z),
      arrays(np.zeros((8, 16), complex), complex_ok=True), "coeffs")
sweep("predict-on", lambda o, v: C.predict(o.coeffs, o.fovea, o.grid, lambda z: z, on=v), {"str": "grid", "int": 3},
      r"\bon\b")
sweep("predict_many-point_maps", lambda o, v: C.predict_many(o.coeffs, o.fovea, o.grid, v),
      {"empty": [], "callable": lambda z: z, "str": "maps", "none": None, "member": [lambda z: z, 3]}, "point map")
sweep("predict_many-dtype", lambda o, v: C.predict_many(o.coeffs, o.fovea, o.grid, [lambda z: z], dtype=v),
      {"float16": np.float16, "none": None, "str": "fast"}, "dtype")
sweep("RemapPlan-grid", lambda o, v: C.RemapPlan(v), {"str": "grid", "none": None, "int": 3}, "grid")
sweep("RemapPlan-on", lambda o, v: C.RemapPlan(o.grid, on=v), {"str": "grid", "int": 3}, "grid")
sweep("RemapPlan.__call__-coeffs", lambda o, v: o.plan(v, o.plan_args[1], o.plan_args[2]),
      {**arrays(np.zeros((2, 8, 16, 1), complex), complex_ok=True), "3d": np.zeros((8, 16, 1), complex),
       "one_eye": np.zeros((1, 8, 16, 1), complex)}, "coeffs|fovea")
sweep("RemapPlan.__call__-fovea", lambda o, v: o.plan(o.plan_args[0], v, o.plan_args[2]),
      {**arrays(np.zeros((2, 13, 1))), "complex": np.zeros((2, 13, 1), complex)}, "fovea")
sweep("RemapPlan.__call__-maps", lambda o, v: o.plan(o.plan_args[0], o.plan_args[1], v), {
    "str": "maps", "none": None, "flat": [C.homography_map(np.eye(3))] * 2, "one_eye": [[C.homography_map(np.eye(3))]],
    "callables": [[abs], [abs]], "strings": [["homography"], ["homography"]]}, "maps|point maps|ProjectiveMap")
sweep("RemapPlan.series_coefficients-coeffs", lambda o, v: o.plan.series_coefficients(v),
      {**arrays(np.zeros((2, 8, 16, 1), complex), complex_ok=True, batch=True), "3d": np.zeros((8, 16, 1), complex)}, "coeffs")
sweep("RemapPlan.samples-values", lambda o, v: o.plan.samples(v, np.ones((2, 1, o.plan.n_points), bool)), {
    "str": "v", "none": None, "wrong_points": np.zeros((2, 1, 5, 1), np.float32), "3d": np.zeros((2, 1, 5))}, "values")
sweep("RemapPlan.samples-valid", lambda o, v: o.plan.samples(np.zeros((2, 1, o.plan.n_points, 1), np.float32), v), {
    "float": Lazy(lambda o: np.ones((2, 1, o.plan.n_points))), "shape": np.ones((2, 1, 3), bool), "none": None},
      "valid")
sweep("blas_threads-n", lambda o, v: C.blas_threads(v), {"zero": 0, "negative": -1, "frac": 1.5, "str": "2",
      "none": None, "bool": True}, r"\bn\b")
sweep("checks.integer-value", lambda o, v: C.checks.integer("count", v, 0, 10), ints(0, 10), "count")
sweep("checks.real-value", lambda o, v: C.checks.real("level", v, 0.0, 1.0), reals(0.0, 1.0), "level")
sweep("checks.flag-value", lambda o, v: C.checks.flag("switch", v), FLAGS, "switch")
sweep("checks.choice-value", lambda o, v: C.checks.choice("colour", v, ("red", "green")), choices(("red", "green")),
      "colour")
sweep("checks.array-value", lambda o, v: C.checks.array("data", v, shape=(2, 3)), arrays(np.zeros((2, 3))), "data")


# ---------------------------------------------------------------------- models
sweep("build_spec-scene", lambda o, v: models.build_spec(v), {k: x for k, x in choices(models.SCENES).items()
                                                              if k != "none"}, "scene")
sweep("build_spec-quality", lambda o, v: models.build_spec("bar", quality=v), choices(models.QUALITIES), "quality")
sweep("build_spec-ipd", lambda o, v: models.build_spec("bar", ipd=v), reals(0.01, 0.15), "ipd")
sweep("build_spec-fovy_deg", lambda o, v: models.build_spec("bar", fovy_deg=v), reals(5.0, 170.0), "fovy_deg")
sweep("build_spec-offscreen_size", lambda o, v: models.build_spec("bar", offscreen_size=v), {
    "zero": (0, 480), "frac": (640.5, 480), "huge": (10**9, 10**9), "str": "640x480", "none": None, "three": (1, 2, 3),
    "nan": (NAN, 480), "negative": (-640, 480)}, "offscreen_size")
sweep("build_spec-head_xml", lambda o, v: models.build_spec("bar", head_xml=v), {"int": 3, "empty": "",
      "list": ["head.xml"]}, "head_xml")
case("build_spec-head_xml-missing", lambda o: models.build_spec("bar", head_xml="/nonexistent/head.xml"),
     "cannot read", (models.ModelFileError,))
sweep("build_model-kwargs", lambda o, v: models.build_model("bar", **v), {"ipd": {"ipd": NAN}, "fovy": {"fovy_deg": -1},
      "size": {"offscreen_size": (1e9, 1)}}, "ipd|fovy_deg|offscreen_size")
case("build_model-unknown-kwarg", lambda o: models.build_model("bar", colour="red"), "colour")
sweep("export_xml-path", lambda o, v: models.export_xml("bar", v), {"int": 3, "none": None, "empty": "",
      "folder": "/tmp"}, "path")
case("export_xml-unwritable", lambda o: models.export_xml("bar", "/proc/nope/head.xml"), "cannot write",
     (models.ModelFileError,))
sweep("load_model-path", lambda o, v: models.load_model(v), {"int": 3, "none": None, "empty": ""}, "path")
case("load_model-missing", lambda o: models.load_model("/nonexistent.xml"), "cannot load", (models.ModelFileError,))
for arg, values in (("azimuth", reals(-np.pi / 2, np.pi / 2, lo_open=True, hi_open=True)),
                    ("elevation", reals(-np.pi / 2, np.pi / 2, lo_open=True, hi_open=True)),
                    ("distance", reals(0.0, 1000.0, lo_open=True))):
    sweep(f"screen_point-{arg}",
          lambda o, v, arg=arg: models.screen_point(**{**dict(azimuth=0.1, elevation=0.1, distance=1.0), arg: v}),
          values, arg)
case("CYCLOPEAN_EYE-read-only", lambda o: models.CYCLOPEAN_EYE.__setitem__(0, 5.0), "read-only")
sweep("gl_install_hint-backend", lambda o, v: models.gl_install_hint(v), {"int": 3, "list": ["egl"]}, "backend")
HEAD_BAD = {
    "scene": {"unknown": "moon", "none": None, "int": 1},
    "image_size": {**ints(1, 4096), "pair_frac": (32, 7.5), "pair_huge": (32, 10**6), "triple": (32, 32, 3)},
    "fovy_deg": reals(5.0, 170.0), "ipd": reals(0.01, 0.15), "quality": choices(models.QUALITIES),
    "seed": {"negative": -1, "frac": 1.5, "str": "0", "nan": NAN, "complex": 1j, "bool": True},
    "endpoint_noise": reals(0.0, 1.0),
    "main_sequence": {"dict": {"m0_deg": 7.0}, "int": 3, "str": "vanwetter", "with_burst": models.MainSequence()},
    "saccade_model": {"unknown": "robinson", "none": None, "int": 1},
    "generator": {"dict": {}, "main_sequence": models.MainSequence()},
    "vergence": {"dict": {}, "float": 150.0}, "eye_position": {"dict": {}, "float": 50.0},
    "timestep_ms": {**reals(0.01, 1.0), "not_a_divisor": 0.3, "tiny": 1e-9},
    "saccade_timestep_ms": {**reals(0.01, 1.0), "not_a_divisor": 0.7},
}
for arg, values in HEAD_BAD.items():
    sweep(f"Head-{arg}", lambda o, v, arg=arg: models.Head(**{"scene": "bar", "image_size": 16, arg: v}), values, arg)

sweep("Head.step_ms-n", lambda o, v: o.head.step_ms(v), {**ints(0, 60_000), "2.5": 2.5, "1e9": 1e9}, r"\bn\b")
sweep("Head.step_ms-record", lambda o, v: o.head.step_ms(1, record=v), FLAGS, "record")
sweep("Head.reset-seed", lambda o, v: o.head.reset(seed=v), HEAD_BAD["seed"], "seed")
sweep("Head.reset-settle_ms", lambda o, v: o.head.reset(settle_ms=v), ints(0, 60_000), "settle_ms")
sweep("Head.reset-fixate", lambda o, v: o.head.reset(fixate=v), {"nan": [NAN, 0, 1], "short": [1.0, 2.0],
      "int": 3, "unknown": "unicorn"}, "fixate|target|unicorn", (ValueError, TypeError, InputTypeError,
                                                                  models.OculomotorRangeError, KeyError))
sweep("Head.set_gaze-settle_ms", lambda o, v: o.head.set_gaze("fixation", settle_ms=v), ints(0, 60_000), "settle_ms")
sweep("Head.set_gaze-target", lambda o, v: o.head.set_gaze(v), {"nan": [NAN, 0, 1], "inf": [INF, 0, 1],
      "str_list": ["a", "b", "c"], "none": None, "2d": [1.0, 2.0], "complex": [1j, 0, 1]}, "target")
sweep("Head.set_neck-pan", lambda o, v: o.head.set_neck(v, 0.0), {**reals(), "far": 10.0}, "pan|neck")
sweep("Head.set_neck-tilt", lambda o, v: o.head.set_neck(0.0, v), {**reals(), "far": -10.0}, "tilt|neck")
sweep("Head.plan_saccade-horizontal", lambda o, v: o.head.plan_saccade(v, 0.0), reals(), "horizontal")
sweep("Head.plan_saccade-vertical", lambda o, v: o.head.plan_saccade(0.0, v), reals(), "vertical")
sweep("Head.plan_saccade-latency_ms", lambda o, v: o.head.plan_saccade(0.1, 0.0, latency_ms=v), ints(0, 60_000),
      "latency_ms")
sweep("Head.plan_saccade_to-target", lambda o, v: o.head.plan_saccade_to(v), {
    "nan": [NAN, 0, 1.2], "none": None, "int": 3, "matrix": np.eye(3), "unknown": "unicorn"}, "target|unicorn",
      (ValueError, TypeError, InputTypeError, models.OculomotorRangeError, KeyError))
sweep("Head.plan_saccade_to-latency_ms", lambda o, v: o.head.plan_saccade_to("target", latency_ms=v),
      ints(0, 60_000), "latency_ms")
sweep("Head.start_saccade-plan", lambda o, v: o.head.start_saccade(v), {"none": None, "dict": {"onset_ms": 0},
      "str": "plan"}, "plan")
sweep("Head.run_saccade-plan", lambda o, v: o.head.run_saccade(v), {"none": None, "int": 3}, "plan")
sweep("Head.run_saccade-before_ms", lambda o, v: o.head.run_saccade(o.saccade, before_ms=v), ints(0, 60_000),
      "before_ms")
sweep("Head.run_saccade-after_ms", lambda o, v: o.head.run_saccade(o.saccade, after_ms=v), ints(0, 60_000), "after_ms")
sweep("Head.saccade_to-after_ms", lambda o, v: o.head.saccade_to("target", after_ms=v), ints(0, 60_000), "after_ms")
sweep("Head.flash-duration_ms", lambda o, v: o.head.flash("flash_00", duration_ms=v), ints(1, 60_000), "duration_ms")
sweep("Head.flash-names", lambda o, v: o.head.flash(v), {"int": 3, "none": None, "empty": [], "member": [1]}, "name")
sweep("Head.object_position-name", lambda o, v: o.head.object_position(v), {"int": 3, "none": None, "list": ["a"]},
      "name")
sweep("Head.object_positions-group", lambda o, v: o.head.object_positions(v), {"int": 3, "none": None}, "group")
sweep("Head.set_object_position-pos", lambda o, v: o.head.set_object_position("target", v), {
    "nan": [NAN, 0, 1], "short": [1, 2], "str": "here", "none": None}, "target")
sweep("Head.set_object_position-name", lambda o, v: o.head.set_object_position(v, [1.0, 0, 1.2]), {"int": 3,
      "none": None}, "name")
sweep("Head.to_head-point", lambda o, v: o.head.to_head(v), {"nan": [NAN, 0, 0], "short": [1.0], "str": "p"}, "target")
sweep("Head.to_world-point_head", lambda o, v: o.head.to_world(v), {"nan": [NAN, 0, 0], "short": [1.0], "str": "p",
      "none": None}, "point_head")
sweep("Head.fixation_angles-point", lambda o, v: o.head.fixation_angles(v), {"inf": [INF, 0, 0], "none": None}, "target")
sweep("Head.project-points", lambda o, v: o.head.project(v), {**arrays(np.array([[1.0, 0.0, 1.2]]), batch=True),
      "four_columns": np.zeros((2, 4))}, "points")
sweep("Head.project_to_pixels-points", lambda o, v: o.head.project_to_pixels(v), {"nan": [NAN, 0, 0], "str": "p"},
      "points")
sweep("Head.render-depth", lambda o, v: o.head.render(depth=v), FLAGS, "depth")
sweep("Head.render-exposure_ms", lambda o, v: o.head.render(exposure_ms=v), reals(0.0, 1000.0), "exposure_ms")
sweep("Head.render-samples", lambda o, v: o.head.render(exposure_ms=2, samples=v),
      {k: v for k, v in ints(1, 1000).items() if k != "none"}, "samples")
case("Head.render-samples-without-exposure", lambda o: o.head.render(samples=3), "samples")
case("Head.render-depth-with-exposure", lambda o: o.head.render(depth=True, exposure_ms=4), "depth")
sweep("Head.eye_position_signal-t_ms", lambda o, v: o.head.eye_position_signal(v),
      {k: v for k, v in reals(0.0).items() if k != "none"}, "t_ms")
sweep("Head.export_xml-path", lambda o, v: o.head.export_xml(v), {"int": 3, "none": None, "empty": "",
      "folder": "/tmp"}, "path")
sweep("EyeState.project-points", lambda o, v: o.head.eye_states()[0].project(v), {"nan": [NAN, 0, 0], "str": "p",
      "object": np.array([object()] * 3)}, "points")
sweep("EyeRenderer-model", lambda o, v: models.EyeRenderer(v, 16), {"none": None, "str": "model", "data": 3}, "model")
sweep("EyeRenderer-height", lambda o, v: models.EyeRenderer(o.head.model, v), ints(1, 4096), "height")
sweep("EyeRenderer-width", lambda o, v: models.EyeRenderer(o.head.model, 16, v), {"frac": 7.5, "zero": 0, "str": "8"},
      "width")
sweep("EyeRenderer.render-data", lambda o, v: o.renderer.render(v), {"none": None, "model": 3, "str": "data"}, "data")
sweep("EyeRenderer.render-depth", lambda o, v: o.renderer.render(o.head.data, depth=v), FLAGS, "depth")
sweep("EyeRenderer.render-time_ms", lambda o, v: o.renderer.render(o.head.data, time_ms=v),
      {"frac": 2.5, "nan": NAN, "str": "0"}, "time_ms")
sweep("EyeImage.pixel_to_plane-rows", lambda o, v: o.frame.left.pixel_to_plane(v, [1.0, 2.0]), {"nan": [NAN],
      "str": "r", "complex": [1j], "mismatch": [1.0, 2.0, 3.0]}, "rows")
sweep("EyeImage.plane_to_pixel-z", lambda o, v: o.frame.left.plane_to_pixel(v), {"nan": [NAN], "inf": [INF],
      "str": "z"}, r"\bz\b")
sweep("StereoFrame.__getitem__-name", lambda o, v: o.frame[v], {"unknown": "middle", "int": 0, "none": None},
      "eye", (KeyError,))
MS_BAD = {"m0_deg": reals(0.0, 100.0, lo_open=True), "vpk_deg_per_ms": reals(0.0, 0.7, lo_open=True),
          "end_velocity_deg_s": reals(0.0, 525.0, lo_open=True, hi_open=True),
          "settle_deg": reals(0.0, 1.0, lo_open=True)}
for arg, values in MS_BAD.items():
    sweep(f"MainSequence-{arg}", lambda o, v, arg=arg: models.MainSequence(**{arg: v}), values, arg)
for meth in ("position_deg", "velocity_deg_per_ms"):
    sweep(f"MainSequence.{meth}-amp_deg", lambda o, v, meth=meth: getattr(models.MainSequence(), meth)(10.0, v),
          reals(0.0, 180.0), "amp_deg")
    sweep(f"MainSequence.{meth}-t_ms", lambda o, v, meth=meth: getattr(models.MainSequence(), meth)(v, 10.0),
          {"nan": [NAN], "inf": INF, "str": "t", "complex": 1j}, "t_ms")
for meth in ("peak_velocity_deg_s", "duration_ms", "settle_ms"):
    sweep(f"MainSequence.{meth}-amp_deg", lambda o, v, meth=meth: getattr(models.MainSequence(), meth)(v),
          reals(0.0, 180.0), "amp_deg")
for cls, params in ((models.BurstGenerator, ("burst_max_deg_s", "burst_scale_deg", "burst_lag_ms", "adaptation_gain",
                                             "adaptation_ms", "plant_t2_ms", "abducting_t2_ms", "adducting_t2_ms",
                                             "settle_deg")),
                    (models.VergenceDynamics, ("tau_ms", "saccade_speedup")),
                    (models.EyePositionSignal, ("sigma_ms", "delay_ms"))):
    for arg in params:
        sweep(f"{cls.__name__}-{arg}", lambda o, v, cls=cls, arg=arg: cls(**{arg: v}),
              {"nan": NAN, "inf": INF, "str": "1", "none": None, "huge": 1e9, "negative": -1e9}, arg)
sweep("BurstGenerator.profile-amp_deg", lambda o, v: models.BurstGenerator().profile(v), reals(0.0, 90.0), "amp_deg")
SP = dict(onset_ms=0, start_angles=np.zeros((2, 3)), end_angles=np.full((2, 3), 0.1), amplitude=0.1)
for arg, values in (("onset_ms", ints(0)), ("start_angles", {**arrays(np.zeros((2, 3))), "flat6": np.zeros(6)}),
                    ("end_angles", arrays(np.zeros((2, 3)))), ("amplitude", reals(0.0, np.pi)),
                    ("generator", {"dict": {}, "str": "burst"}), ("vergence", {"dict": {}, "float": 150.0}),
                    ("eye_position", {"dict": {}, "str": "signal"}),
                    ("intended_end_angles", {**{k: v for k, v in arrays(np.zeros((2, 3))).items() if k != "none"},
                                             "flat6": np.zeros(6)}),
                    ("signal_start_angles", {"nan": np.full((2, 3), NAN), "flat6": np.zeros(6)}),
                    ("intended_amplitude", {k: v for k, v in reals(0.0, np.pi).items() if k != "none"}),
                    ("target", {"nan": [NAN, 0, 0], "short": [1.0]})):
    sweep(f"SaccadePlan-{arg}", lambda o, v, arg=arg: models.SaccadePlan(**{**SP, arg: v}), values,
          arg if "angles" not in arg else f"{arg}|angles")
sweep("SaccadePlan.angles-t_ms", lambda o, v: models.SaccadePlan(**SP).angles(v), {"nan": NAN, "str": "t",
      "complex": [1j]}, "t_ms")
sweep("SaccadePlan.sample-step_ms", lambda o, v: models.SaccadePlan(**SP).sample(v),
      {**reals(0.001, 1000.0), "zero": 0.0, "tiny": 1e-12}, "step_ms")
for meth in ("velocities", "profile"):
    sweep(f"SaccadePlan.{meth}-t_ms", lambda o, v, meth=meth: getattr(models.SaccadePlan(**SP), meth)(v),
          {"nan": [NAN], "inf": INF, "str": "t", "none": None}, "t_ms")
SI = dict(name="custom", description="a scene")
for arg, values in (("name", {"none": None, "int": 3}), ("groups", {"list": [("a",)], "str_values": {"g": "abc"},
                    "int_key": {1: ("a",)}}), ("movable", {"str": "target", "ints": (1, 2)}),
                    ("default_fixation", {"nan": [NAN, 0, 1], "short": [1.0], "none": None}),
                    ("layout", {"int": 3, "str": "grid"}), ("flashes", {"none": None})):
    sweep(f"SceneInfo-{arg}", lambda o, v, arg=arg: models.SceneInfo(**{**SI, arg: v}), values,
          arg if arg != "groups" else "groups")
sweep("fixation_angles-target_head", lambda o, v: models.fixation_angles(v, np.zeros((2, 3))),
      {"nan": [NAN, 0, 0], "short": [1.0], "str": "p", "none": None}, "target")
sweep("fixation_angles-eye_centres_head", lambda o, v: models.fixation_angles([1.0, 0, 0], v),
      {"nan": np.full((2, 3), NAN), "shape": np.zeros((2, 2)), "str": "c", "empty": np.zeros((0, 3))},
      "eye_centres_head")
for fn, n in (("fick_matrix", 3), ("gaze_direction", 2), ("listing_torsion", 2)):
    sweep(f"{fn}-h", lambda o, v, fn=fn, n=n: getattr(models, fn)(v, *[np.zeros(2)] * (n - 1)),
          {"nan": NAN, "inf": [INF], "str": "h", "complex": 1j, "none": None, "mismatch": np.zeros(3)}, r"\bh\b")
sweep("fick_angles-R", lambda o, v: models.fick_angles(v), {**arrays(R_OK), "reflection": -np.eye(3),
      "2x2": np.eye(2)}, r"\bR\b")
sweep("rotation_vector-R", lambda o, v: models.rotation_vector(v), {**arrays(R_OK), "scaled": 2 * np.eye(3),
      "stack": np.stack([R_OK, R_OK])}, r"\bR\b")

# ---------------------------------------------------------------------- envs: constructor
ENV_KW = dict(image_size=32, fixation_ms=10)
ENV_BAD = {
    "scene": {"unknown": "moon", "int": 3, "list": ["dots"], "no_target": "bar"},
    "task": {"unknown": "dance", "int": 3, "none": None, "class": envs.FixateTask},
    "action_mode": choices(("vector", "cell")),
    "image_size": {**ints(16, 1024), "7.5": 7.5},
    "render_mode": {k: x for k, x in choices(("rgb_array",)).items() if k != "none"},
    "fixation_ms": {**ints(0, 10_000), "1e9": 1e9},
    "max_amplitude_deg": reals(0.0, 60.0, lo_open=True),
    "vergence": FLAGS, "grayscale": FLAGS, "include_coeffs": FLAGS,
    "remap_model": choices(("homography", "mobius", "shift")),
    "remap_models": {"str": "homography", "member": ("homography", "affine"), "int": 3, "none_member": (None,)},
    "shift_rings": reals(-5.0, 5.0),
    "cortex": choices(("eyes", "hemispheres")),
    "fovea_deg": reals(0.0, 30.0, lo_open=True, hi_open=True),
    "n_sectors": {**{k: x for k, x in ints(4, 4096).items() if k != "none"}, "36.5": 36.5, "100000": 100_000},
    "sampling": choices(("pool", "bilinear", "nearest")),
    "fovy_deg": reals(5.0, 170.0),
    "endpoint_noise": reals(0.0, 1.0),
    "quality": choices(("fast", "default")),
    "task_kwargs": {"list": [1], "str": "max_saccades=3", "unknown_key": {"colour": "red"},
                    "max_saccades_frac": {"max_saccades": 2.7}, "max_saccades_zero": {"max_saccades": 0},
                    "max_saccades_huge": {"max_saccades": 10**9}, "tolerance_nan": {"tolerance_deg": NAN},
                    "cost_nan": {"saccade_cost": NAN}, "ecc_reversed": {"min_ecc_deg": 20.0, "max_ecc_deg": 5.0},
                    "ecc_far": {"max_ecc_deg": 89.0}},
}
ENV_MATCH = {"scene": "scene|task 'fixate' needs", "task": "task", "task_kwargs": "task_kwargs|max_saccades|tolerance_deg"
             "|saccade_cost|ecc_deg|colour", "remap_models": "remap_models|model", "shift_rings": "shift_rings"}
for arg, values in ENV_BAD.items():
    sweep(f"BinocularSaccadeEnv-{arg}", lambda o, v, arg=arg: envs.BinocularSaccadeEnv(**{**ENV_KW, arg: v}), values,
          ENV_MATCH.get(arg, arg))
case("BinocularSaccadeEnv-hemispheres-odd-N", lambda o: envs.BinocularSaccadeEnv(**ENV_KW, cortex="hemispheres",
     n_sectors=18), "divisible by 4")
case("gymnasium.make-bad-kwarg", lambda o: __import__("gymnasium").make("BinocularSaccade-v0", image_size=7.5),
     "image_size")

# ---------------------------------------------------------------------- envs: reset, step, render
case("step-before-reset", lambda o: o.fresh_env.step(np.zeros(2, np.float32)), "reset", (RuntimeError,))
case("render-before-reset", lambda o: o.fresh_env.render(), "reset", (RuntimeError,))
sweep("reset-seed", lambda o, v: o.env.reset(seed=v), {"negative": -1, "frac": 1.5, "str": "0", "nan": NAN,
      "bool": True, "list": [0]}, "seed")
sweep("reset-options", lambda o, v: o.env.reset(options=v), {"list": [1], "str": "fast", "unknown": {"difficulty": 3}},
      "options")
sweep("step-vector-action", lambda o, v: o.env.step(v), {
    "nan": [NAN, 0.0], "inf": [INF, 0.0], "-inf": [0.0, -INF], "complex": [1j, 0], "complex_real": np.array([0.5 + 0j, 0]),
    "bool": [True, False], "str": "left", "str_list": ["0.1", "0.2"], "none": None, "object": np.array([object()] * 2),
    "ragged": [[0.1], [0.1, 0.2]], "shape3": [0.1, 0.1, 0.1], "shape1": [0.1], "scalar": 0.1, "2d": [[0.1, 0.1]],
    "above": [1.5, 0.0], "below": [0.0, -2.0], "huge": [1e300, 0.0], "dict": {"h": 0.1}}, "action")
sweep("step-vergence-action", lambda o, v: o.vergence_env.step(v), {"nan_vergence": [0.0, 0.0, NAN],
      "two": [0.1, 0.1], "above": [0.0, 0.0, 3.0]}, "action")
sweep("step-cell-action", lambda o, v: o.cell_env.step(v), {
    "negative": -1, "n": Lazy(lambda o: o.cell_env.action_space.n), "huge": 10**12, "frac": 2.5, "integral_float": 3.0, "nan": NAN, "inf": INF, "str": "3",
    "none": None, "bool": True, "complex": 3 + 0j, "list": [3], "array1": np.array([3]), "vector": [0.1, 0.2],
    "uint_overflow": np.uint64(2**63)}, "action|cell index")

# ---------------------------------------------------------------------- envs: Vision, tasks, display
VIS_KW = dict(image_shape=(32, 32), pixels_per_unit=22.85)
for arg, values in (("image_shape", {"frac": (32.5, 32), "zero": (0, 32), "huge": (10**6, 10**6), "str": "32x32",
                                     "one": (32,), "none": None}),
                    ("pixels_per_unit", reals(0.0, 1e6, lo_open=True)),
                    ("fovea_deg", reals(0.0, 30.0, lo_open=True, hi_open=True)),
                    ("n_sectors", {"frac": 36.5, "huge": 100_000, "zero": 0, "str": "36"}),
                    ("grayscale", FLAGS), ("sampling", choices(("pool", "nearest"))), ("shift_rings", reals(-5, 5))):
    sweep(f"Vision-{arg}", lambda o, v, arg=arg: envs.Vision(**{**VIS_KW, arg: v}), values, arg)
case("Vision-fovea-covers-picture", lambda o: envs.Vision((32, 32), 100.0, fovea_deg=29.0), "fovea")
UINT_IMG = np.zeros((32, 32, 3), np.uint8)
sweep("Vision.see-image", lambda o, v: o.vision.see(v), {
    "float_255": np.full((32, 32, 3), 255.0), "negative": np.full((32, 32, 3), -1.0), "nan": np.full((32, 32, 3), NAN),
    "complex": UINT_IMG.astype(complex), "uint16": UINT_IMG.astype(np.uint16), "bool": UINT_IMG.astype(bool),
    "shape": np.zeros((32, 32), np.uint8), "str": "image", "none": None, "longdouble": UINT_IMG.astype(np.longdouble)},
      "image")
sweep("Vision.see_eyes-images", lambda o, v: o.vision.see_eyes(v), {"one_image": UINT_IMG, "empty": [], "int": 3,
      "mixed": [UINT_IMG, UINT_IMG.astype(float)]}, "image")
sweep("Vision.point_map-model", lambda o, v: o.vision.point_map(v, np.eye(3)), choices(envs.REMAP_MODELS), "model")
sweep("Vision.point_map-rotation_eye", lambda o, v: o.vision.point_map("homography", v), {**arrays(R_OK),
      "reflection": -np.eye(3)}, "rotation_eye")
case("Vision.point_map-shift-behind", lambda o: o.vision.point_map("shift", C.rotation_matrix([0, 0, 1.0], 2.0)),
     "optical axis")
sweep("Vision.predict-view", lambda o, v: o.vision.predict(v, "homography", np.eye(3)), {"none": None, "array":
      np.zeros((5, 12, 3)), "tuple": ("a",)}, "views|EyeView")
sweep("Vision.predict_models-models", lambda o, v: o.vision.predict_models(o.views[0], v, np.eye(3)), {
    "str": "homography", "empty": (), "unknown": ("affine",), "none": None}, "model")
sweep("Vision.predict_eyes-rotations_eye", lambda o, v: o.vision.predict_eyes(o.views, ("homography",), v), {
    "one": [np.eye(3)], "nan": [np.full((3, 3), NAN)] * 2, "str": "R", "shape": np.zeros((2, 2, 2))}, "rotations_eye")
sweep("Vision.predict_arrays-views", lambda o, v: o.vision.predict_arrays(v, ("homography",), [np.eye(3)]), {
    "view": "v", "none": None, "empty": ()}, "views")
def _n_points(o: World) -> int:
    return o.vision.grid.n_fovea + o.vision.grid.M * o.vision.grid.N


sweep("Vision.errors-values", lambda o, v: o.vision.errors(v, np.ones((2, 1, _n_points(o)), bool), o.views), {
    "nan": Lazy(lambda o: np.full((2, 1, _n_points(o), 3), NAN, np.float32)), "shape": np.zeros((2, 1, 5, 3)),
    "str": "v"}, "values")
sweep("Vision.errors-valid", lambda o, v: o.vision.errors(np.zeros((2, 1, _n_points(o), 3)), v, o.views), {
    "float": Lazy(lambda o: np.ones((2, 1, _n_points(o)))), "shape": np.ones((2, 1, 5), bool)}, "valid")
sweep("normalized_error-pred", lambda o, v: envs.normalized_error(v, o.views[0]), {"none": None, "array": np.zeros(3),
      "other_grid": C.RetinaSamples(np.zeros(13), np.zeros((8, 16)), np.ones((8, 16), bool), np.ones(13, bool))},
      "pred")
sweep("normalized_error-actual", lambda o, v: envs.normalized_error(o.predictions[0]["homography"], v),
      {"none": None, "samples": "x"}, "actual")
sweep("model_errors-predictions", lambda o, v: envs.model_errors(v, o.views), {"empty": [], "none": None,
      "dict": {"homography": 1}, "empty_dict": [{}, {}]}, "predictions")
sweep("model_errors-actual", lambda o, v: envs.model_errors(o.predictions, v), {"short": ("x",), "none": None}, "actual")
for cls in (envs.Task, envs.FixateTask, envs.SearchTask, envs.FreeViewingTask):
    for arg, values in (("max_saccades", {**ints(1, 10_000), "2.7": 2.7}), ("tolerance_deg", reals(0.0, 45.0,
                        lo_open=True)), ("saccade_cost", reals(0.0, 10.0)), ("scene", {"unknown": "moon", "int": 1})):
        sweep(f"{cls.__name__}-{arg}", lambda o, v, cls=cls, arg=arg: cls(**{arg: v}), values, arg)
for arg, values in (("min_ecc_deg", reals(0.0, 30.0)), ("max_ecc_deg", {**reals(5.0, 30.0), "89": 89.0})):
    sweep(f"FixateTask-{arg}", lambda o, v, arg=arg: envs.FixateTask(**{arg: v}), values, arg)
for meth in ("check_scene", "target_position", "score"):
    sweep(f"FixateTask.{meth}-head", lambda o, v, meth=meth: getattr(envs.FixateTask(), meth)(v),
          {"none": None, "env": "env", "int": 3}, "head")
sweep("FreeViewingTask.score-head", lambda o, v: envs.FreeViewingTask().score(v), {"none": None}, "head")
sweep("FixateTask.initialize_episode-rng", lambda o, v: envs.FixateTask().initialize_episode(o.head, v),
      {"none": None, "seed": 3, "legacy": np.random.RandomState(0)}, "rng")
sweep("make_task-task", lambda o, v: envs.make_task(v), {"unknown": "dance", "int": 3, "none": None,
      "class": envs.FixateTask}, "task")
case("make_task-instance-with-kwargs", lambda o: envs.make_task(envs.FixateTask(), max_saccades=3), "keyword")
case("make_task-unknown-kwarg", lambda o: envs.make_task("fixate", colour="red"), "colour")
sweep("gaze_errors_deg-point", lambda o, v: envs.gaze_errors_deg(o.head, v), {"nan": [NAN, 0, 0], "short": [1.0],
      "str": "p", "nodal": Lazy(lambda o: o.head.eye_states()[0].camera_position)}, "point")
sweep("gaze_errors_deg-head", lambda o, v: envs.gaze_errors_deg(v, [1.0, 0, 1.2]), {"none": None, "env": "env"}, "head")
sweep("grid_overlay-shape", lambda o, v: envs.grid_overlay(o.grid, v, 10.0), {"frac": (7.5, 8), "zero": (0, 8),
      "huge": (10**6, 10**6), "str": "8x8", "one": (8,)}, "shape")
sweep("grid_overlay-pixels_per_unit", lambda o, v: envs.grid_overlay(o.grid, (8, 8), v), reals(0.0, 1e9, lo_open=True),
      "pixels_per_unit")
sweep("grid_overlay-grid", lambda o, v: envs.grid_overlay(v, (8, 8), 10.0), {"str": "grid", "none": None}, "grid")
sweep("compose_frame-frame", lambda o, v: envs.compose_frame(v, o.views, o.vision), {"none": None, "array":
      np.zeros((2, 32, 32, 3))}, "frame")
sweep("compose_frame-views", lambda o, v: envs.compose_frame(o.frame, v, o.vision), {"none": None, "one": "one"},
      "views")
sweep("compose_frame-vision", lambda o, v: envs.compose_frame(o.frame, o.views, v), {"none": None, "grid": "grid"},
      "vision")


@pytest.mark.parametrize("case", CASES, ids=[c.id for c in CASES])
def test_bad_input_raises_a_clear_error(case: Case, o: World):
    with pytest.raises(Exception) as info:
        case.call(o)
    err = info.value
    assert type(err) in case.types, f"{type(err).__module__}.{type(err).__name__}: {err}"
    assert re.search(case.match, str(err)), f"message does not name {case.match!r}: {err}"


# ---------------------------------------------------------------------- what must keep working at the edges
def _same_samples(retina: C.Retina, image: np.ndarray) -> bool:
    return np.allclose(retina.sample(image).periphery, retina.sample(image.astype(np.float64)).periphery, atol=1e-6)


#: Unimodular, with entries up to ~1e16: the square's determinant computes as 0 (+-1e9 rounding).
LARGE = np.array([[1.0, 3e4 + 0.37], [0, 1]]) @ np.array([[1.0, 0], [7e3 + 0.11, 1]])
GOOD: list[tuple[str, Callable[[World], Any]]] = [
    ("RetinaGrid-integral-float-M", lambda o: type(C.RetinaGrid(**{**GRID_KW, "M": 8.0}).M) is int),
    ("RetinaGrid-numpy-int-N", lambda o: C.RetinaGrid(**{**GRID_KW, "N": np.int64(16)}).N == 16),
    ("from_field_of_view-0d-array", lambda o: C.RetinaGrid.from_field_of_view(np.array(1.0), 0.05, 16).N == 16),
    ("check_sl2-product-with-large-entries", lambda o: C.check_sl2(LARGE @ LARGE) is not None),
    ("compose-then-act", lambda o: np.allclose(C.act(C.compose(LARGE, LARGE), 0.5), C.act(LARGE, C.act(LARGE, 0.5)))),
    ("fovea_image-nan-marker", lambda o: np.isnan(C.fovea_image(o.fovea, o.grid, outside=NAN)).any()),
    ("Retina-float16-image", lambda o: _same_samples(o.retina, o.rng.uniform(size=(40, 40)).astype(np.float16))),
    ("Retina-bigendian-image", lambda o: _same_samples(o.retina, o.rng.uniform(size=(40, 40)).astype(">f8"))),
    ("Retina-bool-image", lambda o: _same_samples(o.retina, o.rng.uniform(size=(40, 40)) > 0.5)),
    ("Retina-uint64-image", lambda o: _same_samples(o.retina, (o.rng.uniform(size=(40, 40)) * 9).astype(np.uint64))),
    ("Retina-noncontiguous-image", lambda o: _same_samples(o.retina, o.rng.uniform(size=(80, 80))[::2, ::2])),
    ("log_radius_shift-far-is-zero", lambda o: not C.log_radius_shift(o.samples, o.grid, 1e9).any()),
    ("dpft-float16-samples", lambda o: np.allclose(C.dpft(o.samples.astype(np.float16), o.grid),
                                                   C.dpft(o.samples.astype(np.float16).astype(float), o.grid))),
    ("Head.step_ms-integral-float", lambda o: (o.head.reset(settle_ms=0), o.head.step_ms(5.0), o.head.time_ms)[-1] == 5),
    ("Head.step_ms-numpy-int", lambda o: (o.head.reset(settle_ms=0), o.head.step_ms(np.int64(3)), o.head.time_ms)[-1] == 3),
    ("Head.render-numpy-bool", lambda o: o.head.render(depth=np.False_).left.depth is None),
    ("Vision-numpy-bool-grayscale", lambda o: envs.Vision((32, 32), 22.85, grayscale=np.True_).channels == 1),
    ("Vision-float-image", lambda o: o.vision.see(np.full((32, 32, 3), 0.5)).periphery.max() <= 0.5 + 1e-9),
    ("env-float32-action", lambda o: len(o.env.step(np.array([0.1, -0.1], np.float32))) == 5),
    ("env-list-action", lambda o: len(o.env.step([0.0, 0.05])) == 5),
    ("env-int-action", lambda o: len(o.env.step(np.array([0, 0]))) == 5),
    ("cell-env-numpy-int", lambda o: len(o.cell_env.step(np.int64(3))) == 5),
    ("cell-env-0d-array", lambda o: len(o.cell_env.step(np.array(5))) == 5),
    ("env-reset-numpy-seed", lambda o: len(o.env.reset(seed=np.int64(3))) == 2),
    ("env-reset-empty-options", lambda o: len(o.env.reset(options={})) == 2),
    ("make-env-integral-float-size", lambda o: envs.BinocularSaccadeEnv(image_size=32.0, fixation_ms=10.0).head.image_shape
     == (32, 32)),
    ("task-integral-float-budget", lambda o: envs.FixateTask(max_saccades=3.0).max_saccades == 3),
]


@pytest.mark.parametrize("call", [c for _, c in GOOD], ids=[i for i, _ in GOOD])
def test_valid_edge_input_still_works(call, o: World):
    assert call(o)


# ---------------------------------------------------------------------- properties
finite = st.floats(allow_nan=False, allow_infinity=False)


@settings(max_examples=200, deadline=None)
@given(st.one_of(st.floats(), st.integers(-10**20, 10**20)))
def test_integers_are_never_truncated(x):
    try:
        n = C.checks.integer("n", x)
    except ValueError as exc:
        assert "n must be an integer" in str(exc)
        assert not (isinstance(x, int) or (np.isfinite(x) and float(x).is_integer()))
    else:
        assert type(n) is int and n == x


@settings(max_examples=100, deadline=None)
@given(st.lists(st.tuples(st.floats(-1e3, 1e3), st.floats(-1e3, 1e3), st.booleans()), min_size=1, max_size=8),
       st.complex_numbers(max_magnitude=10.0))
def test_compose_is_always_accepted_by_act(shears, z):
    """Products of unimodular matrices with large entries stay acceptable to ``act`` (issue 11:
    ``compose`` results that ``act`` then rejected, an absolute determinant tolerance)."""
    gs = [np.array([[1.0, a], [0.0, 1.0]]) if up else np.array([[1.0, 0.0], [a, 1.0]]) for a, _, up in shears]
    gs += [np.diag([s, 1 / s]) for _, b, _ in shears for s in [1.0 + abs(b)]]
    g = C.compose(*gs)
    C.check_sl2(g)  # accepted
    seq = z
    for m in reversed(gs):
        try:
            seq = C.act(m, seq)
        except ValueError:  # z (or an intermediate image) is a pole of some factor
            return
    try:
        w = C.act(g, z)
    except ValueError as exc:
        assert "infinity" in str(exc) or "floating-point" in str(exc)
        return
    assert np.isfinite(w)


@settings(max_examples=100, deadline=None)
@given(st.complex_numbers(allow_nan=True, allow_infinity=True), st.complex_numbers(max_magnitude=1e6))
def test_act_gives_finite_points_or_a_clear_error(z, b):
    g = np.array([[1.0, b], [0.0, 1.0]])  # poles at z = -1/b
    try:
        w = C.act(g, z)
    except ValueError as exc:
        assert re.search("NaN|infinit|floating-point", str(exc))
    else:
        assert np.isfinite(w)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.sampled_from(["uint8", "int16", "float16", "float32", "float64", "bool", ">f4"]), st.integers(0, 2**31))
def test_any_finite_image_gives_finite_samples_within_its_range(o, dtype, seed):
    rng = np.random.default_rng(seed)
    img = (rng.uniform(-50, 200, size=(40, 40))).astype(dtype)
    s = o.retina.sample(img)
    vals = np.concatenate([s.fovea, s.periphery.ravel()])
    lo, hi = float(np.min(img.astype(float))), float(np.max(img.astype(float)))
    assert np.all(np.isfinite(vals)) and vals.min() >= lo - 1e-6 * (1 + abs(lo)) and vals.max() <= hi + 1e-6 * (1 + abs(hi))


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.floats(-1e300, 1e300), st.floats(-1e300, 1e300), st.integers(-10, 10**6))
def test_grids_are_bounded_or_refused(rb, r0, n):
    try:
        g = C.RetinaGrid.from_field_of_view(rb, r0, n)
    except ValueError as exc:
        assert re.search(r"rb|r0|n_sectors|M|N|n_fovea|period", str(exc))
    else:
        assert g.M * g.N <= 2**22 and g.n_fovea <= 2**20 and np.isfinite(g.rb)


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.tuples(st.floats(-1, 1), st.floats(-1, 1)))
def test_any_valid_action_gives_a_finite_observation(o, action):
    obs, reward, terminated, truncated, info = o.env.step(np.array(action))
    assert o.env.observation_space.contains(obs)  # finite, within [0, 1] (cortical) and [-pi, pi] (eyes)
    assert np.isfinite(reward) and np.isfinite(info["landing_error_deg"])
    if terminated or truncated:
        o.env.reset()


# ---------------------------------------------------------------------- AsyncVectorEnv with fork after rendering
_FORK_SCRIPT = textwrap.dedent("""
    import time
    import gymnasium as gym
    import envs
    e = envs.BinocularSaccadeEnv(image_size=16, fixation_ms=0)
    e.reset(seed=0)  # this process renders: it now holds an EGL context
    e.close()
    vec = gym.make_vec("BinocularSaccade-v0", num_envs=2, vectorization_mode="async", image_size=16, fixation_ms=0,
                       vector_kwargs={"context": "fork"})
    print("workers", *[p.pid for p in vec.processes], flush=True)
    t = time.monotonic()
    try:
        vec.reset(seed=0)
    except Exception as exc:
        print("raised", type(exc).__name__, round(time.monotonic() - t, 2), str(exc).replace("\\n", " "), flush=True)
    else:
        print("no error", flush=True)
""")


def test_fork_after_render_raises_naming_spawn():
    """An AsyncVectorEnv forked after its parent rendered used to deadlock forever and orphan its
    workers (issue 11, item 4); now every worker's first render raises ``ForkedGLContextError``,
    reported in the parent at ``reset``, and no worker outlives the parent."""
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    env = {**os.environ, "PYTHONPATH": root + os.pathsep + os.environ.get("PYTHONPATH", "")}
    run = subprocess.run([sys.executable, "-c", _FORK_SCRIPT], cwd=root, env=env, capture_output=True, text=True,
                         timeout=120)
    out = run.stdout
    assert "raised ForkedGLContextError" in out, out + run.stderr[-3000:]
    line = next(l for l in out.splitlines() if l.startswith("raised"))
    assert float(line.split()[2]) < 20  # fails fast
    assert "spawn" in line and "vector_kwargs={'context': 'spawn'}" in line
    pids = [int(p) for p in next(l for l in out.splitlines() if l.startswith("workers")).split()[1:]]
    assert len(pids) == 2
    for pid in pids:  # the parent has exited (without closing the vector env): no worker is left
        with pytest.raises(ProcessLookupError):
            os.kill(pid, 0)


_FORKED_RENDERER_SCRIPT = textwrap.dedent("""
    import os
    import models
    head = models.Head("bar", image_size=16)
    head.render()  # the renderer and its EGL context belong to this process
    pid = os.fork()
    if pid == 0:  # the child inherits the renderer object
        try:
            head.render()
            code = 1
        except models.ForkedGLContextError as exc:
            code = 0 if "spawn" in str(exc) else 2
        head.close()  # must not hang either
        os._exit(code)
    _, status = os.waitpid(pid, 0)
    print("child exit", os.waitstatus_to_exitcode(status), flush=True)
    head.render()  # the parent's context still works
    head.close()
    print("parent ok", flush=True)
""")


def test_renderer_inherited_through_fork_raises_instead_of_hanging():
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    env = {**os.environ, "PYTHONPATH": root + os.pathsep + os.environ.get("PYTHONPATH", "")}
    run = subprocess.run([sys.executable, "-c", _FORKED_RENDERER_SCRIPT], cwd=root, env=env, capture_output=True,
                         text=True, timeout=60)
    assert "child exit 0" in run.stdout and "parent ok" in run.stdout, run.stdout + run.stderr[-3000:]


@pytest.mark.adversarial
@pytest.mark.parametrize("r0", [2.2250738585e-313, 5e-324, 1e-310])
def test_subnormal_foveal_radius_is_refused(r0):
    """Found by hypothesis (test_grids_are_bounded_or_refused): a subnormal r0 made the implied
    sampling density overflow to inf and the log spacing 0 (ZeroDivisionError)."""
    with pytest.raises(ValueError, match="r0"):
        C.RetinaGrid.from_field_of_view(1.0, r0, 4)
