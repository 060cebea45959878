"""Hostile input to every public name of ``conformal``, ``models`` and ``envs`` (issue 11, item 5;
issue 21, item 10: the same guarantees in a fraction of the items and the time).

The contract: a public function, constructor, method or env action given NaN, infinity, a wrong
type, a wrong shape, zero, a negative, a huge or a non-integral value raises a ``ValueError`` or
``TypeError`` (``conformal.checks.InputTypeError`` is both) whose message names the argument,
never a silent NaN, a truncation, an internal traceback (numba, IndexError, LinAlgError), a hang
or an unbounded allocation. It is checked in three layers, each once:

* ``tests/test_checks.py`` tries every kind of hostile value on each check of ``conformal.checks``
  (the helpers every public argument goes through);
* ``test_public_api_validates_every_argument`` walks the public API: every callable named in
  ``conformal.__all__``, ``models.__all__`` and ``envs.__all__`` (functions, constructors and the
  public methods the packages define, ``__call__`` and ``__getitem__`` included) must have an
  entry in ``API`` (a valid call) or a reason in ``EXEMPT``; the walk then calls it once with valid
  arguments (which must work) and, for each parameter in turn, with probes chosen from the kind of
  the valid value (a number: NaN, inf, a string, a bool and None; a bool: a string and an int; a
  string: an int; an array: all-NaN, a string and an object array; any other object: a bare
  ``object()`` and an int; None wherever None is not the default), plus the entry's own
  domain values (bounds, non-integral counts, sizes that would allocate without limit, wrong
  shapes, unknown choices). Each must raise ``ValueError``/``TypeError`` (or the entry's listed
  types) with a message naming the parameter. A public callable added without an entry fails the
  walk. ``KNOWN_GAPS`` lists the arguments the walk found unvalidated (reported in issue 21),
  and the walk fails when one of them becomes validated, so the list cannot go stale;
* ``CASES``: the refusals that are not "a bad value of one argument" (overflow, poles, singular
  and non-unimodular matrices, argument combinations, read-only constants, calls before
  ``reset``, missing files), one item each.

A few cases check what must keep working at the edges (integral floats, float16 and big-endian
images, numpy scalars), hypothesis properties check that any finite valid input gives a finite
result, and two subprocess tests check that rendering after a ``fork`` raises instead of
deadlocking (``test_fork_after_render_raises_naming_spawn``,
``test_renderer_inherited_through_fork_raises_instead_of_hanging``).
"""

from __future__ import annotations

import inspect
import numbers
import os
import re
import signal
import subprocess
import sys
import textwrap
from dataclasses import dataclass, field
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
#: a call running this long is a hang (the guard never fires on a merely loaded machine)
HANG_S = 600


@pytest.fixture(autouse=True)
def _no_hang():
    """Fail a test that runs longer than HANG_S seconds (a hang), instead of blocking the suite."""

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
    def plan_values(self):
        return self.plan(*self.plan_args)

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

    @cached_property
    def n_points(self) -> int:
        return self.vision.grid.n_fovea + self.vision.grid.M * self.vision.grid.N

    @cached_property
    def profile(self):
        return models.BurstGenerator().profile(10.0)

    @cached_property
    def trace(self):
        self.head.reset(settle_ms=0)
        return self.head.step_ms(3, record=True)

    @cached_property
    def planner(self):
        return models.BatchedPlanner(self.head, 2)

    @cached_property
    def plan_batch(self):
        self.head.reset(settle_ms=0)
        batch, _ = self.planner.plan(np.arange(2), np.full((2, 2), 0.05), np.ones(2))
        return batch

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


class Lazy:
    """A value that depends on the shared objects: ``Lazy(lambda o: ...)``."""

    def __init__(self, make: Callable[[World], Any]):
        self.make = make


def _resolve(v, o: World):
    return v.make(o) if isinstance(v, Lazy) else v


# ---------------------------------------------------------------------- domain values (beyond the generic probes)
def bounds(lo=None, hi=None, *, lo_open=False, hi_open=False) -> dict[str, Any]:
    """Values just outside the interval of a real argument (and a huge one when it is bounded above)."""
    out: dict[str, Any] = {}
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


def counts(lo=None, hi=None) -> dict[str, Any]:
    """Bad values for an integer in [lo, hi]: non-integral (never truncated), outside, huge."""
    base = lo if lo is not None else 0
    out: dict[str, Any] = {"frac": base + 1.5 if hi is None or base + 2 <= hi else base + 0.5}
    if lo is not None:
        out["below"] = lo - 1
    if hi is not None:
        out["above"] = hi + 1
        out["huge"] = 10**12
        out["huge_float"] = 1e9 if hi < 1e9 else 1e15
    return out


def unknown(valid: str) -> dict[str, Any]:
    """Bad values for a string choice."""
    return {"unknown": "nonsense", "empty": "", "upper": valid.upper(), "list": [valid]}


def shapes(good, complex_ok: bool = False) -> dict[str, Any]:
    """Wrong shapes and kinds for an array argument (its NaN, string and object forms are generic probes)."""
    good = np.asarray(good)
    out = {"ragged": [[1.0, 2.0], [3.0]], "empty": np.zeros((0,)), "extra_dims": good[..., None, None]}
    if good.ndim >= 1:
        out["short"] = np.take(good, np.arange(max(good.shape[0] - 1, 0)), axis=0)
    if good.dtype.kind != "c" and not complex_ok:
        out["complex"] = good.astype(complex) + 1j
    return out


G_OK = np.eye(2, dtype=complex)
R_OK = np.eye(3)
Z_OK = np.array([0.1 + 0.2j, -0.3j])
GRID_KW = dict(r0=0.05, delta=0.3, M=8, N=16, fovea_spacing=0.04, n_fovea=13)
IMG = np.zeros((40, 40))
UINT_IMG = np.zeros((32, 32, 3), np.uint8)
SP = dict(onset_ms=0, start_angles=np.zeros((2, 3)), end_angles=np.full((2, 3), 0.1), amplitude=0.1)
RS = dict(fovea=np.zeros(13), periphery=np.zeros((8, 16)), mask=np.ones((8, 16), bool), fovea_mask=np.ones(13, bool))
SL2_BAD = {"det2": np.diag([2.0, 1.0]), "singular": np.zeros((2, 2)), "3x3": np.eye(3)}
ROT_BAD = {"reflection": np.diag([1, 1, -1.0]), "scaled": 2 * np.eye(3), "2x2": np.eye(2)}
H_BAD = {"4x4": np.eye(4), "2x2": np.eye(2), "singular": np.zeros((3, 3)), "rank1": np.ones((3, 3))}
PIXEL_SHAPE_BAD = {"zero": (0, 8), "negative": (-1, 8), "frac": (7.5, 8), "huge": (10**9, 10**9), "one": (8,),
                   "bool": (True, 8)}
ALL_ERRORS = (ValueError, TypeError)


# ---------------------------------------------------------------------- the public API: one valid call each
@dataclass
class Api:
    """How to call one public callable validly, and what else it must refuse.

    ``get(o)`` gives the callable (a function, a class or a bound method); ``valid`` its valid
    arguments by parameter name (values may be ``Lazy``; a ``*args`` parameter takes a tuple);
    parameters left out take their defaults. ``bad`` adds domain values per parameter, ``names``
    the regex a message must match for a parameter (default: its name), ``free`` parameters that
    take any value of the probed kind, with the reason, ``types`` the accepted exception types,
    ``run_valid=False`` skips the valid call (one with side effects the later entries must not see).
    """

    get: Callable[[World], Callable]
    valid: dict[str, Any] = field(default_factory=dict)
    bad: dict[str, dict[str, Any]] = field(default_factory=dict)
    names: dict[str, str] = field(default_factory=dict)
    free: dict[str, str] = field(default_factory=dict)
    types: tuple = ALL_ERRORS
    run_valid: bool = True


