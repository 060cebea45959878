"""A declarative flash-localization design expanded into trials (paper §6.5, Fig. 11).

Positions are head-centred visual angles in degrees (azimuth x along the saccade, elevation y),
as seen from the cyclopean eye on the ``dots`` scene's screen (``models.screen_point``). The
saccade goes horizontally from -A/2 to +A/2; flash positions are offsets from the target.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import asdict, dataclass, field

from .bounds import MAX_TRIALS, Limit, check_int, check_real

__all__ = ["Design", "Trial", "FIG11_OFFSETS_DEG", "MORRONE_OFFSETS_DEG", "default_design", "quick_design"]

#: The Fig. 11-style array: 6 columns x 4 rows (24 dots) around the target, deg (dx, dy).
#: Columns lie before and beyond the target along the saccade, rows above and below its path,
#: none nearer the target than 4 deg (so that compressed flashes stay outside the fovea).
FIG11_OFFSETS_DEG: tuple[tuple[float, float], ...] = tuple(
    (dx, dy) for dy in (6.0, 3.0, -3.0, -6.0) for dx in (-12.0, -8.0, -4.0, 4.0, 8.0, 12.0) if math.hypot(dx, dy) >= 4.0
)
#: A reduced Morrone-style set: 4 positions along the path (just above it) and 4 above/below.
MORRONE_OFFSETS_DEG: tuple[tuple[float, float], ...] = (
    (-12.0, 3.0),
    (-8.0, 3.0),
    (-4.0, 3.0),
    (8.0, 3.0),
    (-8.0, -3.0),
    (-4.0, -6.0),
    (4.0, 6.0),
    (8.0, -6.0),
)


#: Flash offsets from the target (deg): the screen is +-40 deg wide and +-30 deg high.
_OFFSET_LIMIT = Limit(-80.0, 80.0, unit="deg")


def _sequence(name: str, value, what: str = "a non-empty sequence") -> tuple:
    """``value`` as a tuple, or TypeError (a string, a number, a mapping) / ValueError (empty)."""
    if isinstance(value, (str, bytes, dict)):
        raise TypeError(f"{name} must be {what}; got {value!r}")
    try:
        out = tuple(value)
    except TypeError:
        raise TypeError(f"{name} must be {what}; got {value!r}") from None
    if not out:
        raise ValueError(f"{name} must be {what}; got an empty one")
    return out


@dataclass(frozen=True)
class Trial:
    """One flash: saccade of ``amplitude_deg`` from -A/2 to +A/2 deg azimuth, a flash at target +
    (dx, dy) deg, ``flash_time_ms`` relative to saccade onset. ``seed`` drives the per-trial RNG."""

    trial_id: int
    amplitude_deg: float
    flash_dx_deg: float
    flash_dy_deg: float
    flash_time_ms: int
    repetition: int
    seed: int

    @property
    def fixation_deg(self) -> tuple[float, float]:
        return (-self.amplitude_deg / 2, 0.0)

    @property
    def target_deg(self) -> tuple[float, float]:
        return (self.amplitude_deg / 2, 0.0)

    @property
    def flash_deg(self) -> tuple[float, float]:
        return (self.amplitude_deg / 2 + self.flash_dx_deg, self.flash_dy_deg)


@dataclass(frozen=True)
class Design:
    """Saccade amplitudes x flash offsets (from the target) x flash times x repetitions.

    amplitudes_deg : horizontal saccade amplitudes (deg), each from -A/2 to +A/2.
    flash_offsets_deg : flash positions relative to the target, (dx, dy) deg.
    flash_times_ms : flash times relative to saccade onset (whole ms).
    repetitions : repeats of every condition (trials differ only by their seed).
    seed : base seed; trial i gets ``seed + i``.

    Bounds (``bounds.LIMITS``): amplitudes in (0, 40] deg, flash times whole ms within +-1000 ms,
    1-1000 repetitions, seed in [0, 2**31 - 1], at most ``bounds.MAX_TRIALS`` trials in all, every
    flash on the screen. Wrong types raise TypeError, values out of bounds ValueError.
    """

    amplitudes_deg: tuple[float, ...] = (12.0, 16.0, 20.0, 24.0)
    flash_offsets_deg: tuple[tuple[float, float], ...] = FIG11_OFFSETS_DEG
    flash_times_ms: tuple[int, ...] = tuple(range(-150, 151, 25))
    repetitions: int = 1
    seed: int = 0
    name: str = field(default="default")

    def __post_init__(self) -> None:
        # bounds: ``bounds.LIMITS`` and ``bounds.MAX_TRIALS`` (TypeError for wrong types, ValueError otherwise)
        amps = tuple(check_real("amplitudes_deg", a) for a in _sequence("amplitudes_deg", self.amplitudes_deg))
        pairs = _sequence("flash_offsets_deg", self.flash_offsets_deg)
        offs_list: list[tuple[float, ...]] = []
        for p in pairs:
            p = _sequence("flash_offsets_deg", p, "(dx, dy) pairs")
            if len(p) != 2:
                raise ValueError(f"flash_offsets_deg must hold (dx, dy) pairs; got {p!r}")
            offs_list.append(tuple(check_real("flash_offsets_deg", v, _OFFSET_LIMIT) for v in p))
        offs = tuple(offs_list)
        times = tuple(check_int("flash_times_ms", t) for t in _sequence("flash_times_ms", self.flash_times_ms))
        reps = check_int("repetitions", self.repetitions)
        seed = check_int("seed", self.seed)
        if not isinstance(self.name, str):
            raise TypeError(f"name must be a string; got {self.name!r}")
        n = len(amps) * len(offs) * len(times) * reps
        if n > MAX_TRIALS:
            raise ValueError(
                f"the design has {n} trials, more than {MAX_TRIALS}: use fewer repetitions, "
                "amplitudes, flash offsets or flash times"
            )
        for a in amps:
            for dx, dy in offs:
                if abs(a / 2 + dx) > 40 or abs(dy) > 30:
                    raise ValueError(f"flash at target+({dx}, {dy}) deg for a {a} deg saccade is off the screen")
        object.__setattr__(self, "amplitudes_deg", amps)
        object.__setattr__(self, "flash_offsets_deg", offs)
        object.__setattr__(self, "flash_times_ms", times)
        object.__setattr__(self, "repetitions", reps)
        object.__setattr__(self, "seed", seed)

    @property
    def n_trials(self) -> int:
        return len(self.amplitudes_deg) * len(self.flash_offsets_deg) * len(self.flash_times_ms) * self.repetitions

    def trials(self) -> list[Trial]:
        """All trials in a fixed order (trial_id = position); the same design gives the same list."""
        out = []
        combos = itertools.product(
            range(self.repetitions), self.amplitudes_deg, self.flash_offsets_deg, self.flash_times_ms
        )
        for i, (rep, a, (dx, dy), t) in enumerate(combos):
            out.append(Trial(i, a, dx, dy, t, rep, self.seed + i))
        return out

    def to_dict(self) -> dict:
        d = asdict(self)
        d["flash_offsets_deg"] = [list(p) for p in self.flash_offsets_deg]
        return d


def default_design(seed: int = 0) -> Design:
    """The full study: amplitudes 12, 16, 20, 24 deg; 24 flash dots; -150..150 ms every 25 ms."""
    return Design(seed=seed, name="default")


def quick_design(seed: int = 0) -> Design:
    """A reduced study (~1 minute): one 20-deg saccade, 8 flash positions, 7 flash times."""
    return Design(
        amplitudes_deg=(20.0,),
        flash_offsets_deg=MORRONE_OFFSETS_DEG,
        flash_times_ms=(-150, -100, -50, -25, 0, 50, 150),
        seed=seed,
        name="quick",
    )
