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
Because e^u f is not periodic in u, the paper's series rings between rings; the default
evaluates the evenly extended series of f instead (see ``OffGridEvaluator``).
"""

from __future__ import annotations

import math
from functools import cached_property, lru_cache
from typing import cast

import numpy as np
import scipy.fft
from numpy.typing import ArrayLike, DTypeLike, NDArray

from . import checks
from .geometry import act, inverse
from .grid import RetinaGrid
from .kernels import series_table

__all__ = [
    "dpft",
    "dpft_prechecked",
    "dpft_tables",
    "dpft_weight",
    "mirror_map",
    "idpft",
    "dpft_direct",
    "idpft_direct",
    "pft_frequencies",
    "OffGridEvaluator",
    "EXTENSIONS",
    "evaluate",
    "evaluate_direct",
    "transform",
    "warp",
]


def _check_grid(grid: RetinaGrid, name: str = "grid") -> RetinaGrid:
    if not isinstance(grid, RetinaGrid):
        raise checks.InputTypeError(f"{name} must be a RetinaGrid; got {type(grid).__name__}")
    return grid


def _check_samples(a: ArrayLike, grid: RetinaGrid, name: str, complex_ok: bool = False) -> NDArray:
    _check_grid(grid)
    x = checks.array(name, a, kinds="biufc" if complex_ok else "biuf", ndim=(2, 3))
    if x.shape[:2] != (grid.M, grid.N):
        raise ValueError(f"{name} must have shape (M, N[, C]) = ({grid.M}, {grid.N}[, C]); got {x.shape}")
    if x.dtype == np.float16:  # scipy.fft and numba work in single or double precision
        x = x.astype(np.float32)
    return x


#: The direct (reference) sums build an (M N) x (M N) kernel: at most this many samples M N.
MAX_DIRECT_SAMPLES = 3000


def _check_direct(grid: RetinaGrid) -> None:
    if grid.M * grid.N > MAX_DIRECT_SAMPLES:
        raise ValueError(
            f"the direct sum builds an (M N)^2 kernel; M N = {grid.M * grid.N} exceeds "
            f"{MAX_DIRECT_SAMPLES}: use the FFT version (dpft / idpft) for this grid"
        )


def _expand(v: NDArray, ndim: int) -> NDArray:
    return v.reshape(v.shape + (1,) * (ndim - v.ndim))


def dpft_weight(grid: RetinaGrid) -> float:
    """The DPFT's quadrature weight ``2 pi T / (M N)`` of ``grid`` (eq. ``dpft``)."""
    return 2 * math.pi * grid.T / (grid.M * grid.N)


@lru_cache(maxsize=32)
def dpft_tables(grid: RetinaGrid) -> tuple[NDArray, NDArray, NDArray, NDArray]:
    """Per-grid constants, computed once: phase (M, N), its conjugate, e^{u_k}, e^{-u_k}."""
    m = np.arange(grid.M)[:, None]
    n = np.arange(grid.N)[None, :]
    phase = np.exp(-1j * (2 * math.pi * m * grid.u[0] / grid.T + n * grid.theta[0]))
    out = (phase, np.conj(phase), np.exp(grid.u), np.exp(-grid.u))
    for a in out:
        a.setflags(write=False)
    return out


def _phase(grid: RetinaGrid) -> NDArray[np.complex128]:
    """e^{-i (2 pi m u_0 / T + n theta_0)} for m = 0..M-1, n = 0..N-1, shape (M, N)."""
    return dpft_tables(grid)[0]


def pft_frequencies(grid: RetinaGrid) -> tuple[NDArray[np.float64], NDArray[np.intp]]:
    """The PFT arguments (s_m, n) that F_{m,n} approximates: s_m = 2 pi m / T, m = 0..M-1."""
    _check_grid(grid)
    s_m = cast(NDArray[np.float64], 2 * math.pi * np.arange(grid.M) / grid.T)  # numpy's stubs: floating[Any]
    return s_m, np.arange(grid.N)