API: dict[str, Api] = {
    # ---------------------------------------------------------------- conformal: geometry
    "conformal.act": Api(lambda o: C.act, dict(g=G_OK, z=Z_OK), bad={"g": SL2_BAD}, names={"g": r"\bg\b", "z": r"\bz\b"}),
    "conformal.apply_homography": Api(lambda o: C.apply_homography, dict(H=R_OK, z=Z_OK), bad={"H": H_BAD},
                                      names={"H": r"\bH\b", "z": r"\bz\b"}),
    "conformal.check_sl2": Api(lambda o: C.check_sl2, dict(g=G_OK), bad={"g": SL2_BAD, "tol": bounds(0.0, 0.01, lo_open=True)},
                               names={"g": r"\bg\b"}),
    "conformal.check_rotation": Api(lambda o: C.check_rotation, dict(R=R_OK), bad={"R": ROT_BAD}, names={"R": r"\bR\b"}),
    "conformal.compose": Api(lambda o: C.compose, dict(gs=(G_OK, G_OK)), bad={"gs": {"det3": (G_OK, 3 * np.eye(2))}},
                             names={"gs": "g2"}),
    "conformal.cortical_map": Api(lambda o: C.cortical_map, dict(samples=np.zeros((8, 16)), grid=Lazy(lambda o: o.grid)),
                                  bad={"samples": shapes(np.zeros((8, 16)), complex_ok=True)}),
    "conformal.hemifields": Api(lambda o: C.hemifields, dict(samples=np.zeros((8, 16, 3)), grid=Lazy(lambda o: o.grid)),
                                bad={"samples": shapes(np.zeros((8, 16, 3)), complex_ok=True)}),
    "conformal.binocular_cortex": Api(lambda o: C.binocular_cortex, dict(
        left_eye=np.zeros((8, 16)), right_eye=np.zeros((8, 16)), grid=Lazy(lambda o: o.grid)),
        bad={"left_eye": shapes(np.zeros((8, 16)), complex_ok=True), "right_eye": {"short": np.zeros((7, 16))}}),
    "conformal.BinocularCortex": Api(lambda o: C.BinocularCortex, dict(
        left_hemisphere=np.zeros((2, 8, 8)), right_hemisphere=np.zeros((2, 8, 8))),
        bad={"left_hemisphere": {"one_eye": np.zeros((1, 8, 8)), **shapes(np.zeros((2, 8, 8)), complex_ok=True)}},
        names={"left_hemisphere": "hemisphere", "right_hemisphere": "hemisphere"}),
    "conformal.k_matrix": Api(lambda o: C.k_matrix, dict(psi=0.1, phi=0.1, psi2=0.1)),
    "conformal.euler_rotation": Api(lambda o: C.euler_rotation, dict(psi=0.1, phi=0.1, psi2=0.1)),
    "conformal.h_matrix": Api(lambda o: C.h_matrix, dict(b1=0.1, b2=0.1, b3=0.1), bad={"b2": {"-1": -1.0}},
                              names={"b2": "b2"}),
    "conformal.inverse": Api(lambda o: C.inverse, dict(g=G_OK), bad={"g": SL2_BAD}, names={"g": r"\bg\b"}),
    "conformal.lift_to_sphere": Api(lambda o: C.lift_to_sphere, dict(z=Z_OK), bad={"z": {"inf": [1j * INF]}},
                                    names={"z": r"\bz\b"}),
    "conformal.mobius_from_points": Api(lambda o: C.mobius_from_points, dict(z=[0, 1, 1j], w=[0, 1, 1j]), bad={
        "z": {"two": [0, 1], "repeated": [0, 0, 1]}, "w": {"four": [0, 1, 2, 3], "repeated": [1j, 1j, 1]}},
        names={"z": r"\bz\b|three points", "w": r"\bw\b|three points"}),
    "conformal.project": Api(lambda o: C.project, dict(points=np.array([[0.0, 1.0, 0.0]])),
                             bad={"points": {"x2=0": [1.0, 0.0, 2.0], "2d": [1.0, 2.0], "ragged": [[1.0, 2.0], [3.0]]}},
                             names={"points": "points|x2 = 0"}),
    "conformal.rotation_from_su2": Api(lambda o: C.rotation_from_su2, dict(k=G_OK),
                                       bad={"k": {"not_unitary": np.array([[1, 1], [0, 1.0]]), "3x3": np.eye(3)}},
                                       names={"k": r"\bk\b"}),
    "conformal.rotation_matrix": Api(lambda o: C.rotation_matrix, dict(axis=[0.0, 0.0, 1.0], angle=0.1),
                                     bad={"axis": {"zero": np.zeros(3), "3x3": np.eye(3)}}),
    "conformal.schwartz_map": Api(lambda o: C.schwartz_map, dict(z=Z_OK, a=1.0), bad={"a": bounds(0.0, lo_open=True)},
                                  names={"z": r"\bz\b", "a": r"\ba\b"}),
    "conformal.transform_image": Api(lambda o: C.transform_image, dict(f=abs, g=G_OK), bad={"g": SL2_BAD},
                                     names={"f": r"\bf\b", "g": r"\bg\b"}),
    # ---------------------------------------------------------------- conformal: grid
    "conformal.RetinaGrid": Api(lambda o: C.RetinaGrid, GRID_KW, bad={
        "r0": bounds(0.0, 1e6, lo_open=True), "delta": bounds(0.0, 100.0, lo_open=True),
        "fovea_spacing": bounds(0.0, 1e6, lo_open=True), "M": {**counts(2, 4096), "1e9": 1e9}, "N": counts(2, 8192),
        "n_fovea": counts(1, 2**20)}, names={"M": r"\bM\b", "N": r"\bN\b"}),
    "conformal.RetinaGrid.from_picture": Api(lambda o: C.RetinaGrid.from_picture, dict(
        width=64, height=64, dots_per_unit=4.0, foveal_pixels=64, extent="diagonal", r0_decimals=3), bad={
        "width": counts(1, 65536), "height": counts(1, 65536), "foveal_pixels": counts(1, 2**20),
        "dots_per_unit": bounds(0.0, 1e9, lo_open=True), "extent": unknown("diagonal"), "r0_decimals": counts(0, 15)}),
    "conformal.RetinaGrid.from_field_of_view": Api(lambda o: C.RetinaGrid.from_field_of_view, dict(
        rb=1.0, r0=0.05, n_sectors=16), bad={"rb": bounds(0.0, lo_open=True), "r0": bounds(0.0, 1e6, lo_open=True),
                                           "n_sectors": {**counts(4, 8192), "100000": 100000}}),
    "conformal.RetinaGrid.from_angles": Api(lambda o: C.RetinaGrid.from_angles, dict(field_deg=40.0, fovea_deg=1.0), bad={
        "field_deg": bounds(0.0, 90.0, lo_open=True, hi_open=True), "fovea_deg": bounds(0.0, 90.0, lo_open=True, hi_open=True),
        "n_sectors": counts(4, 8192)}),
    "conformal.RetinaGrid.locate": Api(lambda o: o.grid.locate, dict(z=Z_OK), bad={"z": {"inf": 1j * INF}},
                                       names={"z": r"\bz\b"}),
    # ---------------------------------------------------------------- conformal: DPFT, fovea, shift
    "conformal.dpft": Api(lambda o: C.dpft, dict(samples=np.zeros((8, 16)), grid=Lazy(lambda o: o.grid)),
                          bad={"samples": {**shapes(np.zeros((8, 16))), "longdouble": np.zeros((8, 16), np.longdouble)}}),
    "conformal.dpft_direct": Api(lambda o: C.dpft_direct, dict(samples=np.zeros((8, 16)), grid=Lazy(lambda o: o.grid)),
                                 bad={"samples": {**shapes(np.zeros((8, 16))), "longdouble": np.zeros((8, 16), np.longdouble)}}),
    "conformal.idpft": Api(lambda o: C.idpft, dict(coeffs=np.zeros((8, 16), complex), grid=Lazy(lambda o: o.grid)),
                           bad={"coeffs": shapes(np.zeros((8, 16), complex))}),
    "conformal.idpft_direct": Api(lambda o: C.idpft_direct, dict(coeffs=np.zeros((8, 16), complex),
                                                                 grid=Lazy(lambda o: o.grid)),
                                  bad={"coeffs": shapes(np.zeros((8, 16), complex))}),
    "conformal.pft_frequencies": Api(lambda o: C.pft_frequencies, dict(grid=Lazy(lambda o: o.grid))),
    "conformal.field_moments": Api(lambda o: C.field_moments, dict(grid=Lazy(lambda o: o.grid))),
    "conformal.evaluate": Api(lambda o: C.evaluate, dict(coeffs=Lazy(lambda o: o.coeffs), grid=Lazy(lambda o: o.grid),
                                                         points=[0.3]),
                              bad={"points": {"zero": [0j]}, "extension": unknown("mirror"),
                                   "coeffs": shapes(np.zeros((8, 16), complex))}, names={"points": "points|z = 0"}),
    "conformal.evaluate_direct": Api(lambda o: C.evaluate_direct, dict(
        coeffs=Lazy(lambda o: o.coeffs), grid=Lazy(lambda o: o.grid), points=[0.3]),
        bad={"points": {"zero": [0j]}, "extension": unknown("mirror")}, names={"points": "points|z = 0"}),
    "conformal.OffGridEvaluator": Api(lambda o: C.OffGridEvaluator, dict(grid=Lazy(lambda o: o.grid), points=[0.3]), bad={
        "eps": {**bounds(1e-15, 1e-2), "ten": 10.0}, "method": unknown("auto"), "extension": unknown("mirror"),
        "points": {"zero": [0.0]},
        "dtype": {"float16": np.float16, "complex": complex, "int": int, "str": "fast", "longdouble": np.longdouble}}),
    "conformal.OffGridEvaluator.__call__": Api(lambda o: o.evaluator, dict(coeffs=Lazy(lambda o: o.coeffs)),
                                               bad={"coeffs": shapes(np.zeros((8, 16), complex))}),
    "conformal.transform": Api(lambda o: C.transform, dict(coeffs=Lazy(lambda o: o.coeffs), grid=Lazy(lambda o: o.grid),
                                                           g=G_OK), bad={"g": SL2_BAD, "extension": unknown("mirror")},
                               names={"g": r"\bg\b"}),
    "conformal.warp": Api(lambda o: C.warp, dict(coeffs=Lazy(lambda o: o.coeffs), grid=Lazy(lambda o: o.grid),
                                                 point_map=lambda z: z), bad={"point_map": {
        "wrong_shape": lambda z: z.ravel()[:3], "scalar": lambda z: 0.3 + 0j, "nan": lambda z: z * NAN,
        "strings": lambda z: np.full(z.shape, "x"),
        "behind_eye": C.homography_map(C.rotation_matrix([0, 0, 1.0], np.radians(120)))}, "extension": unknown("mirror")}),
    "conformal.fovea_indices": Api(lambda o: C.fovea_indices, dict(grid=Lazy(lambda o: o.grid))),
    "conformal.fovea_image": Api(lambda o: C.fovea_image, dict(fovea=np.zeros(13), grid=Lazy(lambda o: o.grid)),
                                 bad={"fovea": shapes(np.zeros(13), complex_ok=True)}, free={"outside": "NaN marks outside the fovea"}),
    "conformal.fovea_dft": Api(lambda o: C.fovea_dft, dict(fovea=np.zeros(13), grid=Lazy(lambda o: o.grid)),
                               bad={"fovea": shapes(np.zeros(13), complex_ok=True)}),
    "conformal.fovea_idft": Api(lambda o: C.fovea_idft, dict(coeffs=Lazy(lambda o: C.fovea_dft(o.fovea, o.grid)),
                                                         grid=Lazy(lambda o: o.grid)),
                                bad={"coeffs": shapes(np.zeros((4, 4), complex))}, names={"coeffs": "coeffs|foveal coefficients"}),
    "conformal.log_radius_shift": Api(lambda o: C.log_radius_shift, dict(
        samples=Lazy(lambda o: o.samples), grid=Lazy(lambda o: o.grid), shift=0.5), bad={"samples": shapes(np.zeros((8, 16)))}),
    # ---------------------------------------------------------------- conformal: sampling
    "conformal.pixel_points": Api(lambda o: C.pixel_points, dict(shape=(4, 4), pixels_per_unit=10.0), bad={
        "shape": {**PIXEL_SHAPE_BAD, "huge_float": (1e9, 1e9), "three": (4, 4, 4)},
        "pixels_per_unit": bounds(0.0, 1e9, lo_open=True)}),
    "conformal.Retina": Api(lambda o: C.Retina, dict(grid=Lazy(lambda o: o.grid), image_shape=(40, 40),
                                                     pixels_per_unit=20.0), bad={
        "image_shape": {"zero": (0, 40), "frac": (40.5, 40), "huge": (10**6, 10**6), "one": (40,), "four": (4, 4, 3, 1),
                        "channels": (4, 4, 10**6)},
        "pixels_per_unit": bounds(0.0, 1e9, lo_open=True), "mode": unknown("pool"), "supersample": counts(1, 16),
        "min_coverage": bounds(0.0, 1.0, lo_open=True)}),
    "conformal.Retina.sample": Api(lambda o: o.retina.sample, dict(image=IMG), bad={"image": {
        **shapes(IMG), "longdouble": IMG.astype(np.longdouble), "complex64": IMG.astype(np.complex64),
        "datetime": IMG.astype("datetime64[s]"), "rgb_channels_5": np.zeros((40, 40, 5)), "transposed": np.zeros((40, 41)),
        "float16_nan": np.full((40, 40), NAN, np.float16), "bigendian_inf": np.full((40, 40), INF, ">f8")}}),
    "conformal.Retina.sample_many": Api(lambda o: o.retina.sample_many, dict(images=[IMG]), bad={
        "images": {"one_picture": IMG, "bad_member": [IMG, np.zeros((3, 3))]}}, names={"images": "image"}),
    "conformal.Retina.render": Api(lambda o: o.retina.render, dict(samples=Lazy(lambda o: o.retina_samples)), bad={
        "samples": {"dict": {"fovea": 0}, "array": np.zeros((8, 16))}}),
    "conformal.RetinaSamples": Api(lambda o: C.RetinaSamples, RS, bad={
        "fovea": {"complex": np.zeros(13, complex), "3d": np.zeros((13, 1, 1))},
        "periphery": {"1d": np.zeros(5), "channels": np.zeros((8, 16, 2))},
        "mask": {"float": np.ones((8, 16)), "shape": np.ones((8, 15), bool)},
        "fovea_mask": {"int": np.ones(13, int), "shape": np.ones(12, bool)}},
        names={"periphery": "periphery|channels"},
        free={"fovea": "nan: samples outside the picture are NaN-free by mask, NaN values are data",
              "periphery": "nan: as fovea"}),
    # ---------------------------------------------------------------- conformal: remapping
    "conformal.ProjectiveMap": Api(lambda o: C.ProjectiveMap, dict(H=R_OK), bad={"H": H_BAD}, names={"H": r"\bH\b"}),
    "conformal.ProjectiveMap.__call__": Api(lambda o: C.ProjectiveMap(R_OK), dict(z=Z_OK), names={"z": r"\bz\b"}),
    "conformal.MobiusMap": Api(lambda o: C.MobiusMap, dict(g=G_OK), bad={"g": {"singular": np.ones((2, 2)), "3x3": np.eye(3)}},
                               names={"g": r"\bg\b"}),
    "conformal.MobiusMap.__call__": Api(lambda o: C.MobiusMap(G_OK), dict(z=Z_OK), names={"z": r"\bz\b"}),
    "conformal.homography_map": Api(lambda o: C.homography_map, dict(R=R_OK), bad={"R": ROT_BAD}, names={"R": r"\bR\b"}),
    "conformal.mobius_map": Api(lambda o: C.mobius_map, dict(R=R_OK), bad={"R": ROT_BAD}, names={"R": r"\bR\b"}),
    "conformal.mobius_for_rotation": Api(lambda o: C.mobius_for_rotation, dict(R=R_OK), bad={"R": ROT_BAD},
                                         names={"R": r"\bR\b"}),
    "conformal.rotation_homography": Api(lambda o: C.rotation_homography, dict(R=R_OK), bad={"R": ROT_BAD},
                                         names={"R": r"\bR\b"}),
    "conformal.su2_from_rotation": Api(lambda o: C.su2_from_rotation, dict(R=R_OK), bad={"R": ROT_BAD}, names={"R": r"\bR\b"}),
    "conformal.target_shift_map": Api(lambda o: C.target_shift_map, dict(z_target=0.1 + 0j, shift=1.0, delta=0.1), bad={
        "z_target": {"list": [0.1, 0.2], "inf": complex(0, INF)}, "delta": bounds(0.0, 100.0, lo_open=True)}),
    "conformal.predict": Api(lambda o: C.predict, dict(coeffs=Lazy(lambda o: o.coeffs), fovea=Lazy(lambda o: o.fovea),
                                                       grid=Lazy(lambda o: o.grid), point_map=lambda z: z,
                                                       on=Lazy(lambda o: o.grid)),
                             bad={"point_map": {"wrong_shape": lambda z: z[:3], "strings": lambda z: np.full(z.shape, "x")},
                                  "fovea": {"channels": np.zeros((13, 3)), "short": np.zeros(12)}},
                             names={"point_map": "point map", "on": r"\bon\b"}),
    "conformal.predict_many": Api(lambda o: C.predict_many, dict(
        coeffs=Lazy(lambda o: o.coeffs), fovea=Lazy(lambda o: o.fovea), grid=Lazy(lambda o: o.grid),
        point_maps=[lambda z: z], on=Lazy(lambda o: o.grid), dtype=np.float32),
        bad={"point_maps": {"empty": [], "callable": lambda z: z, "member": [lambda z: z, 3]},
             "dtype": {"float16": np.float16, "str": "fast"}}, names={"point_maps": "point map", "on": r"\bon\b"}),
    "conformal.RemapPlan": Api(lambda o: C.RemapPlan, dict(grid=Lazy(lambda o: o.grid), on=Lazy(lambda o: o.grid)),
                               names={"on": "grid"}),
    "conformal.RemapPlan.__call__": Api(lambda o: o.plan, dict(coeffs=Lazy(lambda o: o.plan_args[0]),
                                                               fovea=Lazy(lambda o: o.plan_args[1]),
                                                               maps=Lazy(lambda o: o.plan_args[2])), bad={
        "coeffs": {"3d": np.zeros((8, 16, 1), complex), "one_eye": np.zeros((1, 8, 16, 1), complex)},
        "fovea": {"complex": np.zeros((2, 13, 1), complex), "short": np.zeros((2, 12, 1))},
        "maps": {"flat": [C.homography_map(np.eye(3))] * 2, "one_eye": [[C.homography_map(np.eye(3))]],
                 "callables": [[abs], [abs]], "strings": [["homography"], ["homography"]]}},
        names={"coeffs": "coeffs|fovea", "maps": "maps|point maps|ProjectiveMap"}),
    "conformal.RemapPlan.series_coefficients": Api(lambda o: o.plan.series_coefficients, dict(
        coeffs=Lazy(lambda o: o.plan_args[0])), bad={"coeffs": {"3d": np.zeros((8, 16, 1), complex)}}),
    "conformal.RemapPlan.samples": Api(lambda o: o.plan.samples, dict(
        values=Lazy(lambda o: o.plan_values[0]), valid=Lazy(lambda o: o.plan_values[1])), bad={
        "values": {"wrong_points": np.zeros((2, 1, 5, 1), np.float32), "3d": np.zeros((2, 1, 5))},
        "valid": {"float": Lazy(lambda o: np.ones((2, 1, o.plan.n_points))), "shape": np.ones((2, 1, 3), bool)}},
        free={"values": "nan: the values are data (invalid points are masked by valid)"}),
    "conformal.blas_threads": Api(lambda o: C.blas_threads, dict(n=1), bad={"n": {"zero": 0, "negative": -1, "frac": 1.5}},
                                  names={"n": r"\bn\b"}),
    # ---------------------------------------------------------------- models: building
    "models.build_spec": Api(lambda o: models.build_spec, dict(scene="bar", head_xml=str(models.HEAD_XML)), bad={
        "scene": unknown("bar"), "quality": unknown("fast"), "ipd": bounds(0.01, 0.15), "fovy_deg": bounds(5.0, 170.0),
        "offscreen_size": {"zero": (0, 480), "frac": (640.5, 480), "huge": (10**9, 10**9), "three": (1, 2, 3),
                           "negative": (-640, 480)},
        "head_xml": {"empty": "", "list": ["head.xml"]}}, free={"scene": "None builds the head without a scene"}),
    "models.build_model": Api(lambda o: models.build_model, dict(scene="bar"), bad={"scene": unknown("bar")},
                              free={"scene": "none: builds the head without a scene"}),
    "models.export_xml": Api(lambda o: models.export_xml, dict(scene="bar", path=Lazy(lambda o: _tmp("export.xml"))),
                             bad={"path": {"empty": "", "folder": "/tmp"}},
                             free={"scene": "None exports the head without a scene"}),
    "models.load_model": Api(lambda o: models.load_model, dict(path=str(models.HEAD_XML)), bad={"path": {"empty": ""}}),
    "models.screen_point": Api(lambda o: models.screen_point, dict(azimuth=0.1, elevation=0.1, distance=1.0), bad={
        "azimuth": bounds(-np.pi / 2, np.pi / 2, lo_open=True, hi_open=True),
        "elevation": bounds(-np.pi / 2, np.pi / 2, lo_open=True, hi_open=True), "distance": bounds(0.0, 1000.0, lo_open=True)}),
    "models.gl_install_hint": Api(lambda o: models.gl_install_hint, dict(backend="egl"), bad={"backend": {"list": ["egl"]}}),
    # ---------------------------------------------------------------- models: the head
    "models.Head": Api(lambda o: models.Head, dict(scene="bar", image_size=16, seed=0, generator=models.BurstGenerator(),
                                                   vergence=models.VergenceDynamics(),
                                                   eye_position=models.EyePositionSignal(),
                                                   plant=models.OrbitalPlant(), motor_noise=models.MotorNoise()), bad={
        "scene": {"unknown": "moon"},
        "image_size": {**counts(1, 4096), "pair_frac": (32, 7.5), "pair_huge": (32, 10**6), "triple": (32, 32, 3)},
        "fovy_deg": bounds(5.0, 170.0), "ipd": bounds(0.01, 0.15), "quality": unknown("fast"),
        "seed": {"negative": -1, "frac": 1.5}, "endpoint_noise": bounds(0.0, 1.0),
        "main_sequence": {"dict": {"m0_deg": 7.0}, "burst": models.BurstGenerator(), "object": object(), "int": 3,
                          "str": "vanwetter", "with_burst": models.MainSequence()},
        "saccade_model": unknown("burst"), "generator": {"dict": {}, "main_sequence": models.MainSequence()},
        "vergence": {"dict": {}, "float": 150.0}, "eye_position": {"dict": {}, "float": 50.0},
        "timestep_ms": {**bounds(0.01, 1.0), "not_a_divisor": 0.3, "tiny": 1e-9},
        "saccade_timestep_ms": {**bounds(0.01, 1.0), "not_a_divisor": 0.7},
        "eye_drive": unknown("plant"), "plant": {"dict": {}, "float": 150.0},
        "motor_noise": {"dict": {}, "float": 0.1}, "linear_tail": {"int": 1, "none": None, "str": "yes"}},
        names={"main_sequence": "main_sequence|saccade_model"},
        free={"main_sequence": "probed by its domain values (valid only with saccade_model='legacy')"}),
    "models.Head.step_ms": Api(lambda o: o.head.step_ms, dict(n=1), bad={"n": {**counts(0, 60_000), "1e9": 1e9}},
                               names={"n": r"\bn\b"}),
    "models.Head.reset": Api(lambda o: o.head.reset, dict(seed=0, fixate="fixation", settle_ms=0), bad={
        "seed": {"negative": -1, "frac": 1.5}, "settle_ms": counts(0, 60_000),
        "fixate": {"nan": [NAN, 0, 1], "short": [1.0, 2.0], "unknown": "unicorn"}},
        names={"fixate": "fixate|target|unicorn"}, types=ALL_ERRORS + (KeyError,)),
    "models.Head.set_gaze": Api(lambda o: o.head.set_gaze, dict(target="fixation", settle_ms=0), bad={
        "settle_ms": counts(0, 60_000), "target": {"inf": [INF, 0, 1], "2d": [1.0, 2.0], "complex": [1j, 0, 1],
                                                  "str_list": ["a", "b", "c"]}}),
    "models.Head.set_neck": Api(lambda o: o.head.set_neck, dict(pan=0.0, tilt=0.0), bad={"pan": {"far": 10.0},
                                                                                     "tilt": {"far": -10.0}},
                                names={"pan": "pan|neck", "tilt": "tilt|neck"}),
    "models.Head.plan_saccade": Api(lambda o: o.head.plan_saccade, dict(horizontal=0.05, vertical=0.0, latency_ms=0),
                                    bad={"latency_ms": counts(0, 60_000), "horizontal": {"huge": 1e300}}),
    "models.Head.plan_saccade_to": Api(lambda o: o.head.plan_saccade_to, dict(target="target"), bad={
        "target": {"nan": [NAN, 0, 1.2], "matrix": np.eye(3), "unknown": "unicorn"}, "latency_ms": counts(0, 60_000)},
        names={"target": "target|unicorn"}, types=ALL_ERRORS + (KeyError,)),
    "models.SaccadePlan.with_eye_position": Api(lambda o: o.saccade.with_eye_position,
                                                dict(eye_position=models.EyePositionSignal(30.0, 20.0))),
    "models.Head.start_saccade": Api(lambda o: o.head.start_saccade, dict(plan=Lazy(lambda o: o.saccade)), bad={
        "plan": {"dict": {"onset_ms": 0}}}, run_valid=False),
    "models.Head.run_saccade": Api(lambda o: o.head.run_saccade, dict(plan=Lazy(lambda o: o.saccade)), bad={
        "before_ms": counts(0, 60_000), "after_ms": counts(0, 60_000)}, run_valid=False),
    "models.Head.saccade_to": Api(lambda o: o.head.saccade_to, dict(target="target"), bad={
        "after_ms": counts(0, 60_000), "latency_ms": counts(0, 60_000), "target": {"unknown": "unicorn"}},
        names={"target": "target|unicorn"}, types=ALL_ERRORS + (KeyError,), run_valid=False),
    "models.SceneObjects.flash": Api(lambda o: o.head.flash, dict(names="flash_00"), bad={
        "duration_ms": counts(1, 60_000), "names": {"empty": [], "member": [1]}}, names={"names": "name"}),
    "models.SceneObjects.object_position": Api(lambda o: o.head.object_position, dict(name="target"), bad={"name": {"list": ["a"]}}),
    "models.SceneObjects.object_positions": Api(lambda o: o.head.object_positions, dict(group="flashes")),
    "models.SceneObjects.set_object_position": Api(lambda o: o.head.set_object_position, dict(
        name="target", pos=Lazy(lambda o: o.head.object_position("target"))), bad={"pos": {"short": [1, 2]}},
        names={"pos": "target|pos"}),
    "models.SceneObjects.set_visible": Api(lambda o: o.head.set_visible, dict(name="flash_00", visible=False),
                                   bad={"name": {"unknown": "unicorn"}}, names={"name": "name|unicorn"},
                                   types=ALL_ERRORS + (KeyError,)),
    "models.Head.set_state": Api(lambda o: o.head.set_state, dict(state=Lazy(lambda o: o.head.get_state()))),
    "models.Head.set_scene_state": Api(lambda o: o.head.set_scene_state,
                                       dict(state=Lazy(lambda o: o.head.scene_state()))),
    "models.SceneObjects.set_sphere_radius": Api(lambda o: o.head.set_sphere_radius,
                                                 dict(name="flash_00", radius=Lazy(lambda o: _radius(o.head, "flash_00"))),
                                                 bad={"name": {"unknown": "unicorn", "box": "ruler"},
                                                      "radius": bounds(0.0, 100.0, lo_open=True)},
                                                 names={"name": "name|unicorn"}, types=ALL_ERRORS + (KeyError,)),
    "models.SceneObjects.set_opacity": Api(lambda o: o.head.set_opacity, dict(name="ruler", opacity=0.5),
                                   bad={"name": {"unknown": "unicorn"}}, names={"name": "name|unicorn"},
                                   types=ALL_ERRORS + (KeyError,)),
    "models.Head.to_head": Api(lambda o: o.head.to_head, dict(point=[1.0, 0.0, 1.2]), bad={"point": {"short": [1.0]}},
                               names={"point": "target|point"}),
    "models.Head.to_world": Api(lambda o: o.head.to_world, dict(point_head=[1.0, 0.0, 0.0]),
                                bad={"point_head": {"short": [1.0]}}),
    "models.Head.fixation_angles": Api(lambda o: o.head.fixation_angles, dict(point=[1.0, 0.0, 1.2]),
                                       names={"point": "target|point"}),
    "models.Head.project": Api(lambda o: o.head.project, dict(points=np.array([[1.0, 0.0, 1.2]])), bad={
        "points": {"four_columns": np.zeros((2, 4)), "ragged": [[1.0, 2.0], [3.0]]}}),
    "models.Head.project_to_pixels": Api(lambda o: o.head.project_to_pixels, dict(points=np.array([[1.0, 0.0, 1.2]]))),
    "models.HeadRendering.render": Api(lambda o: o.head.render, dict(depth=False, exposure_ms=2.0, samples=2), bad={
        "exposure_ms": bounds(0.0, 1000.0), "samples": counts(1, 1000)}),
    "models.Head.eye_position_signal": Api(lambda o: o.head.eye_position_signal, dict(t_ms=Lazy(lambda o: o.head.time_ms)),
                                           bad={"t_ms": {"below": -1.0}}),
    "models.HeadRendering.export_xml": Api(lambda o: o.head.export_xml, dict(path=Lazy(lambda o: _tmp("head.xml"))),
                                  bad={"path": {"empty": "", "folder": "/tmp"}}),
    "models.EyeState.project": Api(lambda o: o.head.eye_states()[0].project, dict(points=np.array([[1.0, 0.0, 1.2]]))),
    "models.EyeRenderer": Api(lambda o: models.EyeRenderer, dict(model=Lazy(lambda o: o.head.model), height=16, width=16),
                              bad={"height": counts(1, 4096), "width": counts(1, 4096)}, run_valid=False),
    "models.EyeRenderer.render": Api(lambda o: o.renderer.render, dict(data=Lazy(lambda o: o.head.data), time_ms=0),
                                     bad={"time_ms": {"frac": 2.5}}),
    "models.HeadRendering.remember_frames": Api(lambda o: o.head.remember_frames, dict(megabytes=1.0),
                                                bad={"megabytes": {"below": -1.0, "above": 5000.0}}),
    "models.EyeRenderer.remember_frames": Api(lambda o: o.renderer.remember_frames, dict(megabytes=1.0),
                                              bad={"megabytes": {"below": -1.0, "above": 5000.0}}),
    "models.EyeImage.pixel_to_plane": Api(lambda o: o.frame.left.pixel_to_plane, dict(rows=[1.0, 2.0], cols=[1.0, 2.0]),
                                          bad={"rows": {"mismatch": [1.0, 2.0, 3.0]}}),
    "models.EyeImage.plane_to_pixel": Api(lambda o: o.frame.left.plane_to_pixel, dict(z=Z_OK), names={"z": r"\bz\b"}),
    "models.StereoFrame.__getitem__": Api(lambda o: o.frame.__getitem__, dict(name="left"),
                                          bad={"name": {"unknown": "middle"}}, names={"name": "eye"},
                                          types=(KeyError,)),
    # ---------------------------------------------------------------- models: oculomotor plant
    "models.MainSequence": Api(lambda o: models.MainSequence, {}, bad={
        "m0_deg": bounds(0.0, 100.0, lo_open=True), "vpk_deg_per_ms": bounds(0.0, 1.0, lo_open=True),
        "end_velocity_deg_s": bounds(0.0, 525.0, lo_open=True, hi_open=True), "settle_deg": bounds(0.0, 1.0, lo_open=True)}),
    **{f"models.MainSequence.{m}": Api(lambda o, m=m: getattr(models.MainSequence(), m), dict(t_ms=[1.0], amp_deg=10.0),
                                       bad={"amp_deg": bounds(0.0, 180.0)})
       for m in ("position_deg", "velocity_deg_per_ms")},
    **{f"models.MainSequence.{m}": Api(lambda o, m=m: getattr(models.MainSequence(), m), dict(amp_deg=10.0),
                                       bad={"amp_deg": bounds(0.0, 180.0)})
       for m in ("peak_velocity_deg_s", "duration_ms", "settle_ms")},
    "models.BurstGenerator": Api(lambda o: models.BurstGenerator, {}, bad={
        p: {"huge": 1e9, "negative": -1e9} for p in ("burst_max_deg_s", "burst_scale_deg", "burst_lag_ms", "adaptation_gain",
                                                     "adaptation_ms", "plant_t2_ms", "abducting_t2_ms", "adducting_t2_ms",
                                                     "settle_deg")}),
    **{f"models.BurstGenerator.{m}": Api(lambda o, m=m: getattr(models.BurstGenerator(), m), dict(amp_deg=10.0),
                                         bad={"amp_deg": bounds(0.0, 90.0)})
       for m in ("profile", "peak_velocity_deg_s", "duration_ms")},
    "models.BurstGenerator.simulate": Api(lambda o: models.BurstGenerator().simulate,
                                          dict(amplitudes_deg=[5.0, 10.0], span_ms=20.0, dt_ms=0.05), bad={
        "amplitudes_deg": {"negative": [-1.0], "above": [181.0], "too_many": np.ones(10**6)},
        "span_ms": bounds(0.0, 60_000.0, lo_open=True), "dt_ms": {"zero": 0.0, "negative": -0.05, "above_span": 21.0},
        "every": counts(1, 400)}),
    "models.BurstGenerator.to_file": Api(lambda o: models.BurstGenerator().to_file,
                                         dict(path=Lazy(lambda o: _tmp("generator.json"))),
                                         bad={"path": {"empty": "", "folder": "/tmp"}}),
    "models.BurstGenerator.from_file": Api(lambda o: models.BurstGenerator.from_file,
                                           dict(path=Lazy(lambda o: _generator_file())),
                                           bad={"path": {"empty": "", "folder": "/tmp", "missing": "/nonexistent/g.json"}}),
    "models.OrbitalPlant": Api(lambda o: models.OrbitalPlant, dict(t2_ms=7.0), bad={
        p: {"huge": 1e9, "negative": -1e9} for p in ("t1_ms", "t2_ms", "pulse_gain")}),
    "models.SaccadeProfile": Api(lambda o: models.SaccadeProfile, dict(
        amplitude_deg=10.0, dt_ms=0.25, positions=Lazy(lambda o: o.profile.positions), burst=Lazy(lambda o: o.profile.burst),
        settle_deg=0.01)),
    "models.SaccadeProfile.position": Api(lambda o: o.profile.position, dict(t_rel=np.array([1.0, 2.0]), plant=0),
                                          bad={"plant": {"above": 3}}),
    "models.SaccadeProfile.rate": Api(lambda o: o.profile.rate, dict(t_rel=np.array([1.0, 2.0]), plant=0),
                                      bad={"plant": {"above": 3}}),
    "models.VergenceDynamics": Api(lambda o: models.VergenceDynamics, {}, bad={
        p: {"huge": 1e9, "negative": -1e9} for p in ("tau_ms", "saccade_speedup", "latency_ms", "divergence_tau_ms")}),
    "models.VergenceDynamics.peak_velocity_deg_s": Api(lambda o: models.VergenceDynamics().peak_velocity_deg_s,
                                                       dict(change_deg=np.array([1.0, -2.0]))),
    "models.MotorNoise": Api(lambda o: models.MotorNoise, {}, bad={
        "along": bounds(0.0, 1.0), "across": bounds(0.0, 1.0), "gain": bounds(0.5, 1.5), "isotropic": {"str": "yes"}}),
    "models.MotorNoise.of": Api(lambda o: models.MotorNoise.of, dict(sd=0.1), bad={"sd": bounds(0.0, 1.0)}),
    "models.VergenceDynamics.fraction": Api(lambda o: models.VergenceDynamics().fraction, dict(
        t_rel_ms=np.array([1.0, 20.0]), saccade_offset_ms=30.0)),
    "models.VergenceDynamics.rate": Api(lambda o: models.VergenceDynamics().rate, dict(
        t_rel_ms=np.array([1.0, 20.0]), saccade_offset_ms=30.0)),
    "models.VergenceDynamics.settle_ms": Api(lambda o: models.VergenceDynamics().settle_ms, dict(
        change_deg=1.0, saccade_offset_ms=30.0, settle_deg=0.01)),
    "models.EyePositionSignal": Api(lambda o: models.EyePositionSignal, {}, bad={
        p: {"huge": 1e9, "negative": -1e9} for p in ("sigma_ms", "delay_ms")}),
    "models.SaccadePlan": Api(lambda o: models.SaccadePlan, dict(
        **SP, generator=models.BurstGenerator(), target=[1.0, 0.0, 1.2], intended_target=[1.0, 0.0, 1.2],
        intended_end_angles=np.full((2, 3), 0.1), intended_amplitude=0.1, vergence=models.VergenceDynamics(),
        eye_position=models.EyePositionSignal(), signal_start_angles=np.zeros((2, 3))), bad={
        "onset_ms": counts(0), "start_angles": {"flat6": np.zeros(6)}, "end_angles": shapes(np.zeros((2, 3))),
        "amplitude": bounds(0.0, np.pi), "generator": {"dict": {}, "str": "burst"}, "vergence": {"dict": {}, "float": 150.0},
        "eye_position": {"dict": {}, "str": "signal"}, "intended_end_angles": {"flat6": np.zeros(6)},
        "signal_start_angles": {"flat6": np.zeros(6)}, "intended_amplitude": bounds(0.0, np.pi),
        "target": {"short": [1.0]}},
        names={a: f"{a}|angles" for a in ("start_angles", "end_angles", "intended_end_angles", "signal_start_angles")}),
    **{f"models.SaccadePlan.{m}": Api(lambda o, m=m: getattr(models.SaccadePlan(**SP), m), dict(t_ms=[1.0]))
       for m in ("angles", "velocities", "profile", "intended_angles", "eye_position_signal")},
    "models.SaccadePlan.sample": Api(lambda o: models.SaccadePlan(**SP).sample, dict(step_ms=1.0), bad={
        "step_ms": {**bounds(0.001, 1000.0), "zero": 0.0, "tiny": 1e-12}}),
    "models.SceneInfo": Api(lambda o: models.SceneInfo, dict(
        name="custom", description="a scene", groups={"g": ("a",)}, movable=("a",), default_fixation=[1.0, 0.0, 1.2],
        layout=lambda rng: {}, flashes=("a",)), bad={
        "groups": {"list": [("a",)], "str_values": {"g": "abc"}, "int_key": {1: ("a",)}},
        "movable": {"str": "target", "ints": (1, 2)}, "default_fixation": {"short": [1.0]}, "layout": {"str": "grid"}},
        free={"default_fixation": "str: a fixation may be named (the name of a scene object)"}),
    "models.fixation_angles": Api(lambda o: models.fixation_angles, dict(target_head=[1.0, 0.0, 0.0],
                                                                         eye_centres_head=np.zeros((2, 3))), bad={
        "target_head": {"short": [1.0]}, "eye_centres_head": {"shape": np.zeros((2, 2)), "empty": np.zeros((0, 3))}},
        names={"target_head": "target"}),
    "models.fick_matrix": Api(lambda o: models.fick_matrix, dict(h=np.zeros(2), v=np.zeros(2), t=np.zeros(2)), bad={"h": {"mismatch": np.zeros(3)}},
                              names={"h": r"\bh\b", "v": r"\bv\b", "t": r"\bt\b"}),
    "models.gaze_direction": Api(lambda o: models.gaze_direction, dict(h=np.zeros(2), v=np.zeros(2)), bad={"h": {"mismatch": np.zeros(3)}},
                                 names={"h": r"\bh\b", "v": r"\bv\b"}),
    "models.listing_torsion": Api(lambda o: models.listing_torsion, dict(h=np.zeros(2), v=np.zeros(2)), bad={"h": {"mismatch": np.zeros(3)}},
                                  names={"h": r"\bh\b", "v": r"\bv\b"}),
    "models.fick_angles": Api(lambda o: models.fick_angles, dict(R=R_OK), bad={"R": {"reflection": -np.eye(3), "2x2": np.eye(2)}},
                              names={"R": r"\bR\b"}),
    "models.rotation_vector": Api(lambda o: models.rotation_vector, dict(R=R_OK), bad={
        "R": {"scaled": 2 * np.eye(3), "stack": np.stack([R_OK, R_OK])}}, names={"R": r"\bR\b"}),
    # ---------------------------------------------------------------- envs
    "envs.BinocularSaccadeEnv": Api(lambda o: envs.BinocularSaccadeEnv, dict(
        scene="dots", image_size=32, fixation_ms=10, n_sectors=16, remap_models=("homography",), render_mode="rgb_array",
        task_kwargs={"max_saccades": 3}, generator=models.BurstGenerator(), motor_noise=models.MotorNoise()), bad={
        "scene": {"unknown": "moon", "list": ["dots"], "no_target": "bar"}, "task": {"unknown": "dance", "class": envs.FixateTask},
        "generator": {"dict": {}, "main_sequence": models.MainSequence()}, "eye_drive": unknown("plant"),
        "action_mode": unknown("vector"), "image_size": {**counts(16, 1024), "7.5": 7.5},
        "render_mode": unknown("rgb_array"), "fixation_ms": {**counts(0, 10_000), "1e9": 1e9},
        "max_amplitude_deg": bounds(0.0, 60.0, lo_open=True), "remap_model": unknown("homography"),
        "remap_models": {"str": "homography", "member": ("homography", "affine"), "none_member": (None,)},
        "shift_rings": bounds(-5.0, 5.0), "cortex": unknown("eyes"), "fovea_deg": bounds(0.0, 30.0, lo_open=True, hi_open=True),
        "n_sectors": {**counts(4, 4096), "100000": 100_000}, "sampling": unknown("pool"), "fovy_deg": bounds(5.0, 170.0),
        "endpoint_noise": bounds(0.0, 1.0), "quality": unknown("fast"), "saccade_model": unknown("burst"),
        "motor_noise": {"float": 0.1},
        "task_kwargs": {"list": [1], "str": "max_saccades=3", "unknown_key": {"colour": "red"},
                        "max_saccades_frac": {"max_saccades": 2.7}, "max_saccades_zero": {"max_saccades": 0},
                        "max_saccades_huge": {"max_saccades": 10**9}, "tolerance_nan": {"tolerance_deg": NAN},
                        "cost_nan": {"saccade_cost": NAN}, "ecc_reversed": {"min_ecc_deg": 20.0, "max_ecc_deg": 5.0},
                        "ecc_far": {"max_ecc_deg": 89.0}}},
        names={"scene": "scene|task 'fixate' needs",
               "task_kwargs": "task_kwargs|max_saccades|tolerance_deg|saccade_cost|ecc_deg|colour",
               "remap_models": "remap_models|model"}),
    "envs.BinocularSaccadeEnv.reset": Api(lambda o: o.env.reset, dict(seed=0, options={}), bad={
        "seed": {"negative": -1, "frac": 1.5, "list": [0]}, "options": {"list": [1], "unknown": {"difficulty": 3}}}),
    "envs.BinocularSaccadeEnv.step": Api(lambda o: o.env.step, dict(action=np.zeros(2, np.float32)), bad={"action": {
        "-inf": [0.0, -INF], "complex_real": np.array([0.5 + 0j, 0]), "bool": [True, False], "str_list": ["0.1", "0.2"],
        "ragged": [[0.1], [0.1, 0.2]], "shape3": [0.1, 0.1, 0.1], "shape1": [0.1], "scalar": 0.1, "2d": [[0.1, 0.1]],
        "above": [1.5, 0.0], "below": [0.0, -2.0], "huge": [1e300, 0.0], "dict": {"h": 0.1}}}),
    "envs.Vision": Api(lambda o: envs.Vision, dict(image_shape=(32, 32), pixels_per_unit=22.85, n_sectors=16), bad={
        "image_shape": {"frac": (32.5, 32), "zero": (0, 32), "huge": (10**6, 10**6), "one": (32,)},
        "pixels_per_unit": bounds(0.0, 1e6, lo_open=True), "fovea_deg": bounds(0.0, 30.0, lo_open=True, hi_open=True),
        "n_sectors": {"frac": 36.5, "huge": 100_000, "zero": 0}, "sampling": unknown("pool"),
        "shift_rings": bounds(-5, 5)}),
    "envs.Vision.see": Api(lambda o: o.vision.see, dict(image=UINT_IMG), bad={"image": {
        "float_255": np.full((32, 32, 3), 255.0), "negative": np.full((32, 32, 3), -1.0), "complex": UINT_IMG.astype(complex),
        "uint16": UINT_IMG.astype(np.uint16), "bool": UINT_IMG.astype(bool), "shape": np.zeros((32, 32), np.uint8),
        "longdouble": UINT_IMG.astype(np.longdouble)}}, names={"image": "images?"}),
    "envs.Vision.see_eyes": Api(lambda o: o.vision.see_eyes, dict(images=(UINT_IMG, UINT_IMG)), bad={"images": {
        "one_image": UINT_IMG, "empty": [], "mixed": [UINT_IMG, UINT_IMG.astype(float)]}}, names={"images": "image"}),
    "envs.Vision.point_map": Api(lambda o: o.vision.point_map, dict(model="homography", rotation_eye=R_OK), bad={
        "model": unknown("homography"), "rotation_eye": {"reflection": -np.eye(3)}}),
    "envs.Vision.predict": Api(lambda o: o.vision.predict, dict(view=Lazy(lambda o: o.views[0]), model="homography",
                                                                rotation_eye=R_OK, pooled=True),
                               bad={"view": {"array": np.zeros((5, 12, 3)), "tuple": ("a",)}, "model": unknown("homography")},
                               names={"view": "views?|EyeView", "rotation_eye": "rotations?_eye"}),
    "envs.Vision.predict_models": Api(lambda o: o.vision.predict_models, dict(
        view=Lazy(lambda o: o.views[0]), models=("homography",), rotation_eye=R_OK, pooled=True), bad={
        "models": {"str": "homography", "empty": (), "unknown": ("affine",)}}, names={"view": "views?|EyeView",
                                                                                       "models": "model",
                                                                                       "rotation_eye": "rotations?_eye"}),
    "envs.Vision.predict_eyes": Api(lambda o: o.vision.predict_eyes, dict(
        views=Lazy(lambda o: o.views), models=("homography",), rotations_eye=[R_OK, R_OK], pooled=True), bad={
        "rotations_eye": {"one": [np.eye(3)], "shape": np.zeros((2, 2, 2))}, "views": {"empty": ()}},
        names={"models": "model", "views": "views?|EyeView"}),
    "envs.Vision.predict_arrays": Api(lambda o: o.vision.predict_arrays, dict(
        views=Lazy(lambda o: o.views), models=("homography",), rotations_eye=[R_OK, R_OK], pooled=True),
        bad={"views": {"empty": ()}}, names={"models": "model", "views": "views?|EyeView"}),
    "envs.Vision.errors": Api(lambda o: o.vision.errors, dict(
        values=Lazy(lambda o: np.zeros((2, 1, o.n_points, 3))), valid=Lazy(lambda o: np.ones((2, 1, o.n_points), bool)),
        views=Lazy(lambda o: o.views)), bad={"values": {"shape": np.zeros((2, 1, 5, 3))},
                                             "valid": {"float": Lazy(lambda o: np.ones((2, 1, o.n_points))),
                                                       "shape": np.ones((2, 1, 5), bool)}},
        names={"views": "views?|EyeView"}),
    "envs.normalized_error": Api(lambda o: envs.normalized_error, dict(
        pred=Lazy(lambda o: o.predictions[0]["homography"]), actual=Lazy(lambda o: o.views[0])), bad={"pred": {
            "other_grid": C.RetinaSamples(np.zeros(13), np.zeros((8, 16)), np.ones((8, 16), bool), np.ones(13, bool))}}),
    "envs.model_errors": Api(lambda o: envs.model_errors, dict(predictions=Lazy(lambda o: o.predictions),
                                                               actual=Lazy(lambda o: o.views)), bad={
        "predictions": {"empty": [], "dict": {"homography": 1}, "empty_dict": [{}, {}]}, "actual": {"short": ("x",)}}),
    **{f"envs.{cls.__name__}": Api(lambda o, cls=cls: cls, {}, bad={
        "max_saccades": {**counts(1, 10_000), "2.7": 2.7}, "tolerance_deg": bounds(0.0, 45.0, lo_open=True),
        "saccade_cost": bounds(0.0, 10.0), "scene": {"unknown": "moon"},
        **({"min_ecc_deg": bounds(0.0, 30.0), "max_ecc_deg": {**bounds(5.0, 30.0), "89": 89.0}}
           if cls is envs.FixateTask else {})}) for cls in (envs.Task, envs.FixateTask, envs.SearchTask, envs.FreeViewingTask)},
    "envs.Task.check_scene": Api(lambda o: envs.Task().check_scene, dict(head=Lazy(lambda o: o.head))),
    "envs.Task.target_position": Api(lambda o: envs.Task().target_position, dict(head=Lazy(lambda o: o.head))),
    "envs.Task.initialize_episode": Api(lambda o: envs.SearchTask(scene="dots").initialize_episode, dict(
        head=Lazy(lambda o: o.head), rng=np.random.default_rng(0)), bad={"rng": {"seed": 3, "legacy": np.random.RandomState(0)}}),
    "envs.FixateTask.check_scene": Api(lambda o: envs.FixateTask().check_scene, dict(head=Lazy(lambda o: o.head))),
    "envs.Task.score": Api(lambda o: envs.FixateTask().score, dict(head=Lazy(lambda o: o.head))),
    "models.limit_plan_threads": Api(lambda o: (lambda on: models.limit_plan_threads(models.limit_plan_threads(on))),
                                     dict(on=True), bad={"on": {"int": 1, "none": None, "str": "yes"}}),
    "envs.Task.placements": Api(lambda o: envs.SearchTask(scene="dots").placements, dict(rng=np.random.default_rng(0)),
                                bad={"rng": {"seed": 3, "legacy": np.random.RandomState(0)}}),
    "envs.FixateTask.placements": Api(lambda o: envs.FixateTask().placements, dict(rng=np.random.default_rng(0)),
                                      bad={"rng": {"seed": 3, "legacy": np.random.RandomState(0)}}),
    "envs.FreeViewingTask.check_scene": Api(lambda o: envs.FreeViewingTask(scene="dots").check_scene,
                                            dict(head=Lazy(lambda o: o.head))),
    "envs.FreeViewingTask.score": Api(lambda o: envs.FreeViewingTask(scene="dots").score, dict(head=Lazy(lambda o: o.head))),
    "envs.PotentialShaping": Api(lambda o: envs.PotentialShaping, dict(env=Lazy(lambda o: o.env), gamma=0.9, scale_deg=10.0),
                                 bad={"gamma": bounds(0.0, 1.0, lo_open=True), "scale_deg": bounds(0.0, 180.0, lo_open=True)}),
    "envs.make_task": Api(lambda o: envs.make_task, dict(task="fixate"), bad={"task": {"unknown": "dance",
                                                                                       "class": envs.FixateTask}}),
    "envs.gaze_errors_deg": Api(lambda o: envs.gaze_errors_deg, dict(head=Lazy(lambda o: o.head), point=[1.0, 0.0, 1.2]),
                                bad={"point": {"short": [1.0],
                                               "nodal": Lazy(lambda o: o.head.eye_states()[0].camera_position)}}),
    "envs.grid_overlay": Api(lambda o: envs.grid_overlay, dict(grid=Lazy(lambda o: o.grid), shape=(8, 8),
                                                               pixels_per_unit=10.0),
                             bad={"shape": {"frac": (7.5, 8), "zero": (0, 8), "huge": (10**6, 10**6), "one": (8,)},
                                  "pixels_per_unit": bounds(0.0, 1e9, lo_open=True)}),
    "envs.compose_frame": Api(lambda o: envs.compose_frame, dict(frame=Lazy(lambda o: o.frame), views=Lazy(lambda o: o.views),
                                                                 vision=Lazy(lambda o: o.vision)),
                              bad={"frame": {"array": np.zeros((2, 32, 32, 3))}}),
}

