"""Brainstem saccade generator: a local feedback loop with a saturating burst, driving the eye plant.

The loop, in degrees and milliseconds, per saccade of desired displacement ``A``:

* motor error ``e = A - D``, where ``D`` is the resettable displacement integrator fed back from
  the burst (Jürgens, Becker & Kornhuber 1981, Biol Cybern 39:87; Robinson 1975's local feedback
  loop with the integrator moved into the feedback path);
* burst drive ``f(e) = B_max (1 - exp(-e / b))`` for ``e > 0``: the saturating burst nonlinearity
  of Van Gisbergen, Robinson & Gielen (1981), J Neurophysiol 45:417 -- it makes peak velocity
  saturate for large saccades (the main sequence) instead of growing linearly;
* burst cells follow their drive with a first-order lag ``burst_lag_ms`` (membrane and synaptic
  delay in the loop), so the eye accelerates over several ms and the velocity profile is a bell,
  not a jump;
* burst adaptation: the drive is reduced by a slow trace of the burst's own activity
  (``adaptation_gain``, ``adaptation_ms``, spike-frequency adaptation of burst neurons), which
  flattens the velocity plateau of large saccades and lowers their skewness (Collewijn et al. 1988);
* the omnipause neurons latch the burst off once the motor error reaches 0 (the loop ends the
  saccade on the desired displacement: there is no endpoint error without noise);
* the neural integrator makes the step (eye position ``N = D``) and the burst the pulse; with the
  pulse gain matched to the plant's long time constant T1, the pulse-step through the
  second-order plant ``1 / ((1 + s T1)(1 + s T2))`` (Robinson 1964, J Physiol 174:245) reduces to
  ``E = N`` low-passed by ``T2``: T1 drops out.

Binocular coordination: Hering's law (one burst, both eyes) with eye-specific plants (abducting
faster, Collewijn, Erkelens & Steinman 1988); oblique saccades share one vector burst. Defaults
fitted once to Collewijn et al. 1988 and Carpenter 1988; profiles interpolated from a table
simulated once per process. Why this mechanism, the defaults' fit, the binocular asymmetry, what
the model does not do and the table's accuracy: docs/head.md ("Model notes", "The saccade
generator").
"""

from __future__ import annotations

import functools
import os
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from conformal import checks

from .eye_kinematics.ranges import MAX_PEAK_VELOCITY_DEG_S

__all__ = ["BurstGenerator", "SaccadeProfile", "PLANTS", "DETECTION_THRESHOLD_DEG_S", "PARAMETER_BOUNDS"]

#: The three plants of a profile: ``nominal`` (vertical components, the cyclopean eye),
#: ``abducting`` and ``adducting`` (horizontal component of the eye moving temporally / nasally).
PLANTS = ("nominal", "abducting", "adducting")
#: Eye speed (deg/s) whose crossings delimit a saccade's duration.
DETECTION_THRESHOLD_DEG_S = 30.0
#: The accepted range (inclusive) of every parameter: what ``BurstGenerator`` accepts is what a fit
#: (``experiments.oculomotor.generator_fit``) may return, so every fitted file loads. The table's peak-velocity
#: ceiling (``MAX_PEAK_VELOCITY_DEG_S``) is a further joint bound the fit also respects.
PARAMETER_BOUNDS = {
    "burst_max_deg_s": (1.0, 2000.0),
    "burst_scale_deg": (0.01, 50.0),
    "burst_lag_ms": (0.1, 50.0),
    "adaptation_gain": (0.0, 5.0),
    "adaptation_ms": (0.1, 500.0),
    "plant_t2_ms": (0.5, 50.0),
    "abducting_t2_ms": (0.5, 50.0),
    "adducting_t2_ms": (0.5, 50.0),
    "settle_deg": (1e-4, 1.0),
}
#: Amplitudes of the tabulated profiles (deg).
_AMP_STEP_DEG, _AMP_MAX_DEG = 0.25, 90.0
#: Simulation step and table step (ms).
_SIM_DT_MS, _TABLE_DT_MS = 0.05, 0.25
_TABLE_SPAN_MS = 320.0
#: Limits of a direct simulation (``simulate``): the largest amplitude (deg), span (ms) and number
#: of stored values (an allocation bound).
_SIM_AMP_MAX_DEG, _SIM_SPAN_MAX_MS, _SIM_MAX_VALUES = 180.0, 60_000.0, 10**8