def dpft(samples: ArrayLike, grid: RetinaGrid) -> NDArray[np.complex128]:
    """(M, N)-point DPFT of peripheral samples f(z_{k,l}) by FFT (eqs. ``lpdft``, ``dpft``).

    Includes the e^{u_k} weight and the factor 2 pi T / (M N) of eq. ``pixels``.
    Accepts (M, N) or (M, N, C); transforms over the first two axes.
    """
    return dpft_prechecked(_check_samples(samples, grid, "samples"), grid)


def dpft_prechecked(f: NDArray, grid: RetinaGrid) -> NDArray[np.complex128]:
    """``dpft`` of samples the caller has already checked (a hot path's entry: no validation here;
    ``_check_samples``: (M, N[, C]) float32/float64 or integer)."""
    weighted = dpft_weight(grid) * _expand(dpft_tables(grid)[2], f.ndim) * f
    return scipy.fft.fft2(weighted, axes=(0, 1)) * _expand(_phase(grid), f.ndim)


def idpft(coeffs: ArrayLike, grid: RetinaGrid, *, real: bool = True) -> NDArray:
    """Inverse DPFT by FFT (eqs. ``ilpdft``, ``idpft``): the samples f(z_{k,l}) back.

    With ``real=True`` (default) returns the real part, as for real images.
    """
    real = checks.flag("real", real)
    F = _check_samples(coeffs, grid, "coeffs", complex_ok=True)
    lp = scipy.fft.ifft2(F * _expand(dpft_tables(grid)[1], F.ndim), axes=(0, 1))
    f = lp * _expand(dpft_tables(grid)[3], F.ndim) / dpft_weight(grid)
    return f.real if real else f


def dpft_direct(samples: ArrayLike, grid: RetinaGrid) -> NDArray[np.complex128]:
    """Eq. ``dpft`` as a direct O((MN)^2) sum; the slow reference for ``dpft`` (M N <= 3000)."""
    f = _check_samples(samples, grid, "samples")
    _check_direct(grid)
    z = grid.points.ravel()
    m = np.arange(grid.M)
    n = np.arange(grid.N)
    r, ang = np.abs(z), np.angle(z)
    # kernel[m, n, j] = (z_j/|z_j|)^{-n} |z_j|^{-i 2 pi m / T + 1}
    kern = np.exp(-1j * n[None, :, None] * ang[None, None, :]) * np.exp(
        (-1j * 2 * math.pi * m[:, None, None] / grid.T + 1) * np.log(r)[None, None, :]
    )
    fk = dpft_weight(grid) * f.reshape(grid.M * grid.N, -1)
    out = np.tensordot(kern, fk, axes=([2], [0]))
    return out.reshape(f.shape).astype(complex)


def idpft_direct(coeffs: ArrayLike, grid: RetinaGrid) -> NDArray[np.complex128]:
    """Eq. ``idpft`` as a direct sum (complex result); the slow reference for ``idpft`` (M N <= 3000)."""
    F = _check_samples(coeffs, grid, "coeffs", complex_ok=True)
    _check_direct(grid)
    z = grid.points.ravel()
    m = np.arange(grid.M)
    n = np.arange(grid.N)
    r, ang = np.abs(z), np.angle(z)
    kern = np.exp(1j * n[None, None, :] * ang[:, None, None]) * np.exp(
        (1j * 2 * math.pi * m[None, :, None] / grid.T - 1) * np.log(r)[:, None, None]
    )
    out = np.tensordot(kern, F.reshape(grid.M, grid.N, -1), axes=([1, 2], [0, 1])) / (grid.M * grid.N)
    return cast(NDArray[np.complex128], (out / dpft_weight(grid)).reshape(F.shape))  # stubs: tensordot -> 0-d


# ---------------------------------------------------------------------- off-grid evaluation
def _check_points(z: ArrayLike, name: str = "points") -> NDArray[np.complex128]:
    zz = checks.array(name, z, kinds="biufc", finite=False).astype(complex)
    if not np.all(np.isfinite(zz)):
        raise ValueError(f"{name} contain NaN or infinity; the log-polar series is not defined there")
    if np.any(zz == 0):
        raise ValueError("points contain z = 0, where log-polar coordinates are singular")
    return zz