#: public callables the walk does not call, with the reason (a class: its methods too)
EXEMPT = {
    "conformal.checks": "the checks themselves: tests/test_checks.py tries every hostile value on each",
    "conformal.kernels": "numba kernels the checked public functions call with validated arrays",
    "envs.BatchedBinocularSaccade": "needs the gpu extra (Warp); tests/test_batched_env.py checks its arguments and actions",
    "envs.BatchedPotentialShaping": "wraps a BatchedBinocularSaccade (the gpu extra); tests/test_batched_ppo.py checks its env, gamma and task",
    "envs.BatchedPotentialShaping.step": "passes the actions to the wrapped batched env's step (its checks: tests/test_batched_env.py)",
    "models.SaccadePlans": "arrays of plans that BatchedPlanner.plan and SaccadePlan (validated) build",
    "models.Profiles": "the profiles SaccadePlans builds from validated amplitudes",
    "models.profiles": "as models.Profiles",
    "models.time_kernel_paths": "benchmarks/planner.py's timing of a SaccadePlans batch (built by BatchedPlanner.plan, validated)",
    "models.SaccadePlan.from_batch": "a plan of a SaccadePlans batch (its fields already checked), rebuilt through SaccadePlan's checks",
    "models.fixation_batch": "array geometry of the planners (validated points); models.fixation_angles is its checked entry",
    "models.displaced": "array geometry of the planners (as fixation_batch)",
    "models.cyclopean_amplitude": "array geometry of the planners (as fixation_batch)",
    "models.plan_clipped": "Head.plan_saccade / plan_saccade_to (walked) in a bisection; the env decodes its arguments",
    "models.servo_setpoints": "the servo law, fed the command tables the planners compute (Head's and the batched env's)",
    "models.LinearTail": "the head's closed-form physics, built by Head from its compiled model (Head(linear_tail=...) is its switch, walked)",
    "models.OrbitalPlant.install": "installs the plant into the compiled model Head builds (addresses Head computes)",
    "models.OculomotorState": "a record Head.get_state returns (Head.set_state checks its type)",
    "envs.FixateTask.score_errors": "as envs.Task.score_errors",
    "envs.SearchTask.score_errors": "as envs.Task.score_errors",
    "envs.FreeViewingTask.score_errors": "as envs.Task.score_errors",
    "envs.Task.score_errors": "the tasks' scoring of gaze errors the envs compute (arrays from the head or the device)",
    "envs.gaze_errors": "array geometry of the envs' scoring (eye poses from the simulation); gaze_errors_deg is its checked entry",
    "envs.Vision.map_params": "the env's hot path, fed the plan's efference copy (rotations the head computed)",
    "conformal.RemapPlan.evaluate_prechecked": "the unchecked hot path of RemapPlan.predict (walked), named so",
    "conformal.Retina.sample_prechecked": "the unchecked hot path of Retina.sample_many (walked), named so",
    "models.EyeTrace": "a record Head.step_ms(record=True) returns (a dataclass of arrays the head computed)",
    "models.EyeState": "a record Head.eye_states() returns",
    "models.EyeImage": "a record EyeRenderer.render returns",
    "models.StereoFrame": "a record EyeRenderer.render returns",
    "envs.EyeView": "a record Vision.see returns (unlike conformal.RetinaSamples it checks nothing)",
    "models.BatchedPlanner": "the batched env's host side, fed the env's validated arrays (it checks nothing itself)",
    "models.SettledReset": "the batched env's host side (as BatchedPlanner)",
    "envs.PotentialShaping.step": "passes the action to the wrapped env's step (walked: envs.BinocularSaccadeEnv.step)",
    "envs.PotentialShaping.get_wrapper_attr": "gymnasium.Wrapper's, not this package's",
    "envs.PotentialShaping.has_wrapper_attr": "gymnasium.Wrapper's, not this package's",
    "envs.PotentialShaping.set_wrapper_attr": "gymnasium.Wrapper's, not this package's",
    "envs.BinocularSaccadeEnv.get_wrapper_attr": "gymnasium.Env's, not this package's",
    "envs.BinocularSaccadeEnv.has_wrapper_attr": "gymnasium.Env's, not this package's",
    "envs.BinocularSaccadeEnv.set_wrapper_attr": "gymnasium.Env's, not this package's",
}

