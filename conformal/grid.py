"""The exp-polar retina grid: a uniform foveal disc plus log-polar periphery (paper §5.1, §6.2).

Ring k of the periphery spans radii [r0 e^{k delta}, r0 e^{(k+1) delta}) and sector l spans
angles [2 pi l / N, 2 pi (l+1) / N); the foveal disc |z| < r0 is sampled on a square lattice
of spacing 1/K. All lengths are image-plane units (|z| = tan(eccentricity)).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

__all__ = ["RetinaGrid"]


def _positive(name: str, value: float) -> float:
    v = float(value)
    if not math.isfinite(v) or v <= 0:
        raise ValueError(f"{name} must be a positive finite number; got {value!r}")
    return v


@dataclass(frozen=True)
class RetinaGrid:
    """Geometry of the exp-polar retina (the paper's eq. ``l-p discret.`` and §6.2 design rules).

    Attributes
    ----------
    r0 : radius of the foveal disc (= r_a, the removed disc), image-plane units.
    delta : log-radial spacing, u_{k+1} - u_k.
    M : number of rings.  N : number of sectors.
    fovea_spacing : spacing 1/K of the uniform foveal lattice.
    n_fovea : number of foveal samples N_f.
    """

    r0: float
    delta: float
    M: int
    N: int
    fovea_spacing: float
    n_fovea: int
    _fovea_points: NDArray[np.complex128] = field(init=False, repr=False, compare=False)
    _derived: dict = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        _positive("r0", self.r0)
        _positive("delta", self.delta)
        _positive("fovea_spacing", self.fovea_spacing)
        for name in ("M", "N"):
            v = getattr(self, name)
            if int(v) != v or v < 2:
                raise ValueError(f"{name} must be an integer >= 2; got {v!r}")
        if int(self.n_fovea) != self.n_fovea or self.n_fovea < 1:
            raise ValueError(f"n_fovea must be a positive integer; got {self.n_fovea!r}")
        object.__setattr__(self, "M", int(self.M))
        object.__setattr__(self, "N", int(self.N))
        object.__setattr__(self, "n_fovea", int(self.n_fovea))
        object.__setattr__(self, "_fovea_points", self._make_fovea_points())
        self._fovea_points.setflags(write=False)
        # the sample geometry, computed once (read-only: a grid is immutable)
        edges = self.r0 * np.exp(self.delta * np.arange(self.M + 1))
        radii = edges[:-1] * (1 + math.exp(self.delta)) / 2
        theta = (2 * np.arange(self.N) + 1) * math.pi / self.N
        derived = {"ring_edges": edges, "radii": radii, "u": np.log(radii), "theta": theta,
                   "points": radii[:, None] * np.exp(1j * theta[None, :])}
        for a in derived.values():
            a.setflags(write=False)
        object.__setattr__(self, "_derived", derived)

    # ------------------------------------------------------------------ constructors
    @classmethod
    def from_picture(
        cls,
        width: int,
        height: int,
        dots_per_unit: float,
        foveal_pixels: int,
        *,
        extent: str = "diagonal",
        r0_decimals: int | None = None,
    ) -> "RetinaGrid":
        """The paper's design rules (§6.2) for an A x B picture shown at K dots per unit length.

        pi r0^2 = N_f / K^2;  N = [2 pi r0 K + pi];  delta = ln(1 + 1/(r0 K));
        M = [ln(r_b / r0) / delta] with r_b = sqrt(A^2 + B^2) / (2K) (``extent="diagonal"``,
        as in the paper's Example) or min(A, B) / (2K) (``extent="inscribed"``).
        The outer radius is then r_M = r0 e^{M delta} (``rb``).
        ``r0_decimals``: round r0 to this many decimals before the other rules, as the paper's
        Example does (r0 = 2.427, giving its delta = 0.09804); default: unrounded (0.098053).
        """
        for name, v in (("width", width), ("height", height), ("foveal_pixels", foveal_pixels)):
            if int(v) != v or v < 1:
                raise ValueError(f"{name} must be a positive integer; got {v!r}")
        k = _positive("dots_per_unit", dots_per_unit)
        r0 = math.sqrt(foveal_pixels / math.pi) / k
        if r0_decimals is not None:
            if int(r0_decimals) != r0_decimals or not 0 <= r0_decimals <= 15:
                raise ValueError(f"r0_decimals must be an integer in 0..15 or None; got {r0_decimals!r}")
            r0 = round(r0, int(r0_decimals))
            if r0 <= 0:
                raise ValueError(f"r0 rounds to 0 at {r0_decimals} decimals; use more decimals")
        if extent == "diagonal":
            rb = math.hypot(width, height) / (2 * k)
        elif extent == "inscribed":
            rb = min(width, height) / (2 * k)
        else:
            raise ValueError(f"extent must be 'diagonal' or 'inscribed'; got {extent!r}")
        if r0 >= rb:
            raise ValueError(f"the fovea (r0 = {r0:.4g}) must be smaller than the picture (r_b = {rb:.4g})")
        n = int(round(2 * math.pi * r0 * k + math.pi))
        delta = math.log(1 + 1 / (r0 * k))
        m = int(round(math.log(rb / r0) / delta))
        return cls(r0=r0, delta=delta, M=max(m, 2), N=n, fovea_spacing=1 / k, n_fovea=int(foveal_pixels))

    @classmethod
    def from_field_of_view(cls, rb: float, r0: float, n_sectors: int = 64) -> "RetinaGrid":
        """A grid covering radii r0 .. rb (image-plane units) with ``n_sectors`` sectors.

        Uses the same rules as ``from_picture`` with the sampling density K implied by N
        (N = 2 pi r0 K + pi), so cells at the fovea's edge are about square and the foveal
        lattice has the same density: N_f = [pi r0^2 K^2].
        """
        rb = _positive("rb", rb)
        r0 = _positive("r0", r0)
        if r0 >= rb:
            raise ValueError(f"r0 = {r0:.4g} must be smaller than rb = {rb:.4g}")
        if int(n_sectors) != n_sectors or n_sectors < 4:
            raise ValueError(f"n_sectors must be an integer >= 4; got {n_sectors!r}")
        k = (n_sectors - math.pi) / (2 * math.pi * r0)
        delta = math.log(1 + 1 / (r0 * k))
        m = max(int(round(math.log(rb / r0) / delta)), 2)
        n_f = max(int(round(math.pi * r0**2 * k**2)), 1)
        return cls(r0=r0, delta=delta, M=m, N=int(n_sectors), fovea_spacing=1 / k, n_fovea=n_f)

    @classmethod
    def from_angles(cls, field_deg: float, fovea_deg: float = 1.0, n_sectors: int = 64) -> "RetinaGrid":
        """``from_field_of_view`` with eccentricities in degrees: rb = tan(field), r0 = tan(fovea)."""
        f = _positive("field_deg", field_deg)
        fo = _positive("fovea_deg", fovea_deg)
        if f >= 90:
            raise ValueError(f"field_deg must be below 90 degrees; got {field_deg}")
        return cls.from_field_of_view(math.tan(math.radians(f)), math.tan(math.radians(fo)), n_sectors)

    # ------------------------------------------------------------------ derived quantities
    @property
    def rb(self) -> float:
        """Outer radius r_M = r0 e^{M delta} (paper: r_b = r_M)."""
        return self.r0 * math.exp(self.M * self.delta)

    @property
    def T(self) -> float:
        """Log-radial period T = ln(r_b / r_a) = M delta (eq. ``l-p discret.``)."""
        return self.M * self.delta

    @property
    def n_periphery(self) -> int:
        return self.M * self.N

    @property
    def n_samples(self) -> int:
        """Foveal plus peripheral samples (2,664 in the paper's Example)."""
        return self.n_fovea + self.M * self.N

    @property
    def ring_edges(self) -> NDArray[np.float64]:
        """Radii r_k = r0 e^{k delta}, k = 0..M (M + 1 edges)."""
        return self._derived["ring_edges"]

    @property
    def radii(self) -> NDArray[np.float64]:
        """Sample radii at mid-ring, r_k + rho_k / 2 = r_k (1 + e^delta) / 2 (the paper's Example)."""
        return self._derived["radii"]

    @property
    def u(self) -> NDArray[np.float64]:
        """Log-radii of the samples, u_k = ln(radii[k]) (uniform, spacing delta)."""
        return self._derived["u"]

    @property
    def theta(self) -> NDArray[np.float64]:
        """Sample angles at mid-sector, theta_l + pi/N = (2l + 1) pi / N."""
        return self._derived["theta"]

    @property
    def points(self) -> NDArray[np.complex128]:
        """Peripheral sample positions z_{k,l}, shape (M, N)."""
        return self._derived["points"]

    @property
    def fovea_points(self) -> NDArray[np.complex128]:
        """Foveal sample positions: the N_f lattice points (spacing 1/K, centred on the fixation
        point between pixels) nearest the centre, ordered by radius then angle."""
        return self._fovea_points

    def _make_fovea_points(self) -> NDArray[np.complex128]:
        h = self.fovea_spacing
        n = int(math.ceil(math.sqrt(self.n_fovea / math.pi))) + 3
        idx = np.arange(-n, n) + 0.5
        z = (idx[None, :] + 1j * idx[::-1, None]).ravel() * h
        ang = np.mod(np.angle(z), 2 * np.pi)
        order = np.lexsort((ang, np.round(np.abs(z) / h, 9)))
        return z[order[: self.n_fovea]]

    def cell_areas(self) -> NDArray[np.float64]:
        """Area of each peripheral cell, shape (M,): (pi / N)(r_{k+1}^2 - r_k^2)."""
        e = self.ring_edges
        return math.pi / self.N * (e[1:] ** 2 - e[:-1] ** 2)

    def locate(self, z: NDArray[np.complex128]) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
        """Ring and sector indices (k, l) of points z; k is -1 inside the fovea and M beyond rb."""
        zz = np.asarray(z, dtype=complex)
        r = np.abs(zz)
        with np.errstate(divide="ignore"):
            k = np.floor(np.log(np.maximum(r, 1e-300) / self.r0) / self.delta).astype(np.intp)
        k = np.clip(k, -1, self.M)
        l = np.floor(np.mod(np.angle(zz), 2 * np.pi) / (2 * np.pi / self.N)).astype(np.intp) % self.N
        return k, l