def _centred(coeffs: NDArray, grid: RetinaGrid) -> NDArray[np.complex128]:
    """Origin-relative coefficients A (eq. ``lpdft``), fft-shifted to signed frequencies."""
    A = coeffs * _expand(dpft_tables(grid)[1], coeffs.ndim)
    return np.fft.fftshift(A, axes=(0, 1))


def _signed(n: int) -> NDArray[np.int64]:
    return np.fft.fftshift(np.fft.fftfreq(n, 1.0 / n)).astype(np.int64)


def _exp_ramp(x: NDArray[np.float64], n: int) -> NDArray[np.complex128]:
    """e^{i k x} for the signed frequencies k of ``_signed(n)``, shape (len(x), n), by products."""
    step = np.exp(1j * x)[:, None]
    out = np.repeat(step, n, axis=1)
    out[:, 0] = np.exp(1j * _signed(n)[0] * x)
    return np.cumprod(out, axis=1)


EXTENSIONS = ("mirror", "paper")


def _series(F: NDArray, grid: RetinaGrid, extension: str) -> NDArray[np.complex128]:
    """Centred (signed-frequency) series coefficients, shape (L, N, C), of the chosen extension."""
    if extension == "paper":
        return _centred(F.astype(complex), grid)
    f = idpft(F, grid, real=False)
    g = np.concatenate([f, f[::-1]], axis=0)  # even reflection about both annulus edges
    return np.fft.fftshift(np.fft.fft2(g, axes=(0, 1)), axes=(0, 1))


def _check_extension(extension: str) -> None:
    checks.choice("extension", extension, EXTENSIONS)


