"""Sampling a pinhole image on the exp-polar retina (paper §6.2).

``Retina`` is built once per grid and image geometry. It precomputes one sparse operator
whose rows are receptive fields: each peripheral cell averages the picture over its area
(each pixel weighted by the fraction of it inside the cell, found by supersampling), and
each foveal sample averages the square of side 1/K around its lattice point. A frame then
costs a single sparse matrix product. Point sampling (nearest or bilinear) is available
for comparison.

Pixel convention (shared with ``models``): row 0 is the top of the picture, and pixel
(row, col) has its centre at
    z = ((col - (W - 1)/2) - i (row - (H - 1)/2)) / pixels_per_unit,
i.e. x3 grows with the column and x1 grows upwards.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray

from . import checks
from .grid import RetinaGrid
from .kernels import pool_picture

__all__ = ["Retina", "RetinaSamples", "pixel_points"]

#: Pictures are at most this many pixels per side, and at most ``MAX_PIXELS`` pixels in all.
MAX_IMAGE_SIDE = 16384
MAX_PIXELS = 2**26
#: The pooling operator is found from H W supersample^2 subpixels: at most this many.
MAX_SUBPIXELS = 2**28
#: Channels of a picture (H, W, C): at most this many.
MAX_CHANNELS = 64
#: Image dtypes sampled in place; float16 is converted to float32 first (numba has no float16).
IMAGE_DTYPES = (
    "bool",
    "uint8",
    "uint16",
    "uint32",
    "uint64",
    "int8",
    "int16",
    "int32",
    "int64",
    "float16",
    "float32",
    "float64",
)


def _image_shape(name: str, shape, ndims: tuple[int, ...] = (2,)) -> tuple[int, ...]:
    """``shape`` as a tuple of checked ints: (H, W) or (H, W, C) per ``ndims``."""
    if isinstance(shape, (str, bytes)) or not hasattr(shape, "__len__"):
        raise checks.InputTypeError(
            f"{name} must be a tuple {' or '.join(('(H, W)', '(H, W, C)')[n - 2] for n in ndims)}; got {shape!r}"
        )
    if len(shape) not in ndims:
        raise ValueError(f"{name} must have {' or '.join(map(str, ndims))} entries (H, W[, C]); got {tuple(shape)!r}")
    out = tuple(
        checks.integer(f"{name}[{i}]", v, 1, MAX_IMAGE_SIDE if i < 2 else MAX_CHANNELS) for i, v in enumerate(shape)
    )
    if out[0] * out[1] > MAX_PIXELS:
        raise ValueError(f"{name} {out[0]}x{out[1]} exceeds {MAX_PIXELS} pixels")
    return out


def pixel_points(shape: tuple[int, int], pixels_per_unit: float) -> NDArray[np.complex128]:
    """Image-plane position z of every pixel centre, shape (H, W) (see the module docstring).

    ``shape``: (H, W), each in [1, 16384] and H W <= 2**26; ``pixels_per_unit`` in (0, 1e9]."""
    h, w = _image_shape("shape", shape)
    pixels_per_unit = checks.real("pixels_per_unit", pixels_per_unit, 0.0, 1e9, lo_open=True)
    cols = (np.arange(w) - (w - 1) / 2) / pixels_per_unit
    rows = (np.arange(h) - (h - 1) / 2) / pixels_per_unit
    return cols[None, :] - 1j * rows[:, None]


@dataclass(frozen=True)
class RetinaSamples:
    """One frame sampled on the retina.

    fovea : (N_f[, C]) foveal samples, ordered as ``grid.fovea_points``.
    periphery : (M, N[, C]) log-polar samples, indexed [ring, sector].
    mask : (M, N) bool, True where the cell is covered by the picture (coverage >= the
        retina's ``min_coverage``); other cells hold ``fill`` and must not be trusted.
    fovea_mask : (N_f,) bool, the same for foveal samples.
    """

    fovea: NDArray[np.float64]
    periphery: NDArray[np.float64]
    mask: NDArray[np.bool_]
    fovea_mask: NDArray[np.bool_]

    def __post_init__(self) -> None:
        fov = checks.array("fovea", self.fovea, kinds="biuf", ndim=(1, 2), finite=False)
        per = checks.array("periphery", self.periphery, kinds="biuf", ndim=(2, 3), finite=False)
        if fov.shape[1:] != per.shape[2:]:
            raise ValueError(
                f"fovea (N_f[, C]) and periphery (M, N[, C]) must have the same channels; "
                f"got {fov.shape} and {per.shape}"
            )
        checks.array("mask", self.mask, kinds="b", shape=per.shape[:2])
        checks.array("fovea_mask", self.fovea_mask, kinds="b", shape=fov.shape[:1])


class Retina:
    """Exp-polar retina for pictures of one shape (the paper's Example: 512x512 at K = 4).

    Parameters
    ----------
    grid : the retina grid (image-plane units).
    image_shape : (H, W) or (H, W, C) of the pictures to be sampled (H, W in [1, 16384],
        H W <= 2**26, C in [1, 64]).
    pixels_per_unit : pixels per image-plane unit (for a camera: 0.5 H / tan(fovy / 2)), in (0, 1e9].
    mode : ``"pool"`` (receptive-field cell averages, anti-aliased; default), ``"bilinear"``
        or ``"nearest"`` (point samples at the cell centres).
    supersample : subpixels per pixel side used to find each pixel's share of a cell, 1..16,
        with H W supersample^2 <= 2**28.
    min_coverage : fraction of a cell's area that must lie inside the picture for ``mask``, in (0, 1].
    fill : value reported for cells with no pixel at all (finite).

    Pictures may have any of the dtypes ``IMAGE_DTYPES`` (float16 is converted to float32);
    others (complex, long double, objects) raise a ``TypeError``.
    """

    def __init__(
        self,
        grid: RetinaGrid,
        image_shape: tuple[int, ...],
        pixels_per_unit: float,
        *,
        mode: str = "pool",
        supersample: int = 4,
        min_coverage: float = 0.5,
        fill: float = 0.0,
    ) -> None:
        if not isinstance(grid, RetinaGrid):
            raise checks.InputTypeError(f"grid must be a RetinaGrid; got {type(grid).__name__}")
        shape = _image_shape("image_shape", image_shape, (2, 3))
        ppu = checks.real("pixels_per_unit", pixels_per_unit, 0.0, 1e9, lo_open=True)
        checks.choice("mode", mode, ("pool", "bilinear", "nearest"))
        supersample = checks.integer("supersample", supersample, 1, 16)
        min_coverage = checks.real("min_coverage", min_coverage, 0.0, 1.0, lo_open=True)
        fill = checks.real("fill", fill)
        if mode == "pool" and shape[0] * shape[1] * supersample**2 > MAX_SUBPIXELS:
            raise ValueError(
                f"a {shape[0]}x{shape[1]} picture at supersample={supersample} needs "
                f"{shape[0] * shape[1] * supersample**2} subpixels (at most {MAX_SUBPIXELS}); "
                "use a smaller supersample"
            )
        self.grid = grid
        self.image_shape = shape
        self.pixels_per_unit = ppu
        self.mode = mode
        self.fill = fill
        h, w = shape[:2]
        n_f, m, n = grid.n_fovea, grid.M, grid.N
        if mode == "pool":
            op, area = self._pooling_operator(supersample)
            cell_area_px = np.concatenate(
                [np.full(n_f, (grid.fovea_spacing * ppu) ** 2), np.repeat(grid.cell_areas(), n) * ppu**2]
            )
            self.coverage = np.minimum(area / cell_area_px, 1.0)
        else:
            pts = np.concatenate([grid.fovea_points, grid.points.ravel()])
            op, self.coverage = self._point_operator(pts, mode)
        # Normalise rows to averages; rows with no support stay empty (-> fill).
        rowsum = np.asarray(op.sum(axis=1)).ravel()
        scale = np.divide(1.0, rowsum, out=np.zeros_like(rowsum), where=rowsum > 0)
        self._op = sp.csr_matrix(sp.diags(scale) @ op)
        self._empty = rowsum <= 0  # (the public mask: ``empty``)
        valid = self.coverage >= min_coverage
        self.fovea_mask = valid[:n_f].copy()
        self.mask = valid[n_f:].reshape(m, n).copy()
        self._n_pixels = h * w

    # ------------------------------------------------------------------ operators
    def _pooling_operator(self, s: int) -> tuple[sp.csr_matrix, NDArray[np.float64]]:
        g, ppu = self.grid, self.pixels_per_unit
        h, w = self.image_shape[:2]
        n_f, m, n = g.n_fovea, g.M, g.N
        # Foveal lattice lookup: lattice point (i + 1/2) spacing -> foveal index.
        fp = g.fovea_points / g.fovea_spacing
        fi = np.round(fp.real - 0.5).astype(int)
        fj = np.round(fp.imag - 0.5).astype(int)
        off = int(max(np.abs(fi).max(), np.abs(fj).max())) + 2
        lut = -np.ones((2 * off, 2 * off), dtype=np.int64)
        lut[fj + off, fi + off] = np.arange(n_f)
        sub = (np.arange(s) + 0.5) / s - 0.5  # subpixel offsets in pixels
        rows_out, cols_out = [], []
        r_max = g.rb * ppu + 2.0
        chunk = max(1, 2_000_000 // (w * s * s))
        for r0 in range(0, h, chunk):
            rr = np.arange(r0, min(h, r0 + chunk))
            yy = ((h - 1) / 2 - (rr[:, None] + sub[None, :])).reshape(-1)  # x1 in pixels
            xx = (np.arange(w)[:, None] + sub[None, :] - (w - 1) / 2).reshape(-1)  # x3 in pixels
            pix = (rr[:, None, None, None] * w + np.arange(w)[None, None, :, None]).repeat(s, 1).repeat(s, 3)
            pix = pix.reshape(-1)
            X = np.broadcast_to(xx.reshape(1, 1, w, s), (len(rr), s, w, s)).reshape(-1)
            Y = np.broadcast_to(yy.reshape(len(rr), s, 1, 1), (len(rr), s, w, s)).reshape(-1)
            rad = np.hypot(X, Y)
            keep = rad < r_max
            X, Y, rad, p = X[keep], Y[keep], rad[keep], pix[keep]
            z = (X + 1j * Y) / ppu
            k, l = g.locate(z)
            per = (k >= 0) & (k < m)
            rows_out.append(n_f + k[per] * n + l[per])
            cols_out.append(p[per])
            # foveal squares
            ii = np.floor(X / (g.fovea_spacing * ppu)).astype(int) + off
            jj = np.floor(Y / (g.fovea_spacing * ppu)).astype(int) + off
            inl = (ii >= 0) & (ii < 2 * off) & (jj >= 0) & (jj < 2 * off)
            fidx = np.full(len(X), -1, dtype=np.int64)
            fidx[inl] = lut[jj[inl], ii[inl]]
            fov = fidx >= 0
            rows_out.append(fidx[fov])
            cols_out.append(p[fov])
        rows = np.concatenate(rows_out)
        cols = np.concatenate(cols_out)
        vals = np.full(len(rows), 1.0 / (s * s))
        op = sp.csr_matrix((vals, (rows, cols)), shape=(n_f + m * n, h * w))
        op.sum_duplicates()
        area = np.asarray(op.sum(axis=1)).ravel()
        return op, area

    def _point_operator(self, pts: NDArray[np.complex128], mode: str) -> tuple[sp.csr_matrix, NDArray[np.float64]]:
        h, w = self.image_shape[:2]
        col = pts.real * self.pixels_per_unit + (w - 1) / 2
        row = (h - 1) / 2 - pts.imag * self.pixels_per_unit
        inside = (col >= -0.5) & (col <= w - 0.5) & (row >= -0.5) & (row <= h - 0.5)
        idx = np.arange(len(pts))
        if mode == "nearest":
            c = np.clip(np.round(col).astype(int), 0, w - 1)
            r = np.clip(np.round(row).astype(int), 0, h - 1)
            rows, cols, vals = idx[inside], (r * w + c)[inside], np.ones(inside.sum())
        else:
            c0 = np.clip(np.floor(col).astype(int), 0, w - 2)
            r0 = np.clip(np.floor(row).astype(int), 0, h - 2)
            fc = np.clip(col - c0, 0, 1)
            fr = np.clip(row - r0, 0, 1)
            row_parts: list[NDArray[np.intp]] = []
            col_parts: list[NDArray[np.intp]] = []
            val_parts: list[NDArray[np.float64]] = []
            for dr, dc, wt in (
                (0, 0, (1 - fr) * (1 - fc)),
                (0, 1, (1 - fr) * fc),
                (1, 0, fr * (1 - fc)),
                (1, 1, fr * fc),
            ):
                row_parts.append(idx[inside])
                col_parts.append(((r0 + dr) * w + c0 + dc)[inside])
                val_parts.append(wt[inside])
            rows, cols, vals = np.concatenate(row_parts), np.concatenate(col_parts), np.concatenate(val_parts)
        op = sp.csr_matrix((vals, (rows, cols)), shape=(len(pts), h * w))
        return op, inside.astype(float)

    # ------------------------------------------------------------------ per frame
    def _check_image(self, image: NDArray) -> NDArray:
        """A finite picture of this retina's shape in a dtype the compiled pooling reads (native byte
        order; float16 as float32, bool as uint8); others raise a ``TypeError`` naming ``IMAGE_DTYPES``."""
        if isinstance(image, (str, bytes)) or image is None:
            raise checks.InputTypeError(f"image must be an array; got {type(image).__name__}")
        try:
            img = np.asarray(image)
        except (ValueError, TypeError):  # a ragged nested list
            raise ValueError(f"image must be a rectangular array of shape {self.image_shape}") from None
        if img.dtype.name not in IMAGE_DTYPES:  # (the name ignores the byte order)
            raise checks.InputTypeError(f"image has dtype {img.dtype}; supported: {', '.join(IMAGE_DTYPES)}")
        if img.shape != self.image_shape:
            raise ValueError(
                f"image has shape {img.shape}, but this Retina was built for {self.image_shape}; "
                "build a Retina for this shape"
            )
        if not img.dtype.isnative:
            img = img.astype(img.dtype.newbyteorder("="))
        if img.dtype == np.float16:
            img = img.astype(np.float32)
        elif img.dtype == np.bool_:
            img = img.view(np.uint8)
        if img.dtype.kind == "f" and not np.all(np.isfinite(img)):
            raise ValueError("image contains NaN or infinite values")
        return img

    def sample(self, image: NDArray) -> RetinaSamples:
        """Sample one picture: foveal and peripheral receptive-field values (float64)."""
        out = self.sample_many((image,))[0]
        g = self.grid
        chans = self.image_shape[2:]
        return RetinaSamples(
            fovea=out[: g.n_fovea].reshape((g.n_fovea,) + chans),
            periphery=out[g.n_fovea :].reshape((g.M, g.N) + chans),
            mask=self.mask,
            fovea_mask=self.fovea_mask,
        )

    @property
    def empty(self) -> NDArray[np.bool_]:
        """Mask of the receptive fields no pixel falls in (their samples are ``fill``)."""
        return self._empty.copy()

    def sample_many(self, images, scale: float = 1.0) -> NDArray[np.float64]:
        """Sample several pictures into one array (E, N_f + M N[, C]) in retina order (the
        rows of ``operator``: fovea, then periphery [k, l]), each value times ``scale`` (finite)."""
        if isinstance(images, np.ndarray) and images.ndim == len(self.image_shape):
            raise ValueError(
                f"images must be a sequence of pictures of shape {self.image_shape}; got one picture "
                "(use sample for one)"
            )
        if isinstance(images, (str, bytes)) or not hasattr(images, "__iter__"):
            raise checks.InputTypeError(f"images must be a sequence of pictures; got {type(images).__name__}")
        scale = checks.real("scale", scale)
        return self.sample_prechecked([self._check_image(im) for im in images], scale)

    def sample_prechecked(self, imgs: list[NDArray], scale: float) -> NDArray[np.float64]:
        """``sample_many`` of pictures already checked (``_check_image``) and a finite float ``scale``."""
        chans = self.image_shape[2:]
        out = np.empty((len(imgs), self._op.shape[0], int(np.prod(chans))))
        op = self._op
        for img, o in zip(imgs, out):
            flat = img.reshape(self._n_pixels, -1)
            pool_picture(op.indptr, op.indices, op.data, np.ascontiguousarray(flat), scale, o)  # op @ flat, in place
        if self.fill != 0.0:
            out[:, self._empty] = self.fill
        return out.reshape((len(imgs), self._op.shape[0]) + chans)

    @property
    def operator(self) -> sp.csr_matrix:
        """The sparse (N_f + M N, H W) sampling operator (rows: fovea first, then [k, l] row-major)."""
        return self._op

    def render(self, samples: RetinaSamples, *, background: float = 0.0) -> NDArray[np.float64]:
        """Back to a pinhole picture of this retina's shape, each pixel showing its cell's value.

        Pixels in the fovea take the nearest foveal sample; pixels beyond r_b take ``background``
        (finite). For a smooth rendering from DPFT coefficients use ``conformal.evaluate``.
        """
        if not isinstance(samples, RetinaSamples):
            raise checks.InputTypeError(f"samples must be RetinaSamples; got {type(samples).__name__}")
        background = checks.real("background", background)
        g = self.grid
        per = checks.array("samples.periphery", samples.periphery, kinds="biuf").astype(float)
        fov = checks.array("samples.fovea", samples.fovea, kinds="biuf").astype(float)
        chans = per.shape[2:]
        if per.shape[:2] != (g.M, g.N) or fov.shape[:1] != (g.n_fovea,):
            raise ValueError(
                f"samples do not match this retina's grid: periphery {per.shape}, fovea {fov.shape}; "
                f"expected ({g.M}, {g.N}[, C]) and ({g.n_fovea}[, C])"
            )
        if not hasattr(self, "_render_index"):
            self._render_index = self._make_render_index()
        table = np.concatenate(
            [
                fov.reshape(g.n_fovea, -1),
                per.reshape(g.M * g.N, -1),
                np.full((1, max(1, int(np.prod(chans)))), background),
            ]
        )
        h, w = self.image_shape[:2]
        return table[self._render_index].reshape((h, w) + chans)

    def _make_render_index(self) -> NDArray[np.intp]:
        g = self.grid
        h, w = self.image_shape[:2]
        z = pixel_points((h, w), self.pixels_per_unit).ravel()
        k, l = g.locate(z)
        idx = np.full(z.shape, g.n_fovea + g.M * g.N, dtype=np.intp)
        per = (k >= 0) & (k < g.M)
        idx[per] = g.n_fovea + k[per] * g.N + l[per]
        fov = k < 0
        if np.any(fov):
            from scipy.spatial import cKDTree

            fp = g.fovea_points
            tree = cKDTree(np.c_[fp.real, fp.imag])
            _, nearest = tree.query(np.c_[z[fov].real, z[fov].imag])
            idx[fov] = nearest
        return idx