#: public callables that check none of their arguments yet (reported in issue 21): their walk is a
#: strict xfail, so it fails as soon as one validates its arguments and the entry must move here
UNVALIDATED = {
    "models.SaccadeProfile": "a dataclass of tables (BurstGenerator.profile builds it) with no checks",
    "models.VergenceDynamics.fraction": "NaN and None times are accepted; strings reach numpy",
    "models.VergenceDynamics.rate": "as VergenceDynamics.fraction; a string offset reaches np.clip (UFuncTypeError)",
    "models.VergenceDynamics.settle_ms": "NaN, inf and bools accepted; strings and None reach arithmetic",
}


def _generator_file() -> str:
    path = _tmp("generator_in.json")
    models.BurstGenerator(burst_max_deg_s=650.0).to_file(path)
    return path


def _radius(head, name: str) -> float:
    """The drawn radius of sphere ``name`` (the valid call sets it to itself: later entries see the scene unchanged)."""
    return float(head.model.geom_size[head.model.geom(name).id, 0])


def _tmp(name: str) -> str:
    import tempfile

    d = os.path.join(tempfile.gettempdir(), f"adversarial-api-{os.getpid()}")
    os.makedirs(d, exist_ok=True)
    return os.path.join(d, name)


#: arguments the walk found unvalidated: a ``(entry, parameter, probe)`` triple each, listed so that the
#: walk stays green while they are reported (issue 21), and fails once one is fixed (the list shrinks)
KNOWN_GAPS: set[tuple[str, str, str]] = set()