@dataclass(frozen=True)
class SaccadeProfile:
    """Normalised position profiles (0 -> 1) of one saccade amplitude, on a uniform time grid from
    the burst onset (``t = 0``), one row per plant of ``PLANTS``; ``burst`` is the burst rate
    (deg/ms of commanded displacement) on the same grid. Beyond the grid the eye holds 1."""

    amplitude_deg: float
    dt_ms: float
    positions: np.ndarray  #: (3, K) normalised positions, rows in ``PLANTS`` order
    burst: np.ndarray  #: (K,) burst rate, deg/ms
    settle_deg: float

    if TYPE_CHECKING:  # set in __post_init__ (object.__setattr__), not fields of the dataclass
        _marks: tuple[float, ...] = field(init=False)
        _tables: tuple[np.ndarray, np.ndarray, np.ndarray] = field(init=False)

    def __post_init__(self):
        from . import _plan_kernels as K

        tab = np.ascontiguousarray(np.asarray(self.positions, float)[None])  # a table of one amplitude
        rates = np.ascontiguousarray(np.gradient(tab, self.dt_ms, axis=2))
        zero = np.zeros(1, np.intp)
        marks = np.empty((1, 4))
        K.profile_marks(
            tab,
            self.dt_ms,
            zero,
            zero,
            np.zeros(1),
            np.array([float(self.amplitude_deg)]),
            np.array([tab.shape[2]], np.intp),
            DETECTION_THRESHOLD_DEG_S,
            self.settle_deg,
            marks,
        )
        object.__setattr__(self, "_marks", tuple(float(x) for x in marks[0]))
        object.__setattr__(self, "_tables", (tab, rates, np.array([[0.0, 0.0, 0.0, self.amplitude_deg, marks[0, 2]]])))

    onset_ms = property(
        lambda self: self._marks[0],
        doc="""Movement onset after the burst onset: first 30 deg/s crossing (nominal plant), ms.""",
    )
    offset_ms = property(
        lambda self: self._marks[1], doc="""Movement offset after the burst onset: last 30 deg/s crossing, ms."""
    )
    duration_ms = property(
        lambda self: self._marks[1] - self._marks[0],
        doc="""Detected duration: between the 30 deg/s crossings of the nominal plant's speed.""",
    )
    settle_ms = property(
        lambda self: self._marks[2],
        doc="""Time after burst onset from which all plants are within ``settle_deg`` of the endpoint.""",
    )
    peak_velocity_deg_s = property(lambda self: self._marks[3], doc="""Peak speed of the nominal plant (deg/s).""")

    def _values(self, t_rel, plant: int, rate: bool) -> np.ndarray:
        from . import _plan_kernels as K

        t = checks.array("t_rel", t_rel, kinds="biuf").astype(float)
        plant = checks.integer("plant", plant, 0, len(PLANTS) - 1, hint="0 nominal, 1 abducting, 2 adducting")
        tab, rates, prof = self._tables
        out = np.empty((1, t.size))
        K.profile_values(
            tab, rates, self.dt_ms, prof, False, 0.0, 0.0, int(plant), np.ascontiguousarray(t.reshape(1, -1)), rate, out
        )
        return out.reshape(t.shape)

    def position(self, t_rel: np.ndarray, plant: int = 0) -> np.ndarray:
        """Normalised position at ``t_rel`` ms after burst onset (0 before, 1 from ``settle_ms``)."""
        return self._values(t_rel, plant, False)

    def rate(self, t_rel: np.ndarray, plant: int = 0) -> np.ndarray:
        """d(position)/dt (1/ms) at ``t_rel`` (0 outside the movement)."""
        return self._values(t_rel, plant, True)


