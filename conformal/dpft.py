"""The discrete projective Fourier transform (paper §5.1) and off-grid rendering from it.

Samples are (M, N[, C]) arrays of f(z_{k,l}) on ``RetinaGrid.points``, with
u_k = ``grid.u[k]`` and theta_l = ``grid.theta[l]``. With f_{k,l} = (2 pi T / M N) f(z_{k,l})
(eq. ``pixels``),

    dpft:  F_{m,n} = sum_{k,l} f_{k,l} (z/|z|)^{-n} |z|^{-i 2 pi m / T + 1}        (eq. ``dpft``)
    idpft: f_{k,l} = (1/MN) sum_{m,n} F_{m,n} (z/|z|)^{n} |z|^{i 2 pi m / T - 1}   (eq. ``idpft``)

computed by FFT in log-polar coordinates (eqs. ``lpdft``, ``ilpdft``): the z-form differs
from the log-polar form only by the phase e^{-i (2 pi m u_0 / T + n theta_0)}, so F_{m,n}
approximates the PFT f^(2 pi m / T, n) of eq. ``sft`` itself.

Off-grid values (eq. ``dppcc'``) are a Fourier series in (u, theta); it is evaluated with
signed frequencies m in [-M/2, M/2), n in [-N/2, N/2) and the phase origin at the first
sample (u_0, theta_0), by finufft's type-2 NUFFT, with a direct sum as the reference.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .geometry import act, inverse
from .grid import RetinaGrid

__all__ = [
    "dpft",
    "idpft",
    "dpft_direct",
    "idpft_direct",
    "pft_frequencies",
    "OffGridEvaluator",
    "evaluate",
    "evaluate_direct",
    "transform",
    "warp",
]


def _check_samples(a: ArrayLike, grid: RetinaGrid, name: str, complex_ok: bool = False) -> NDArray:
    if not isinstance(grid, RetinaGrid):
        raise ValueError(f"grid must be a RetinaGrid; got {type(grid).__name__}")
    x = np.asarray(a)
    if x.dtype.kind not in ("biufc" if complex_ok else "biuf"):
        raise ValueError(f"{name} must be a {'complex' if complex_ok else 'real'} numeric array; got dtype {x.dtype}")
    if x.ndim not in (2, 3) or x.shape[:2] != (grid.M, grid.N):
        raise ValueError(f"{name} must have shape (M, N[, C]) = ({grid.M}, {grid.N}[, C]); got {x.shape}")
    if not np.all(np.isfinite(x)):
        raise ValueError(f"{name} contains NaN or infinite values")
    return x


def _expand(v: NDArray, ndim: int) -> NDArray:
    return v.reshape(v.shape + (1,) * (ndim - v.ndim))


def _weight(grid: RetinaGrid) -> float:
    return 2 * math.pi * grid.T / (grid.M * grid.N)


def _phase(grid: RetinaGrid) -> NDArray[np.complex128]:
    """e^{-i (2 pi m u_0 / T + n theta_0)} for m = 0..M-1, n = 0..N-1, shape (M, N)."""
    m = np.arange(grid.M)[:, None]
    n = np.arange(grid.N)[None, :]
    return np.exp(-1j * (2 * math.pi * m * grid.u[0] / grid.T + n * grid.theta[0]))


def pft_frequencies(grid: RetinaGrid) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """The PFT arguments (s_m, n) that F_{m,n} approximates: s_m = 2 pi m / T, m = 0..M-1."""
    return 2 * math.pi * np.arange(grid.M) / grid.T, np.arange(grid.N)


def dpft(samples: ArrayLike, grid: RetinaGrid) -> NDArray[np.complex128]:
    """(M, N)-point DPFT of peripheral samples f(z_{k,l}) by FFT (eqs. ``lpdft``, ``dpft``).

    Includes the e^{u_k} weight and the factor 2 pi T / (M N) of eq. ``pixels``.
    Accepts (M, N) or (M, N, C); transforms over the first two axes.
    """
    f = _check_samples(samples, grid, "samples")
    weighted = _weight(grid) * _expand(np.exp(grid.u), f.ndim) * f
    return np.fft.fft2(weighted, axes=(0, 1)) * _expand(_phase(grid), f.ndim)


def idpft(coeffs: ArrayLike, grid: RetinaGrid, *, real: bool = True) -> NDArray:
    """Inverse DPFT by FFT (eqs. ``ilpdft``, ``idpft``): the samples f(z_{k,l}) back.

    With ``real=True`` (default) returns the real part, as for real images.
    """
    F = _check_samples(coeffs, grid, "coeffs", complex_ok=True)
    lp = np.fft.ifft2(F * _expand(np.conj(_phase(grid)), F.ndim), axes=(0, 1))
    f = lp * _expand(np.exp(-grid.u), F.ndim) / _weight(grid)
    return f.real if real else f


def dpft_direct(samples: ArrayLike, grid: RetinaGrid) -> NDArray[np.complex128]:
    """Eq. ``dpft`` as a direct O((MN)^2) sum; the slow reference for ``dpft``."""
    f = _check_samples(samples, grid, "samples")
    z = grid.points.ravel()
    m = np.arange(grid.M)
    n = np.arange(grid.N)
    r, ang = np.abs(z), np.angle(z)
    # kernel[m, n, j] = (z_j/|z_j|)^{-n} |z_j|^{-i 2 pi m / T + 1}
    kern = np.exp(-1j * n[None, :, None] * ang[None, None, :]) * np.exp(
        (-1j * 2 * math.pi * m[:, None, None] / grid.T + 1) * np.log(r)[None, None, :]
    )
    fk = _weight(grid) * f.reshape(grid.M * grid.N, -1)
    out = np.tensordot(kern, fk, axes=([2], [0]))
    return out.reshape(f.shape).astype(complex)


def idpft_direct(coeffs: ArrayLike, grid: RetinaGrid) -> NDArray[np.complex128]:
    """Eq. ``idpft`` as a direct sum (complex result); the slow reference for ``idpft``."""
    F = _check_samples(coeffs, grid, "coeffs", complex_ok=True)
    z = grid.points.ravel()
    m = np.arange(grid.M)
    n = np.arange(grid.N)
    r, ang = np.abs(z), np.angle(z)
    kern = np.exp(1j * n[None, None, :] * ang[:, None, None]) * np.exp(
        (1j * 2 * math.pi * m[None, :, None] / grid.T - 1) * np.log(r)[:, None, None]
    )
    out = np.tensordot(kern, F.reshape(grid.M, grid.N, -1), axes=([1, 2], [0, 1])) / (grid.M * grid.N)
    return (out / _weight(grid)).reshape(F.shape)


# ---------------------------------------------------------------------- off-grid evaluation
def _check_points(z: ArrayLike) -> NDArray[np.complex128]:
    zz = np.asarray(z)
    if zz.dtype.kind not in "biufc":
        raise ValueError(f"points must be numeric; got dtype {zz.dtype}")
    zz = zz.astype(complex)
    if not np.all(np.isfinite(zz)):
        raise ValueError("points contain NaN or infinity; the log-polar series is not defined there")
    if np.any(zz == 0):
        raise ValueError("points contain z = 0, where log-polar coordinates are singular")
    return zz


def _centred(coeffs: NDArray, grid: RetinaGrid) -> NDArray[np.complex128]:
    """Origin-relative coefficients A (eq. ``lpdft``), fft-shifted to signed frequencies."""
    A = coeffs * _expand(np.conj(_phase(grid)), coeffs.ndim)
    return np.fft.fftshift(A, axes=(0, 1))


def _signed(n: int) -> NDArray[np.int64]:
    return np.fft.fftshift(np.fft.fftfreq(n, 1.0 / n)).astype(np.int64)


class OffGridEvaluator:
    """A plan for evaluating eq. ``dppcc'`` at fixed points z' from any coefficients.

    Build it once per set of points (``setpts`` once), then call it per frame:
    ``values = OffGridEvaluator(grid, zp)(coeffs)``. ``inside`` marks points whose
    log-radius lies within the sampled annulus (half a ring beyond the first and last
    sample centres); outside it the periodic series is not the image (the paper's wrap).
    """

    def __init__(self, grid: RetinaGrid, points: ArrayLike, *, eps: float = 1e-9) -> None:
        import finufft

        zp = _check_points(points)
        self.grid = grid
        self.shape = zp.shape
        zf = zp.ravel()
        u = np.log(np.abs(zf))
        self.u = u
        x = np.mod(2 * math.pi * (u - grid.u[0]) / grid.T + math.pi, 2 * math.pi) - math.pi
        y = np.mod(np.angle(zf) - grid.theta[0] + math.pi, 2 * math.pi) - math.pi
        self.inside = ((u >= grid.u[0] - grid.delta / 2) & (u <= grid.u[-1] + grid.delta / 2)).reshape(zp.shape)
        self._x, self._y = x, y
        self._eps = eps
        self._plans: dict[int, object] = {}
        self._finufft = finufft

    def _plan(self, n_trans: int):
        if n_trans not in self._plans:
            p = self._finufft.Plan(
                2, (self.grid.M, self.grid.N), n_trans=n_trans, eps=self._eps, isign=1, modeord=0, nthreads=1
            )
            p.setpts(self._x, self._y)
            self._plans[n_trans] = p
        return self._plans[n_trans]

    def __call__(self, coeffs: ArrayLike, *, real: bool = True) -> NDArray:
        F = _check_samples(coeffs, self.grid, "coeffs", complex_ok=True)
        A = _centred(F.astype(complex), self.grid)
        chans = A.shape[2:]
        c = int(np.prod(chans)) if chans else 1
        fk = np.ascontiguousarray(np.moveaxis(A.reshape(self.grid.M, self.grid.N, c), 2, 0))
        vals = self._plan(c).execute(fk if c > 1 else fk[0])
        vals = np.asarray(vals).reshape(c, -1)
        out = vals * np.exp(-self.u)[None, :] / (self.grid.M * self.grid.N * _weight(self.grid))
        out = np.moveaxis(out, 0, -1).reshape(self.shape + chans)
        return out.real if real else out


def evaluate(coeffs: ArrayLike, grid: RetinaGrid, points: ArrayLike, *, real: bool = True) -> NDArray:
    """f(z') at arbitrary image-plane points from DPFT coefficients alone (eq. ``dppcc'``), via NUFFT.

    Returns shape ``points.shape + (C,)`` for (M, N, C) coefficients. See ``OffGridEvaluator``
    for reuse and for the ``inside`` mask.
    """
    return OffGridEvaluator(grid, points)(coeffs, real=real)


def evaluate_direct(coeffs: ArrayLike, grid: RetinaGrid, points: ArrayLike, *, real: bool = True) -> NDArray:
    """The same series as ``evaluate`` by a direct sum over all (m, n); the slow reference."""
    F = _check_samples(coeffs, grid, "coeffs", complex_ok=True)
    zp = _check_points(points)
    A = _centred(F.astype(complex), grid)
    zf = zp.ravel()
    u, th = np.log(np.abs(zf)), np.angle(zf)
    m, n = _signed(grid.M), _signed(grid.N)
    em = np.exp(1j * 2 * math.pi * np.outer(u - grid.u[0], m) / grid.T)  # (P, M)
    en = np.exp(1j * np.outer(th - grid.theta[0], n))  # (P, N)
    Ar = A.reshape(grid.M, grid.N, -1)
    vals = np.einsum("pm,mnc,pn->pc", em, Ar, en)
    out = vals * np.exp(-u)[:, None] / (grid.M * grid.N * _weight(grid))
    out = out.reshape(zp.shape + F.shape[2:])
    return out.real if real else out


def transform(coeffs: ArrayLike, grid: RetinaGrid, g: ArrayLike, *, real: bool = True) -> NDArray:
    """Samples of the transformed image f(g^{-1} . z) on the grid, from coefficients alone (eq. ``dppcc'``)."""
    return evaluate(coeffs, grid, act(inverse(g), grid.points), real=real)


def warp(coeffs: ArrayLike, grid: RetinaGrid, point_map, *, real: bool = True) -> NDArray:
    """Samples of f(w(z)) on the grid for any point map ``w`` (e.g. a homography), from coefficients."""
    return evaluate(coeffs, grid, point_map(grid.points), real=real)
