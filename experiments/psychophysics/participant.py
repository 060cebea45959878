"""The simulated participant's own noise: where its eyes land and how it reports what it saw.

A theory says what a flash *looks like*; a participant in an experiment also moves its eyes
imprecisely and reports imprecisely. The scoreboard (``python -m experiments phenomena``) scores
every theory on such a participant, so that its confidence intervals are those an experimenter
would get from repeated trials, not the zero-width intervals of a noiseless simulation:

- **motor noise**: the saccade's endpoint scatters with s.d. ``endpoint_noise`` x amplitude,
  horizontally and vertically (``models.Head(endpoint_noise=...)``; the efference copy keeps the
  intended endpoint). 5 % of the amplitude: the lower end of the 5-10 % reported for saccades to a
  visible target (Kowler & Blaser 1995, Vision Res 35:1741);
- **report noise**: each reported position (azimuth and elevation) scatters around the percept
  with s.d. ``report_weber`` x the flash's eccentricity from the saccade target, where the eyes
  are when the report is made: positional uncertainty of a briefly seen dot grows as ~5 % of its
  eccentricity (White, Levi & Aitsebaomo 1992, Vision Res 32:513).

Both numbers are rows of ``experiments/data/calibration.csv`` (model ``all``): a phenomenon from
either source could not count as predicted by any theory.
"""

from __future__ import annotations

import zlib
from dataclasses import dataclass

import numpy as np

from .bounds import check_constants

__all__ = ["Participant", "PARTICIPANT", "add_report_noise"]


@dataclass(frozen=True)
class Participant:
    """The participant's motor and report noise (see the module docstring)."""

    endpoint_noise: float = 0.05
    report_weber: float = 0.05

    def __post_init__(self) -> None:
        check_constants(self, may_be_zero=("endpoint_noise", "report_weber"))


#: The participant every theory is scored on.
PARTICIPANT = Participant()

#: Reported columns: (perceived x, perceived y, true x, true y) of each flash a row can hold.
_FLASHES = (
    ("perceived_x_deg", "perceived_y_deg", "true_x_deg", "true_y_deg"),
    ("second_perceived_x_deg", "second_perceived_y_deg", "second_true_x_deg", "second_true_y_deg"),
)


def add_report_noise(table: dict[str, np.ndarray], participant: Participant, stream: str) -> dict[str, np.ndarray]:
    """A copy of a localization ``table`` (column -> array) whose perceived positions are the
    participant's reports: Gaussian noise of s.d. ``report_weber`` x |flash - target| (deg) added to
    each flash's azimuth and elevation, and the error columns recomputed. Deterministic: the draws
    come from ``stream`` (e.g. the design's name) in row order, so every theory read out of the same
    trials gets the same noise (common random numbers)."""
    out = {k: np.array(v, copy=True) for k, v in table.items()}
    n = len(out["perceived_x_deg"])
    rng = np.random.default_rng(zlib.crc32(stream.encode()))
    draws = rng.standard_normal((n, len(_FLASHES), 2))
    for k, (px, py, tx, ty) in enumerate(_FLASHES):
        if px not in out:
            continue
        ecc = np.hypot(out[tx] - out["target_x_deg"], out[ty] - out["target_y_deg"])
        sd = participant.report_weber * ecc
        out[px] = out[px] + sd * draws[:, k, 0]
        out[py] = out[py] + sd * draws[:, k, 1]
    out["error_x_deg"] = out["perceived_x_deg"] - out["true_x_deg"]
    out["error_y_deg"] = out["perceived_y_deg"] - out["true_y_deg"]
    return out
