"""The legacy analytic main sequence of saccades (``Head(saccade_model="legacy")``).

Van Wetter & Van Opstal (2008), J. Vision 8(14):8,
``E(t) = m0 ln[A exp(vpk t / m0) / (1 + A exp((vpk t - T)/m0))]``, ``A = 1/(1 - exp(-T/m0))``,
``m0 = 7 deg``, ``vpk = 0.525 deg/ms`` (about 400 deg/s and 57 ms for 10 deg).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from conformal import checks

from .._plan_kernels import legacy_position, legacy_rate
from .ranges import MAX_PEAK_VELOCITY_DEG_S

__all__ = ["MainSequence", "times"]


@dataclass(frozen=True)
class MainSequence:
    """Saccade kinematics of Van Wetter & Van Opstal (2008), J. Vision 8(14):8.

    ``E(t) = m0 ln[A e^{vpk t/m0} / (1 + A e^{(vpk t - T)/m0})]`` with ``A = 1/(1 - e^{-T/m0})``.
    The velocity ``vpk / (1 + A e^{(vpk t - T)/m0})`` peaks at onset at ``vpk (1 - e^{-T/m0})``
    (< vpk <= ``MAX_PEAK_VELOCITY_DEG_S``). Duration is the time until the speed falls below ``end_velocity_deg_s``
    (20 deg/s, a usual saccade-offset criterion): about 57 ms for 10 deg.
    """

    m0_deg: float = 7.0
    vpk_deg_per_ms: float = 0.525
    end_velocity_deg_s: float = 20.0
    settle_deg: float = 0.01  #: the tail is cut (position snaps to the endpoint) this close to it

    def __post_init__(self):
        object.__setattr__(self, "m0_deg", checks.real("m0_deg", self.m0_deg, 0.0, 100.0, lo_open=True))
        object.__setattr__(
            self,
            "vpk_deg_per_ms",
            checks.real(
                "vpk_deg_per_ms",
                self.vpk_deg_per_ms,
                0.0,
                MAX_PEAK_VELOCITY_DEG_S / 1000.0,
                lo_open=True,
                hint=f"peak eye speed never exceeds {MAX_PEAK_VELOCITY_DEG_S:.0f} deg/s",
            ),
        )
        object.__setattr__(
            self,
            "end_velocity_deg_s",
            checks.real(
                "end_velocity_deg_s",
                self.end_velocity_deg_s,
                0.0,
                1000.0 * self.vpk_deg_per_ms,
                lo_open=True,
                hi_open=True,
                hint="the offset speed lies below the peak speed vpk",
            ),
        )
        object.__setattr__(self, "settle_deg", checks.real("settle_deg", self.settle_deg, 0.0, 1.0, lo_open=True))

    @staticmethod
    def _amp(amp_deg) -> float:
        return checks.real("amp_deg", amp_deg, 0.0, 180.0, hint="a saccade amplitude in degrees")

    def _A(self, amp_deg):
        return 1.0 / -np.expm1(-np.asarray(amp_deg, float) / self.m0_deg)

    def position_deg(self, t_ms, amp_deg: float) -> np.ndarray:
        """E(t) in degrees for ``t_ms`` after onset (0 before onset)."""
        t = times(t_ms)
        return np.asarray(legacy_position(t, self._amp(amp_deg), self.m0_deg, self.vpk_deg_per_ms), float)

    def velocity_deg_per_ms(self, t_ms, amp_deg: float) -> np.ndarray:
        """dE/dt in deg/ms (0 up to and including onset; jumps to the peak just after it)."""
        t = times(t_ms)
        return np.asarray(legacy_rate(t, self._amp(amp_deg), self.m0_deg, self.vpk_deg_per_ms), float)

    def peak_velocity_deg_s(self, amp_deg: float) -> float:
        """Peak speed (deg/s) = vpk (1 - e^{-T/m0})."""
        amp_deg = self._amp(amp_deg)
        return float(1000.0 * self.vpk_deg_per_ms * -np.expm1(-amp_deg / self.m0_deg))

    def duration_ms(self, amp_deg: float) -> float:
        """Time from onset until the speed falls below ``end_velocity_deg_s``."""
        amp_deg = self._amp(amp_deg)
        if amp_deg <= 0:
            return 0.0
        v, m0 = self.vpk_deg_per_ms, self.m0_deg
        ratio = (v / (self.end_velocity_deg_s / 1000.0) - 1.0) / self._A(amp_deg)
        if ratio <= 0 or self.peak_velocity_deg_s(amp_deg) <= self.end_velocity_deg_s:
            return float(amp_deg / v)
        return float(max((amp_deg + m0 * np.log(ratio)) / v, 0.0))

    def settle_ms(self, amp_deg: float) -> float:
        """Time after onset when T - E(t) < ``settle_deg``; the plan then holds the endpoint."""
        amp_deg = self._amp(amp_deg)
        if amp_deg <= self.settle_deg:
            return 0.0
        # T - E = m0 ln(1 + e^{-x}/A)  =>  e^{-x} = A (e^{d/m0} - 1)
        A = self._A(amp_deg)
        x = -np.log(A * np.expm1(self.settle_deg / self.m0_deg))
        return float((amp_deg + self.m0_deg * x) / self.vpk_deg_per_ms)


def times(t_ms) -> np.ndarray:
    """Finite real times (ms) as a float array."""
    return checks.array("t_ms", t_ms, kinds="biuf").astype(float)