class OffGridEvaluator:
    """A plan for evaluating the image at fixed points z' from any DPFT coefficients (eq. ``dppcc'``).

    Build it once per set of points, then call it per frame:
    ``values = OffGridEvaluator(grid, zp)(coeffs)``.

    ``extension`` chooses the periodic extension in log-radius that the Fourier series
    interpolates. ``"paper"`` is eq. ``dppcc'`` itself: the series of e^u f with period T.
    e^u f jumps by e^T across the seam, so between rings this series rings (Gibbs): a
    constant image evaluated half a ring off the grid comes back between -0.4 and 1.7 on a
    15-ring grid. ``"mirror"`` (default) evaluates the series of f extended evenly about both
    edges of the annulus (period 2T, computed from the same coefficients by one inverse
    FFT): continuous across the seams, so a constant stays constant and smooth images are
    interpolated smoothly. In the angle both are the exact periodic series. On the grid both
    reproduce the samples exactly.

    ``method``: ``"nufft"`` (finufft type 2, plan built once), ``"matrix"`` (exact separable
    sum with precomputed factors, faster for small grids) or ``"auto"`` (by size).
    ``dtype``: ``np.float64`` (default) or ``np.float32``, the precision of the matrix path's
    factor tables and sums for real images with the mirror extension (about 1e-6 relative
    instead of 1e-12; a few times faster to build, since single-precision cosines are
    vectorised). The NUFFT and complex paths always run in double precision.
    ``inside`` marks points whose log-radius lies within the sampled annulus (half a ring
    beyond the first and last sample centres); outside it the series is not the image.
    ``eps``: the NUFFT's requested relative precision, in [1e-15, 1e-2].
    """

    def __init__(
        self,
        grid: RetinaGrid,
        points: ArrayLike,
        *,
        eps: float = 1e-9,
        method: str = "auto",
        extension: str = "mirror",
        dtype: DTypeLike = np.float64,
    ) -> None:
        _check_grid(grid)
        checks.choice("method", method, ("auto", "nufft", "matrix"))
        dt = _check_float_dtype(dtype)
        self.dtype = dt
        _check_extension(extension)
        eps = checks.real("eps", eps, 1e-15, 1e-2)
        zp = _check_points(points)
        self.grid = grid
        self.extension = extension
        self.shape = zp.shape
        self._rows = grid.M if extension == "paper" else 2 * grid.M
        zf = zp.ravel()
        u = np.log(np.abs(zf))
        self.u = u
        y = np.mod(np.angle(zf) - grid.theta[0] + math.pi, 2 * math.pi) - math.pi
        self.inside = ((u >= grid.u[0] - grid.delta / 2) & (u <= grid.u[-1] + grid.delta / 2)).reshape(zp.shape)
        self._y = y
        self._eps = eps
        self._plans: dict[int, object] = {}
        if method == "auto":  # small problems: dense factor matrices beat NUFFT's fixed cost
            per_point = grid.M * (grid.N // 2 + 1) if extension == "mirror" else self._rows * grid.N
            # single-precision tables are ~10x cheaper to build (vectorised cosines)
            limit = 1_500_000 if (dt == np.float32 and extension == "mirror") else 150_000
            method = "matrix" if zf.size * per_point <= limit else "nufft"
        self.method = method
        self._em: NDArray[np.complex128] | None = None
        self._en: NDArray[np.complex128] | None = None
        if method == "matrix" and extension == "mirror":
            self._cu, self._cs = _mirror_tables(grid, u, y, dt)

    @cached_property
    def _x(self) -> NDArray[np.float64]:
        """Log-radius of the points as an angle of the series' period (NUFFT and complex paths)."""
        period = self.grid.delta * self._rows
        return np.mod(2 * math.pi * (self.u - self.grid.u[0]) / period + math.pi, 2 * math.pi) - math.pi

    @cached_property
    def _scale(self) -> NDArray[np.float64]:
        """Per-point factor of the complex series: e^{-u} / (M N w) (paper) or 1 / (rows N) (mirror)."""
        g = self.grid
        if self.extension == "paper":
            return np.exp(-self.u) / (g.M * g.N * dpft_weight(g))
        return np.full(self.u.shape, 1.0 / (self._rows * g.N))

    def _plan(self, n_trans: int):
        if n_trans not in self._plans:
            import finufft

            p = finufft.Plan(
                2, (self._rows, self.grid.N), n_trans=n_trans, eps=self._eps, isign=1, modeord=0, nthreads=1
            )
            p.setpts(self._x, self._y)
            self._plans[n_trans] = p
        return self._plans[n_trans]

    def __call__(self, coeffs: ArrayLike, *, real: bool = True) -> NDArray:
        real = checks.flag("real", real)
        F = _check_samples(coeffs, self.grid, "coeffs", complex_ok=True)
        if real and self.method == "matrix" and self.extension == "mirror":
            return self._real_mirror(F)
        B = _series(F, self.grid, self.extension)
        chans = B.shape[2:]
        c = int(np.prod(chans)) if chans else 1
        rows, n = self._rows, self.grid.N
        if self.method == "matrix":
            if self._em is None or self._en is None:  # separable exact sum: e^{i m x} and e^{i n y}, signed m, n
                self._em, self._en = _exp_ramp(self._x, rows), _exp_ramp(self._y, n)
            t = (self._en @ B.reshape(rows, n, c).transpose(1, 0, 2).reshape(n, rows * c)).reshape(-1, rows, c)
            vals = (t * self._em[:, :, None]).sum(axis=1).T
        else:
            fk = np.ascontiguousarray(np.moveaxis(B.reshape(rows, n, c), 2, 0))
            vals = self._plan(c).execute(fk if c > 1 else fk[0])
            vals = np.asarray(vals).reshape(c, -1)
        out = np.moveaxis(vals * self._scale[None, :], 0, -1).reshape(self.shape + chans)
        return out.real if real else out

    def _real_mirror(self, F: NDArray) -> NDArray[np.float64]:
        """The mirror series for real images: DCT-II in u, real FFT in theta (a quarter of the work).

        value[p, c] = sum_m cu[m, p] sum_n (cos(n y_p) Re D[m, n, c] - sin(n y_p) Im D[m, n, c])
        with D the weighted DCT-II (in u) of the real FFT (in theta) of the samples
        (``_mirror_series``): one real matrix product over n, then a sum over m along rows of
        length P (points last: contiguous).
        """
        chans = F.shape[2:]
        c = int(np.prod(chans)) if chans else 1
        m = self.grid.M
        D = _mirror_series(F.reshape(1, m, self.grid.N, c), self.grid, self.dtype)[0]  # (M C, 2 nh)
        t = (D @ self._cs).reshape(m, c, -1)  # (M, C, P)
        t *= self._cu[:, None, :]
        vals = t.sum(axis=0).T.astype(np.float64)  # (P, C)
        return vals.reshape(self.shape + chans)


def _check_float_dtype(dtype) -> np.dtype:
    """np.float64 or np.float32 (also as their names or dtypes); anything else raises."""
    try:
        dt = np.dtype(dtype) if dtype is not None else None
    except TypeError:
        dt = None
    if dt is None or dt not in (np.dtype(np.float64), np.dtype(np.float32)):  # (np.dtype(float) == None!)
        raise checks.InputTypeError(f"dtype must be float64 or float32 (np.float64 or np.float32); got {dtype!r}")
    return dt


@lru_cache(maxsize=32)
def mirror_map(grid: RetinaGrid) -> tuple[NDArray, NDArray, NDArray, NDArray]:
    """The linear map from DPFT coefficients F to the weighted mirror-series coefficients, per grid.

    The series of the samples f = Re idpft(F) takes their real FFT in theta and their DCT-II in
    u. Composed: with H = A F (A = DCT-II . diag(e^{-u_k} / w) . IDFT_M . diag(conj alpha_m),
    alpha_m beta_n the DPFT phase of eq. ``dpft``), D[m, q] = (H[m, q] conj(beta_q) +
    conj(H[m, -q]) beta_{-q}) / 2 for q = 0..N/2, with the series weights (1/M, 1/2M at m = 0;
    2/N, 1/N at q = 0 and N/2) folded in. Returns A, the two q-factors and the indices -q mod N.
    """
    m_, n_ = grid.M, grid.N
    nh = n_ // 2 + 1
    k = np.arange(m_)
    dct = 2 * np.cos(np.pi * np.outer(k, 2 * k + 1) / (2 * m_))  # scipy's DCT-II, rows m, columns k
    idft = np.exp(2j * np.pi * np.outer(k, k) / m_) / m_  # rows k, columns m'
    alpha = np.exp(-2j * np.pi * k * grid.u[0] / grid.T)
    beta = np.exp(-1j * np.arange(n_) * grid.theta[0])
    scale = dpft_tables(grid)[3] / dpft_weight(grid)  # e^{-u_k} / w
    wm = np.full(m_, 1.0 / m_)
    wm[0] *= 0.5
    A = wm[:, None] * (dct @ (scale[:, None] * idft)) * np.conj(alpha)[None, :]
    wn = np.full(nh, 2.0 / n_)
    wn[0] = 1.0 / n_
    if n_ % 2 == 0:
        wn[-1] = 1.0 / n_
    q = np.arange(nh)
    neg = (-q) % n_
    out = (A, wn * np.conj(beta[q]) / 2, wn * beta[neg] / 2, neg)
    for a in out:
        a.setflags(write=False)
    return out


def _mirror_series(coeffs: NDArray, grid: RetinaGrid, dtype) -> NDArray:
    """The weighted real coefficients of the mirror series of E pictures' DPFT coefficients
    (E, M, N, C): (E, M C, 2 nh) of ``dtype``, row m C + c holding the cosine then the sine
    coefficients of the angular frequencies q = 0..N/2 (compiled gather: ``kernels.series_table``)."""
    A, b1, b2, neg = mirror_map(grid)
    e, c = coeffs.shape[0], coeffs.shape[3]
    H = (A @ coeffs.reshape(e, grid.M, grid.N * c)).reshape(e, grid.M, grid.N, c)
    out = np.empty((e, grid.M * c, 2 * len(b1)), dtype)
    series_table(H, b1, b2, neg, out)
    return out


def _mirror_tables(
    grid: RetinaGrid, u: NDArray[np.float64], y: NDArray[np.float64], dtype: np.dtype
) -> tuple[NDArray, NDArray]:
    """Factor tables of the mirror series at points (u, y), points last: the DCT-II basis
    cos(m t) in the fractional ring index (M, P) and [cos(n y); -sin(n y)] (2 (N/2 + 1), P).
    One cosine call builds both; the series' weights are in ``_mirror_series``."""
    m_, n_ = grid.M, grid.N
    nh = n_ // 2 + 1
    t = ((u - grid.u[0]) * (math.pi / (m_ * grid.delta)) + math.pi / (2 * m_)).astype(dtype)  # pi (2t+1)/2M
    ang = np.empty((m_ + 2 * nh, len(u)), dtype=dtype)
    np.multiply.outer(np.arange(m_, dtype=dtype), t, out=ang[:m_])
    np.multiply.outer(np.arange(nh, dtype=dtype), y.astype(dtype), out=ang[m_ : m_ + nh])
    np.add(ang[m_ : m_ + nh], dtype.type(math.pi / 2), out=ang[m_ + nh :])  # cos(x + pi/2) = -sin(x)
    np.cos(ang, out=ang)
    return ang[:m_], ang[m_:]


def evaluate(
    coeffs: ArrayLike, grid: RetinaGrid, points: ArrayLike, *, real: bool = True, extension: str = "mirror"
) -> NDArray:
    """f(z') at arbitrary image-plane points from DPFT coefficients alone (eq. ``dppcc'``).

    Returns shape ``points.shape + (C,)`` for (M, N, C) coefficients. See ``OffGridEvaluator``
    for reuse, the ``inside`` mask and the choice of ``extension``.
    """
    return OffGridEvaluator(grid, points, extension=extension)(coeffs, real=real)


def evaluate_direct(
    coeffs: ArrayLike, grid: RetinaGrid, points: ArrayLike, *, real: bool = True, extension: str = "mirror"
) -> NDArray:
    """The same series as ``evaluate`` by a direct sum over all (m, n); the slow reference."""
    real = checks.flag("real", real)
    F = _check_samples(coeffs, grid, "coeffs", complex_ok=True)
    _check_extension(extension)
    zp = _check_points(points)
    B = _series(F, grid, extension)
    rows = B.shape[0]
    zf = zp.ravel()
    u, th = np.log(np.abs(zf)), np.angle(zf)
    m, n = _signed(rows), _signed(grid.N)
    em = np.exp(1j * 2 * math.pi * np.outer(u - grid.u[0], m) / (rows * grid.delta))  # (P, L)
    en = np.exp(1j * np.outer(th - grid.theta[0], n))  # (P, N)
    # sum over n as one matrix product, then over m (the same O(P L N C) sum, BLAS-ordered)
    t = (en @ B.reshape(rows, grid.N, -1).transpose(1, 0, 2).reshape(grid.N, -1)).reshape(len(zf), rows, -1)
    vals = np.einsum("pm,pmc->pc", em, t)
    if extension == "paper":
        out = vals * np.exp(-u)[:, None] / (grid.M * grid.N * dpft_weight(grid))
    else:
        out = vals / (rows * grid.N)
    out = out.reshape(zp.shape + F.shape[2:])
    return out.real if real else out


def transform(
    coeffs: ArrayLike, grid: RetinaGrid, g: ArrayLike, *, real: bool = True, extension: str = "mirror"
) -> NDArray:
    """Samples of the transformed image f(g^{-1} . z) on the grid, from coefficients alone (eq. ``dppcc'``)."""
    _check_grid(grid)
    return evaluate(coeffs, grid, act(inverse(g), grid.points), real=real, extension=extension)


def warp(coeffs: ArrayLike, grid: RetinaGrid, point_map, *, real: bool = True, extension: str = "mirror") -> NDArray:
    """Samples of f(w(z)) on the grid for any point map ``w`` (e.g. a homography), from coefficients.

    ``point_map`` takes the (M, N) complex grid points and must return finite, non-zero points of
    the same shape (``ValueError`` otherwise: use ``predict`` for maps that leave the image)."""
    _check_samples(coeffs, grid, "coeffs", complex_ok=True)
    checks.callable_("point_map", point_map)
    w = checks.array("point_map's result", point_map(grid.points), kinds="biufc", finite=False)
    if w.shape != grid.points.shape:
        raise ValueError(f"point_map must return one point per grid point, shape {grid.points.shape}; got {w.shape}")
    if not np.all(np.isfinite(w)):
        raise ValueError(
            "point_map returned NaN or infinite points (e.g. behind the eye or at a pole); warp "
            "needs a map defined at every grid point: use conformal.predict, which masks them"
        )
    return evaluate(coeffs, grid, w, real=real, extension=extension)