# ---------------------------------------------------------------------- the walk
PACKAGES = (C, models, envs)


def _own(obj) -> bool:
    return getattr(obj, "__module__", "").split(".")[0] in {p.__name__ for p in PACKAGES}


def public_callables() -> dict[str, Callable]:
    """Every public callable of the three packages by qualified name: functions, classes (their
    constructors), and the public methods (``__call__``, ``__getitem__`` too) that a class
    defines or inherits, keyed by the class that defines them; modules named in ``__all__`` too."""
    out: dict[str, Callable] = {}
    for pkg in PACKAGES:
        for name in pkg.__all__:
            obj = getattr(pkg, name)
            key = f"{pkg.__name__}.{name}"
            if inspect.ismodule(obj):
                out[key] = obj
            elif inspect.isclass(obj):
                if issubclass(obj, BaseException):
                    continue  # an exception class: raised, not called with user input
                out[key] = obj
                for attr in dir(obj):
                    if attr.startswith("_") and attr not in ("__call__", "__getitem__"):
                        continue
                    owner = next((b for b in obj.__mro__ if attr in b.__dict__), None)
                    raw = owner.__dict__[attr] if owner is not None else None
                    if raw is None or isinstance(raw, property) or owner is object:
                        continue
                    fn = raw.__func__ if isinstance(raw, (classmethod, staticmethod)) else raw
                    if not inspect.isfunction(fn):
                        continue
                    params = [p for p in inspect.signature(fn).parameters.values()
                              if p.name not in ("self", "cls") and p.kind != p.VAR_KEYWORD]
                    if not params:
                        continue  # nothing to validate
                    qual = f"{pkg.__name__}.{owner.__name__}.{attr}" if _own(owner) else f"{key}.{attr}"
                    out.setdefault(qual, fn)
            elif callable(obj):
                out[key] = obj
    return out