def simulate(
    generator: BurstGenerator,
    amplitudes_deg: np.ndarray,
    span_ms: float = _TABLE_SPAN_MS,
    dt_ms: float = _SIM_DT_MS,
    every: int = 1,
) -> tuple[np.ndarray, np.ndarray]:
    """Simulate the burst-generator loop (module docstring) directly for each amplitude.

    ``generator``: the parameters; ``amplitudes_deg``: desired displacements (any shape, 0-180 deg);
    ``span_ms``: how long to simulate from the burst onset; ``dt_ms``: the integration step;
    ``every``: keep every ``every``-th step. The linear stages are integrated exactly for an input
    held over each step (compiled: ``models._plan_kernels.burst_loop``). Returns eye positions
    ``(3, K) + amplitudes.shape`` in degrees (plants in ``PLANTS`` order) and burst rates
    ``(K,) + amplitudes.shape`` in deg/ms, ``K = round(span_ms / dt_ms) // every + 1`` samples from
    the burst onset. ``BurstGenerator.simulate`` is its public form; ``BurstGenerator.profile``
    interpolates a table of these runs instead.
    """
    if not isinstance(generator, BurstGenerator):
        raise checks.InputTypeError(f"generator must be a models.BurstGenerator; got {type(generator).__name__}")
    amps = checks.array("amplitudes_deg", amplitudes_deg, kinds="iuf")
    if amps.size and (amps.min() < 0.0 or amps.max() > _SIM_AMP_MAX_DEG):
        raise ValueError(
            f"amplitudes_deg must lie in [0, {_SIM_AMP_MAX_DEG:g}] deg; got {amps.min():g} to {amps.max():g}"
        )
    span_ms = checks.real("span_ms", span_ms, 0.0, _SIM_SPAN_MAX_MS, lo_open=True, hint="simulated time in ms")
    dt_ms = checks.real("dt_ms", dt_ms, 0.0, span_ms, lo_open=True, hint="integration step in ms, at most span_ms")
    steps = int(round(span_ms / dt_ms))
    every = checks.integer("every", every, 1, max(1, steps), hint="steps per kept sample")
    if 3 * (steps // every + 1) * max(1, amps.size) > _SIM_MAX_VALUES:
        raise ValueError(
            f"amplitudes_deg ({amps.size}) times span_ms / dt_ms / every ({steps // every + 1} samples) "
            f"exceeds {_SIM_MAX_VALUES:.0e} stored values: simulate fewer amplitudes, a shorter span or a "
            f"coarser grid"
        )
    g = generator
    A = np.ascontiguousarray(np.asarray(amplitudes_deg, float).ravel())
    n = int(round(span_ms / dt_ms))
    t2 = np.array([g.plant_t2_ms, g.abducting_t2_ms, g.adducting_t2_ms])
    pos = np.empty((3, n // every + 1, len(A)))
    burst = np.empty((n // every + 1, len(A)))
    from ._plan_kernels import burst_loop

    burst_loop(
        A,
        n,
        float(dt_ms),
        int(every),
        float(np.exp(-dt_ms / g.burst_lag_ms)),
        float(np.exp(-dt_ms / g.adaptation_ms)),
        t2,
        np.exp(-dt_ms / t2),
        g.burst_max_deg_s / 1000.0,
        float(g.burst_scale_deg),
        float(g.adaptation_gain),
        pos,
        burst,
    )
    shape = np.shape(amplitudes_deg)
    return pos.reshape((3, pos.shape[1]) + shape), burst.reshape((burst.shape[0],) + shape)


@dataclass(frozen=True)
class BurstGenerator:
    """Parameters of the burst generator (see the module docstring); defaults fitted to the
    human main sequence (Collewijn et al. 1988; Carpenter 1988).

    burst_max_deg_s : saturation of the burst nonlinearity (deg/s of commanded eye velocity).
    burst_scale_deg : motor error at which the burst reaches 63 % of its saturation (deg).
    burst_lag_ms : first-order lag of the burst cells. adaptation_gain, adaptation_ms : strength
        and time constant of burst adaptation. plant_t2_ms : short plant time constant of the
        nominal plant (vertical components); abducting_t2_ms / adducting_t2_ms : of the
        horizontal plants of the eye moving temporally / nasally (abducting faster).
    settle_deg : the trajectory snaps to the endpoint (and the saccade ends) once every plant is
        within this distance of it.
    """

    burst_max_deg_s: float = 714.0
    burst_scale_deg: float = 2.82
    burst_lag_ms: float = 8.6
    adaptation_gain: float = 0.646
    adaptation_ms: float = 22.2
    plant_t2_ms: float = 7.4
    abducting_t2_ms: float = 5.5
    adducting_t2_ms: float = 9.5
    settle_deg: float = 0.01

    def __post_init__(self):
        for name, (lo, hi) in PARAMETER_BOUNDS.items():
            object.__setattr__(self, name, checks.real(name, getattr(self, name), lo, hi))

    # ------------------------------------------------------------------ the table
    # B019: the cache holds the instance, on purpose: one table per parameter set (frozen: hashed by
    # value), and the parameter sets of a process are few
    @functools.cache  # noqa: B019
    def _table(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        amps = np.arange(0.0, _AMP_MAX_DEG + _AMP_STEP_DEG / 2, _AMP_STEP_DEG)
        pos, burst = simulate(self, amps, every=int(round(_TABLE_DT_MS / _SIM_DT_MS)))
        peak = float((np.diff(pos, axis=1) / _TABLE_DT_MS).max()) * 1000.0
        if peak > MAX_PEAK_VELOCITY_DEG_S:
            raise ValueError(
                f"these burst-generator parameters drive the eye at {peak:.0f} deg/s, above the "
                f"model family's ceiling of {MAX_PEAK_VELOCITY_DEG_S:.0f} deg/s (no human saccade is faster); lower "
                "burst_max_deg_s or raise adaptation_gain"
            )
        with np.errstate(invalid="ignore", divide="ignore"):
            norm = np.where(amps > 0, pos / amps, 0.0)
        return amps, norm.astype(np.float64), burst

    # ------------------------------------------------------------------ files
    def to_file(self, path, **extra) -> None:
        """Write these parameters as JSON: ``{"model": "BurstGenerator", "parameters": {...}}`` plus the
        keyword arguments ``extra`` (a fit's CIs, data source, ...) as further top-level keys."""
        import dataclasses
        import json

        from .build import _path

        path = _path("path", path)
        doc = {"model": "BurstGenerator", "parameters": dataclasses.asdict(self), **extra}
        try:
            text = json.dumps(doc, indent=2) + "\n"
        except (TypeError, ValueError) as exc:
            raise ValueError(f"the extra entries of a burst-generator file must be JSON values: {exc}") from None
        tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
        try:  # atomically: a reader sees the old file or the new one, never a torn one
            tmp.write_text(text)
            os.replace(tmp, path)
        except OSError as exc:
            tmp.unlink(missing_ok=True)
            raise ValueError(f"path {path}: cannot write the burst generator there ({exc.strerror or exc})") from None

    @classmethod
    def from_file(cls, path) -> BurstGenerator:
        """Parameters from a JSON file written by :meth:`to_file` (e.g. the ``generator.json`` of
        ``python -m experiments saccades --recording``); parameters it omits keep their defaults.
        An unreadable file, another model, an unknown or out-of-range parameter or a parameter set
        above the peak-velocity ceiling is a ``ValueError`` naming the file and the problem."""
        import dataclasses
        import json

        from .build import _path

        path = _path("path", path)
        try:
            doc = json.loads(path.read_text())
        except RecursionError:
            raise ValueError(
                f"path {path}: cannot read a burst generator from it (its JSON is nested too deeply); "
                "pass the generator.json written by `python -m experiments saccades --recording FILE "
                "--out DIR`"
            ) from None
        except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
            raise ValueError(
                f"path {path}: cannot read a burst generator from it ({exc}); pass the generator.json "
                "written by `python -m experiments saccades --recording FILE --out DIR`"
            ) from None
        if (
            not isinstance(doc, dict)
            or doc.get("model") != "BurstGenerator"
            or not isinstance(doc.get("parameters"), dict)
        ):
            raise ValueError(
                f'{path} is not a burst-generator file: it needs "model": "BurstGenerator" and a '
                '"parameters" object (as written by BurstGenerator.to_file)'
            )
        params = doc["parameters"]
        known = {f.name for f in dataclasses.fields(cls)}
        unknown = sorted(set(params) - known)
        if unknown:
            raise ValueError(
                f"{path}: unknown burst-generator parameter(s) {', '.join(unknown)}; known: {', '.join(sorted(known))}"
            )
        try:
            gen = cls(**params)
            gen._table()  # the joint bound (the peak-velocity ceiling): refused here, not after a run has started
            return gen
        except (TypeError, ValueError) as exc:
            raise ValueError(f"{path}: {exc}") from None

    def profile(self, amp_deg: float) -> SaccadeProfile:
        """Normalised trajectories of a saccade of ``amp_deg`` (0-90 deg), interpolated from the table."""
        amp = checks.real("amp_deg", amp_deg, 0.0, _AMP_MAX_DEG, hint="a saccade amplitude in degrees")
        amps, norm, burst = self._table()
        j = min(int(amp / _AMP_STEP_DEG), len(amps) - 2)
        w = (amp - amps[j]) / _AMP_STEP_DEG
        if j == 0:  # below the first non-zero amplitude the normalised profile is that of 0.25 deg
            pos, b = norm[:, :, 1], burst[:, 1] * (amp / amps[1])
        else:
            pos = (1 - w) * norm[:, :, j] + w * norm[:, :, j + 1]
            b = (1 - w) * burst[:, j] + w * burst[:, j + 1]
        return SaccadeProfile(amp, _TABLE_DT_MS, pos, b, self.settle_deg)

    def simulate(
        self, amplitudes_deg: np.ndarray, span_ms: float = _TABLE_SPAN_MS, dt_ms: float = _SIM_DT_MS, every: int = 1
    ) -> tuple[np.ndarray, np.ndarray]:
        """Direct simulation of the loop for each of ``amplitudes_deg`` (any shape, 0-180 deg), no
        table: eye positions ``(3, K) + shape`` (deg, plants in ``PLANTS`` order) and burst rates
        ``(K,) + shape`` (deg/ms), every ``every``-th step of ``dt_ms`` over ``span_ms`` from the
        burst onset, ``K = round(span_ms / dt_ms) // every + 1`` (module docstring for the loop)."""
        return simulate(self, amplitudes_deg, span_ms, dt_ms, every)

    def peak_velocity_deg_s(self, amp_deg: float) -> float:
        return self.profile(amp_deg).peak_velocity_deg_s

    def duration_ms(self, amp_deg: float) -> float:
        return self.profile(amp_deg).duration_ms
