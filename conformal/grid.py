"""The exp-polar retina grid: a uniform foveal disc plus log-polar periphery (paper §5.1, §6.2).

Ring k of the periphery spans radii [r0 e^{k delta}, r0 e^{(k+1) delta}) and sector l spans
angles [2 pi l / N, 2 pi (l+1) / N); the foveal disc |z| < r0 is sampled on a square lattice
of spacing 1/K. All lengths are image-plane units (|z| = tan(eccentricity)).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import cast

import numpy as np
from numpy.typing import ArrayLike, NDArray

from . import checks

__all__ = ["RetinaGrid"]

#: Bounds on a grid's size (so that no argument allocates without limit). The paper's Example
#: has M = 37 rings, N = 64 sectors and 296 foveal samples; a retina for a 2048-pixel image
#: with a 30-degree fovea has N of about 5,300.
MAX_RINGS = 4096
MAX_SECTORS = 8192
MAX_PERIPHERAL_SAMPLES = 2**22  # M * N (the (M, N) complex sample positions: 64 MiB)
MAX_FOVEAL_SAMPLES = 2**20
#: The log-radial period T = M delta is at most this (r_b / r0 = e^T <= e^100).
MAX_LOG_PERIOD = 100.0
#: Lengths (r0, fovea spacing) in image-plane units (|z| = tan(eccentricity)) are at most this.
MAX_LENGTH = 1e6
#: Pictures given to ``from_picture`` are at most this many pixels per side.
MAX_PICTURE_SIDE = 65536


def _positive(name: str, value: float, hi: float | None = MAX_LENGTH) -> float:
    return checks.real(name, value, 0.0, hi, lo_open=True)


@dataclass(frozen=True)
class RetinaGrid:
    """Geometry of the exp-polar retina (the paper's eq. ``l-p discret.`` and §6.2 design rules).

    Attributes
    ----------
    r0 : radius of the foveal disc (= r_a, the removed disc), image-plane units, in (0, 1e6].
    delta : log-radial spacing, u_{k+1} - u_k, in (0, 100] with M delta <= 100.
    M : number of rings, an integer in [2, 4096].  N : number of sectors, an integer in [2, 8192];
        M N <= 2**22.
    fovea_spacing : spacing 1/K of the uniform foveal lattice, in (0, 1e6].
    n_fovea : number of foveal samples N_f, an integer in [1, 2**20].

    The bounds (module constants ``MAX_*``) keep every derived array bounded in memory.
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
        object.__setattr__(self, "r0", _positive("r0", self.r0))
        object.__setattr__(self, "delta", _positive("delta", self.delta, MAX_LOG_PERIOD))
        object.__setattr__(self, "fovea_spacing", _positive("fovea_spacing", self.fovea_spacing))
        object.__setattr__(self, "M", checks.integer("M (rings)", self.M, 2, MAX_RINGS))
        object.__setattr__(self, "N", checks.integer("N (sectors)", self.N, 2, MAX_SECTORS))
        object.__setattr__(self, "n_fovea", checks.integer("n_fovea", self.n_fovea, 1, MAX_FOVEAL_SAMPLES))
        if self.M * self.N > MAX_PERIPHERAL_SAMPLES:
            raise ValueError(
                f"M * N = {self.M} * {self.N} peripheral samples exceeds {MAX_PERIPHERAL_SAMPLES}; "
                "use fewer rings or sectors"
            )
        if self.M * self.delta > MAX_LOG_PERIOD:
            raise ValueError(
                f"the log-radial period M * delta = {self.M * self.delta:.4g} exceeds {MAX_LOG_PERIOD:g} "
                "(r_b / r0 = e^(M delta)); use fewer rings or a smaller delta"
            )
        object.__setattr__(self, "_fovea_points", self._make_fovea_points())
        self._fovea_points.setflags(write=False)
        # the sample geometry, computed once (read-only: a grid is immutable)
        edges = self.r0 * np.exp(self.delta * np.arange(self.M + 1))
        radii = edges[:-1] * (1 + math.exp(self.delta)) / 2
        theta = (2 * np.arange(self.N) + 1) * math.pi / self.N
        derived = {
            "ring_edges": edges,
            "radii": radii,
            "u": np.log(radii),
            "theta": theta,
            "points": radii[:, None] * np.exp(1j * theta[None, :]),
        }
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
    ) -> RetinaGrid:
        """The paper's design rules (§6.2) for an A x B picture shown at K dots per unit length.

        pi r0^2 = N_f / K^2;  N = [2 pi r0 K + pi];  delta = ln(1 + 1/(r0 K));
        M = [ln(r_b / r0) / delta] with r_b = sqrt(A^2 + B^2) / (2K) (``extent="diagonal"``,
        as in the paper's Example) or min(A, B) / (2K) (``extent="inscribed"``).
        The outer radius is then r_M = r0 e^{M delta} (``rb``).
        ``r0_decimals``: round r0 to this many decimals before the other rules, as the paper's
        Example does (r0 = 2.427, giving its delta = 0.09804); default: unrounded (0.098053).
        """
        width = checks.integer("width", width, 1, MAX_PICTURE_SIDE)
        height = checks.integer("height", height, 1, MAX_PICTURE_SIDE)
        foveal_pixels = checks.integer("foveal_pixels", foveal_pixels, 1, MAX_FOVEAL_SAMPLES)
        k = _positive("dots_per_unit", dots_per_unit, 1e9)
        extent = checks.choice("extent", extent, ("diagonal", "inscribed"))
        r0 = math.sqrt(foveal_pixels / math.pi) / k
        if r0_decimals is not None:
            r0_decimals = checks.integer("r0_decimals", r0_decimals, 0, 15, hint="or None")
            r0 = round(r0, r0_decimals)
            if r0 <= 0:
                raise ValueError(f"r0 rounds to 0 at {r0_decimals} decimals; use more decimals")
        if extent == "diagonal":
            rb = math.hypot(width, height) / (2 * k)
        else:
            rb = min(width, height) / (2 * k)
        if r0 >= rb:
            raise ValueError(f"the fovea (r0 = {r0:.4g}) must be smaller than the picture (r_b = {rb:.4g})")
        n = int(round(2 * math.pi * r0 * k + math.pi))
        delta = math.log(1 + 1 / (r0 * k))
        m = int(round((math.log(rb) - math.log(r0)) / delta))
        return cls(r0=r0, delta=delta, M=max(m, 2), N=n, fovea_spacing=1 / k, n_fovea=foveal_pixels)

    @classmethod
    def from_field_of_view(cls, rb: float, r0: float, n_sectors: int = 64) -> RetinaGrid:
        """A grid covering radii r0 .. rb (image-plane units) with ``n_sectors`` sectors.

        Uses the same rules as ``from_picture`` with the sampling density K implied by N
        (N = 2 pi r0 K + pi), so cells at the fovea's edge are about square and the foveal
        lattice has the same density: N_f = [pi r0^2 K^2].
        """
        rb = _positive("rb", rb, None)
        r0 = _positive("r0", r0)
        if r0 >= rb:
            raise ValueError(f"r0 = {r0:.4g} must be smaller than rb = {rb:.4g}")
        n_sectors = checks.integer("n_sectors", n_sectors, 4, MAX_SECTORS)
        k = (n_sectors - math.pi) / (2 * math.pi * r0)
        delta = math.log(1 + 1 / (r0 * k))
        if not (math.isfinite(k) and delta > 0):  # a subnormal r0: the density N / r0 overflows
            raise ValueError(
                f"r0 = {r0:.4g} is too small: the sampling density it implies ({n_sectors} sectors "
                f"around it) overflows a float; use r0 >= 1e-300"
            )
        m = max(int(round((math.log(rb) - math.log(r0)) / delta)), 2)
        n_f = max(int(round(math.pi * (r0 * k) ** 2)), 1)
        return cls(r0=r0, delta=delta, M=m, N=n_sectors, fovea_spacing=1 / k, n_fovea=n_f)

    @classmethod
    def from_angles(cls, field_deg: float, fovea_deg: float = 1.0, n_sectors: int = 64) -> RetinaGrid:
        """``from_field_of_view`` with eccentricities in degrees: rb = tan(field), r0 = tan(fovea)."""
        f = checks.real("field_deg", field_deg, 0.0, 90.0, lo_open=True, hi_open=True)
        fo = checks.real("fovea_deg", fovea_deg, 0.0, 90.0, lo_open=True, hi_open=True)
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
        # cast: numpy's stubs type float + 1j * float as a float array
        z = cast(NDArray[np.complex128], (idx[None, :] + 1j * idx[::-1, None]).ravel() * h)
        ang = np.mod(np.angle(z), 2 * np.pi)
        order = np.lexsort((ang, np.round(np.abs(z) / h, 9)))
        return z[order[: self.n_fovea]]

    def cell_areas(self) -> NDArray[np.float64]:
        """Area of each peripheral cell, shape (M,): (pi / N)(r_{k+1}^2 - r_k^2)."""
        e = self.ring_edges
        return math.pi / self.N * (e[1:] ** 2 - e[:-1] ** 2)

    def locate(self, z: ArrayLike) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
        """Ring and sector indices (k, l) of finite points z; k is -1 inside the fovea and M beyond rb.

        NaN or infinite points raise ``ValueError`` (they lie in no cell)."""
        zz = checks.array("z", z, kinds="biufc").astype(complex)
        r = np.abs(zz)
        with np.errstate(divide="ignore"):
            k = np.floor(np.log(np.maximum(r, 1e-300) / self.r0) / self.delta).astype(np.intp)
        k = np.clip(k, -1, self.M)
        l = np.floor(np.mod(np.angle(zz), 2 * np.pi) / (2 * np.pi / self.N)).astype(np.intp) % self.N
        return k, l