def _probes(value, default) -> dict[str, Any]:
    """Hostile values for a parameter whose valid value is ``value``, by the kind of that value."""
    if isinstance(value, (bool, np.bool_)):
        out: dict[str, Any] = {"str": "no", "int": 1}
    elif isinstance(value, numbers.Real) or (isinstance(value, np.ndarray) and value.ndim == 0):
        out = {"nan": NAN, "inf": INF, "str": "1", "bool": True}
    elif isinstance(value, numbers.Complex):
        out = {"nan": complex(NAN, 0.0), "str": "1"}
    elif isinstance(value, (str, os.PathLike)):
        out = {"int": 3}
    else:
        try:
            a = np.asarray(value)
        except (ValueError, TypeError):
            a = np.array(None)
        if a.dtype.kind in "biufc" and a.size:
            nan = np.full(a.shape, complex(NAN, 0.0) if a.dtype.kind == "c" else NAN)
            out = {"nan": nan, "str": "abc", "object": np.array([object()] * a.size).reshape(a.shape)}
        else:  # any other object: a grid, a head, a callable, a dict, a sequence of objects
            out = {"object": object(), "int": 3}
    if default is not None:
        out["none"] = None
    return out


def _internal(exc: BaseException) -> bool:
    """An exception from numpy, scipy, numba or MuJoCo's internals (LinAlgError is a ValueError too)."""
    return type(exc).__module__.split(".")[0] in ("numpy", "scipy", "numba", "mujoco", "finufft")


