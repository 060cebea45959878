"""The bounds of every numeric parameter of a flash-localization study, and their checks.

One table (``LIMITS``) serves the library (``Design``, ``TrialConfig``, ``RemapTimeCourse`` raise
``TypeError`` for a wrong type and ``ValueError`` for a value out of bounds, NaN or infinite) and the
command line (``python -m experiments run`` turns the same bounds into usage errors). The bounds are
wide enough for any meaningful study and narrow enough that no value runs unbounded: a design holds
at most ``MAX_TRIALS`` trials, images are at most 1024 px, the gain at most 5 (99.3 % compression;
beyond about 3.4 every flash is shifted off the log-polar map).

This module imports nothing heavy, so the command line can show the bounds in ``--help``.
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass

__all__ = ["Limit", "LIMITS", "MAX_TRIALS", "check_real", "check_int", "check_constants"]


@dataclass(frozen=True)
class Limit:
    """A closed or half-open interval [lo, hi] of allowed values; ``integer``: whole numbers only."""

    lo: float
    hi: float
    integer: bool = False
    lo_open: bool = False
    hi_open: bool = False
    unit: str = ""

    def text(self) -> str:
        """The interval as text, e.g. ``[0, 5]`` or ``(0, 40] deg``."""

        def num(v: float) -> str:
            return f"{v:g}" if not float(v).is_integer() or abs(v) < 1e6 else f"{int(v):d}"

        s = f"{'(' if self.lo_open else '['}{num(self.lo)}, {num(self.hi)}{')' if self.hi_open else ']'}"
        return s + (f" {self.unit}" if self.unit else "")

    def contains(self, v: float) -> bool:
        if (isinstance(v, float) and not math.isfinite(v)) or v < self.lo or v > self.hi:
            return False
        return not ((self.lo_open and v == self.lo) or (self.hi_open and v == self.hi))


#: Bounds of every numeric parameter, by the name it has in the library.
LIMITS: dict[str, Limit] = {
    # Design
    "amplitudes_deg": Limit(0.0, 40.0, lo_open=True, unit="deg"),
    "flash_times_ms": Limit(-1000, 1000, integer=True, unit="ms"),
    "repetitions": Limit(1, 1000, integer=True),
    "seed": Limit(0, 2**31 - 1, integer=True),
    # RemapTimeCourse
    "peak_time_ms": Limit(-1000.0, 1000.0, unit="ms"),
    "rise_ms": Limit(1.0, 1000.0, unit="ms"),
    "decay_ms": Limit(1.0, 1000.0, unit="ms"),
    "peak_gain": Limit(0.0, 5.0),
    # TrialConfig
    "image_size": Limit(32, 1024, integer=True, unit="px"),
    "fovy_deg": Limit(20.0, 120.0, unit="deg"),
    "fovea_deg": Limit(0.25, 10.0, unit="deg"),
    "threshold": Limit(0.0, 1.0, hi_open=True),
    "oversample": Limit(1, 8, integer=True),
    "flash_radius_deg": Limit(0.1, 5.0, unit="deg"),
    "endpoint_noise": Limit(0.0, 0.5),
    "visual_latency_ms": Limit(0.0, 300.0, unit="ms"),
    "feedback_gain": Limit(0.0, 50.0, unit="ms/deg"),
    "reference_weight": Limit(0.0, 1.0),
    "reference_unit": Limit(0.0, 1.0, lo_open=True),
    "stability_tolerance": Limit(0.0, 1.0),
    "report_noise_deg": Limit(0.0, 10.0, unit="deg"),
    "eps_sigma_ms": Limit(1.0, 500.0, unit="ms"),
    "eps_delay_ms": Limit(-500.0, 500.0, unit="ms"),
    "reference_contrast": Limit(0.0, 1.0),
    "reference_ms": Limit(0, 1000, integer=True, unit="ms"),
    "target_off_ms": Limit(-1000, 1000, integer=True, unit="ms"),
    # execution
    "workers": Limit(1, 64, integer=True),
    # fitting and simulated observers (fit, compare, simulate, recovery, crossval)
    "max_evals": Limit(10, 100_000, integer=True),
    "reports": Limit(1, 100, integer=True),
    "noise_deg": Limit(0.05, 20.0, unit="deg"),
    # agents (train, baselines)
    "timesteps": Limit(1, 10**8, integer=True),
}

#: The largest design (trials) a study may have (the default study has 1248).
MAX_TRIALS = 100_000


def _is_real(value) -> bool:
    return isinstance(value, numbers.Real) and not isinstance(value, bool)


def check_real(name: str, value, limit: Limit | None = None) -> float:
    """``value`` as a float, or ``TypeError`` (not a real number) / ``ValueError`` (NaN, infinite,
    outside ``limit``, by default ``LIMITS[name]``)."""
    lim = LIMITS[name] if limit is None else limit
    if not _is_real(value):
        raise TypeError(f"{name} must be a real number; got {value!r} ({type(value).__name__})")
    try:
        v = float(value)
    except OverflowError:
        v = math.inf
    if not lim.contains(v):
        raise ValueError(f"{name} must be a finite number in {lim.text()}; got {value!r}")
    return v


def check_int(name: str, value, limit: Limit | None = None) -> int:
    """``value`` as an int, or ``TypeError`` (not a number) / ``ValueError`` (not a whole number,
    outside ``limit``, by default ``LIMITS[name]``). Integral floats (``256.0``) are accepted,
    ``7.5`` is refused rather than truncated."""
    lim = LIMITS[name] if limit is None else limit
    if not _is_real(value):
        raise TypeError(f"{name} must be an integer; got {value!r} ({type(value).__name__})")
    if isinstance(value, numbers.Integral):
        v = int(value)
    else:
        try:
            f = float(value)
        except OverflowError:
            f = math.inf
        if not (math.isfinite(f) and f.is_integer()):
            raise ValueError(f"{name} must be a whole number in {lim.text()}; got {value!r}")
        v = int(f)
    if not lim.contains(v):
        raise ValueError(f"{name} must be a whole number in {lim.text()}; got {value!r}")
    return v


def check_constants(obj, may_be_zero: tuple[str, ...] = ()) -> None:
    """Every field of the frozen dataclass ``obj`` (a model's constants) as a float: ``TypeError``
    unless a finite real number, ``ValueError`` unless > 0 (>= 0 for the fields ``may_be_zero``)."""
    from dataclasses import fields

    kind = type(obj).__name__
    for f in fields(obj):
        v = getattr(obj, f.name)
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            raise TypeError(f"{kind}.{f.name} must be a finite number; got {v!r:.60}")
        zero_ok = f.name in may_be_zero
        if v < 0 or (v == 0 and not zero_ok):
            raise ValueError(f"{kind}.{f.name} must be {'>=' if zero_ok else '>'} 0; got {v!r}")
        object.__setattr__(obj, f.name, float(v))