def _call(fn, kwargs: dict, var_positional: str | None):
    if var_positional is None:
        return fn(**kwargs)
    rest = {k: v for k, v in kwargs.items() if k != var_positional}
    return fn(*kwargs.get(var_positional, ()), **rest)


def _walk(qual: str, o: World) -> tuple[int, list[str], set[tuple[str, str, str]]]:
    """Call ``qual`` with each hostile value of each parameter: (calls, failures, unvalidated)."""
    spec = API[qual]
    fn = spec.get(o)
    sig = inspect.signature(fn)
    params = {p.name: p for p in sig.parameters.values() if p.kind != p.VAR_KEYWORD}
    var_pos = next((p.name for p in params.values() if p.kind == p.VAR_POSITIONAL), None)
    valid = {k: _resolve(v, o) for k, v in spec.valid.items()}
    assert set(valid) <= set(params) and set(spec.bad) <= set(params), f"{qual}: stale table ({sorted(params)})"
    if spec.run_valid:
        _call(fn, valid, var_pos)  # the table's valid call works: each refusal below is the probe's
    calls, failures, gaps = 0, [], set()
    for name, p in params.items():
        free = spec.free.get(name, "")
        if free and ":" not in free.split()[0]:
            generic = {}
        elif name in valid or p.default not in (inspect.Parameter.empty, None):
            good = valid.get(name, p.default)
            generic = _probes(good[-1] if p.kind == p.VAR_POSITIONAL else good,
                              None if p.kind == p.VAR_POSITIONAL else p.default)
        else:
            failures.append(f"{qual}({name}=...): no valid value in API to probe from")
            continue
        domain = {k: _resolve(v, o) for k, v in spec.bad.get(name, {}).items()}
        if free and ":" in free.split()[0]:
            allowed = free.split(":")[0].split(",")
            generic = {k: v for k, v in generic.items() if k not in allowed}
        for label, bad in {**generic, **domain}.items():
            if p.kind == p.VAR_POSITIONAL:
                bad = (*valid[name][:-1], bad) if label in generic else bad
            calls += 1
            fail = _refusal(fn, {**valid, name: bad}, var_pos, spec, name)
            if fail is None:
                continue
            if (qual, name, label) in KNOWN_GAPS:
                gaps.add((qual, name, label))
            else:
                failures.append(f"{qual}({name}={label}): {fail}")
    return calls, failures, gaps


def _refusal(fn, kwargs, var_pos, spec: Api, name: str) -> str | None:
    """None if the call raises a clear error naming ``name``; else what went wrong."""
    try:
        _call(fn, kwargs, var_pos)
    except spec.types as exc:
        if _internal(exc):
            return f"an internal error: {type(exc).__module__}.{type(exc).__name__}: {exc}"
        if not re.search(spec.names.get(name, rf"\b{re.escape(name)}\b"), str(exc)):
            return f"message does not name it: {type(exc).__name__}: {exc}"
        return None
    except Exception as exc:  # noqa: BLE001  (any other exception is the finding)
        return f"{type(exc).__module__}.{type(exc).__name__}: {exc}"
    return "accepted"


def test_every_public_callable_has_an_entry():
    """The walk covers the whole public API: a new public name needs an entry (or a reason)."""
    found = set(public_callables())
    exempt = {q for q in found if any(q == e or q.startswith(e + ".") for e in EXEMPT)}  # a class: its methods too
    missing = sorted(found - set(API) - exempt)
    assert not missing, f"public callables without an API entry (add a valid call) or an EXEMPT reason: {missing}"
    stale = sorted((set(API) | set(EXEMPT)) - found)
    assert not stale, f"API/EXEMPT entries for names that are not public (any more): {stale}"


@pytest.mark.parametrize("qual", [pytest.param(q, marks=pytest.mark.xfail(strict=True, reason=UNVALIDATED[q]))
                                  if q in UNVALIDATED else q for q in API])
def test_public_api_validates_every_argument(qual: str, o: World, hostile_calls):
    calls, failures, gaps = _walk(qual, o)
    known = {g for g in KNOWN_GAPS if g[0] == qual}
    hostile_calls.add(calls, calls - len(failures) - len(gaps))
    assert not failures, f"{len(failures)} of {calls} hostile calls not refused clearly:\n" + "\n".join(failures)
    assert gaps == known, f"fixed, remove from KNOWN_GAPS: {sorted(known - gaps)}"


# ---------------------------------------------------------------------- refusals beyond one bad argument
@dataclass
class Case:
    id: str
    call: Callable[[World], Any]
    match: str  # a regex the message must contain
    types: tuple = ALL_ERRORS


CASES = [
    Case("act-overflow", lambda o: C.act(np.diag([0.5, 2.0]), 1e308), "floating-point range"),
    Case("apply_homography-pole", lambda o: C.apply_homography(np.array([[1, 0, 0], [0, 1, 0], [1, 0, 1.0]]), [-1.0]),
         "infinity"),
    Case("compose-overflow", lambda o: C.compose(*[np.diag([1e100, 1e-100])] * 4), "overflow"),
    Case("project-overflow", lambda o: C.project([1e308, 1e-10, 1e308]), "floating-point range"),
    Case("cortical_map-N-not-divisible-by-4", lambda o: C.cortical_map(np.zeros((o.grid_odd.M, 18)), o.grid_odd),
         "divisible by 4"),
    Case("binocular_cortex-channels-differ",
         lambda o: C.binocular_cortex(np.zeros((8, 16, 3)), np.zeros((8, 16, 1)), o.grid), "same shape"),
    Case("BinocularCortex-shapes-differ", lambda o: C.BinocularCortex(np.zeros((2, 8, 8)), np.zeros((2, 8, 4))), "shape"),
    Case("SPHERE_CENTRE-read-only", lambda o: C.SPHERE_CENTRE.__setitem__(0, 5.0), "read-only"),
    Case("CYCLOPEAN_EYE-read-only", lambda o: models.CYCLOPEAN_EYE.__setitem__(0, 5.0), "read-only"),
    Case("RetinaGrid-M*N-too-many", lambda o: C.RetinaGrid(**{**GRID_KW, "M": 4096, "N": 4096, "delta": 0.01}), "M \\* N"),
    Case("RetinaGrid-period-too-long", lambda o: C.RetinaGrid(**{**GRID_KW, "M": 4000, "delta": 50.0}), "period"),
    Case("from_field_of_view-tiny-r0-huge-rb", lambda o: C.RetinaGrid.from_field_of_view(1e300, 1e-300, 64),
         "M|period|n_fovea"),
    Case("dpft_direct-too-large", lambda o: C.dpft_direct(np.zeros((60, 64)), C.RetinaGrid(**{**GRID_KW, "M": 60,
                                                                                              "N": 64})), "direct sum"),
    Case("idpft_direct-too-large", lambda o: C.idpft_direct(np.zeros((60, 64)), C.RetinaGrid(**{**GRID_KW, "M": 60,
                                                                                                "N": 64})), "direct sum"),
    Case("log_radius_shift-wrapped-shift-out-of-range",
         lambda o: C.log_radius_shift(o.samples, o.grid, 1e300, wrap=True), "shift"),
    Case("Retina-too-many-subpixels", lambda o: C.Retina(o.grid, (8192, 8192), 20.0, supersample=16), "subpixels"),
    Case("Retina.render-nan-samples", lambda o: o.retina.render(C.RetinaSamples(
        np.full(13, NAN), np.zeros((8, 16)), np.ones((8, 16), bool), np.ones(13, bool))), "samples"),
    Case("Retina.render-other-grid", lambda o: o.retina.render(C.RetinaSamples(
        np.zeros(13), np.zeros((8, 12)), np.ones((8, 12), bool), np.ones(13, bool))), "grid"),
    Case("Retina.sample_many-nan-scale", lambda o: o.retina.sample_many([IMG], scale=NAN), "scale"),
    Case("target_shift_map-scale-overflow", lambda o: C.target_shift_map(0.1, 1e6, 1.0), "shift \\* delta"),
    Case("build_spec-head_xml-missing", lambda o: models.build_spec("bar", head_xml="/nonexistent/head.xml"),
         "cannot read", (models.ModelFileError,)),
    Case("build_model-bad-kwarg", lambda o: models.build_model("bar", ipd=NAN), "ipd"),
    Case("build_model-huge-offscreen", lambda o: models.build_model("bar", offscreen_size=(1e9, 1)), "offscreen_size"),
    Case("build_model-unknown-kwarg", lambda o: models.build_model("bar", colour="red"), "colour"),
    Case("export_xml-unwritable", lambda o: models.export_xml("bar", "/proc/nope/head.xml"), "cannot write",
         (models.ModelFileError,)),
    Case("load_model-missing", lambda o: models.load_model("/nonexistent.xml"), "cannot load", (models.ModelFileError,)),
    Case("Head.render-samples-without-exposure", lambda o: o.head.render(samples=3), "samples"),
    Case("Head.render-depth-with-exposure", lambda o: o.head.render(depth=True, exposure_ms=4), "depth"),
    Case("BinocularSaccadeEnv-hemispheres-odd-N",
         lambda o: envs.BinocularSaccadeEnv(image_size=32, fixation_ms=10, cortex="hemispheres", n_sectors=18),
         "divisible by 4"),
    Case("gymnasium.make-bad-kwarg", lambda o: __import__("gymnasium").make("BinocularSaccade-v0", image_size=7.5),
         "image_size"),
    Case("step-before-reset", lambda o: o.fresh_env.step(np.zeros(2, np.float32)), "reset", (RuntimeError,)),
    Case("render-before-reset", lambda o: o.fresh_env.render(), "reset", (RuntimeError,)),
    Case("step-vergence-action-nan", lambda o: o.vergence_env.step([0.0, 0.0, NAN]), "action"),
    Case("step-vergence-action-two", lambda o: o.vergence_env.step([0.1, 0.1]), "action"),
    Case("step-vergence-action-above", lambda o: o.vergence_env.step([0.0, 0.0, 3.0]), "action"),
    *[Case(f"step-cell-action-{k}", lambda o, v=v: o.cell_env.step(_resolve(v, o)), "action|cell index")
      for k, v in {"negative": -1, "n": Lazy(lambda o: o.cell_env.action_space.n), "huge": 10**12, "frac": 2.5,
                   "nan": NAN, "str": "3", "bool": True, "complex": 3 + 0j, "array1": np.array([3]),
                   "vector": [0.1, 0.2], "uint_overflow": np.uint64(2**63)}.items()],
    Case("Vision-fovea-covers-picture", lambda o: envs.Vision((32, 32), 100.0, fovea_deg=29.0), "fovea"),
    Case("Vision.point_map-shift-behind", lambda o: o.vision.point_map("shift", C.rotation_matrix([0, 0, 1.0], 2.0)),
         "optical axis"),
    Case("make_task-instance-with-kwargs", lambda o: envs.make_task(envs.FixateTask(), max_saccades=3), "keyword"),
    Case("make_task-unknown-kwarg", lambda o: envs.make_task("fixate", colour="red"), "colour"),
]


@pytest.mark.parametrize("case", CASES, ids=[c.id for c in CASES])
def test_bad_input_raises_a_clear_error(case: Case, o: World):
    with pytest.raises(Exception) as info:
        case.call(o)
    err = info.value
    assert isinstance(err, case.types) and not _internal(err), f"{type(err).__module__}.{type(err).__name__}: {err}"
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


@pytest.mark.slow
def test_fork_after_render_raises_naming_spawn():
    """An AsyncVectorEnv forked after its parent rendered used to deadlock forever and orphan its
    workers (issue 11, item 4); now every worker's first render raises ``ForkedGLContextError``,
    reported in the parent at ``reset``, and no worker outlives the parent."""
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    env = {**os.environ, "PYTHONPATH": root + os.pathsep + os.environ.get("PYTHONPATH", "")}
    run = subprocess.run([sys.executable, "-c", _FORK_SCRIPT], cwd=root, env=env, capture_output=True, text=True,
                         timeout=HANG_S)
    out = run.stdout
    assert "raised ForkedGLContextError" in out, out + run.stderr[-3000:]
    line = next(l for l in out.splitlines() if l.startswith("raised"))
    assert float(line.split()[2]) < 120  # fails fast (a deadlock never returns; 120 s leaves a loaded machine room)
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


@pytest.mark.slow
def test_renderer_inherited_through_fork_raises_instead_of_hanging():
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    env = {**os.environ, "PYTHONPATH": root + os.pathsep + os.environ.get("PYTHONPATH", "")}
    run = subprocess.run([sys.executable, "-c", _FORKED_RENDERER_SCRIPT], cwd=root, env=env, capture_output=True,
                         text=True, timeout=HANG_S)
    assert "child exit 0" in run.stdout and "parent ok" in run.stdout, run.stdout + run.stderr[-3000:]


@pytest.mark.parametrize("r0", [2.2250738585e-313, 5e-324, 1e-310])
def test_subnormal_foveal_radius_is_refused(r0):
    """Found by hypothesis (test_grids_are_bounded_or_refused): a subnormal r0 made the implied
    sampling density overflow to inf and the log spacing 0 (ZeroDivisionError)."""
    with pytest.raises(ValueError, match="r0"):
        C.RetinaGrid.from_field_of_view(1.0, r0, 4)
