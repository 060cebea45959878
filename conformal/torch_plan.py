"""``TorchRemapPlan``: the DPFT and ``RemapPlan``'s point prediction in torch, many eyes at once on a device.

The torch variant of the compiled series evaluation, kept beside it as ``models._plan_kernels`` keeps
its compiled variants side by side: :meth:`TorchRemapPlan.dpft` is ``dpft.dpft_prechecked`` (eqs.
``lpdft``/``dpft``) and :meth:`TorchRemapPlan.evaluate_prechecked` is ``RemapPlan._evaluate`` with
``pooled=False``: ``kernels.map_points`` (the point maps of ``conformal.maps``, one pole rule), the
mirror series of eq. ``dppcc'`` via ``dpft.mirror_map``, ``kernels.tabulate_angles`` and
``kernels.contract_rings``. Everything that depends only on the grid is built once in float64 numpy and
kept on the device in float32 (complex64); the per-frame work runs in float32, so the numbers are the
compiled path's up to float32 rounding.

torch is optional: ``import conformal`` does not import this module; ``conformal.TorchRemapPlan`` (or
``import conformal.torch_plan``) does, and raises ``ImportError`` saying what to install without torch.
The caller (``envs.batched_vision.TorchVision``) checks the frames, maps and devices it passes.
"""

from __future__ import annotations

import contextlib
import math
from collections.abc import Iterator

import numpy as np

from . import checks
from .dpft import dpft_tables, dpft_weight, mirror_map
from .fovea import fovea_indices
from .grid import RetinaGrid
from .maps import KIND_MOBIUS, KIND_PROJECTIVE, homography_point, mobius_point

try:
    import torch
except ImportError:  # pragma: no cover - only imported with torch (the gpu extra)
    raise ImportError(
        'conformal.torch_plan needs torch: pip install -e ".[gpu]" (torch\'s CPU build serves without a GPU)'
    ) from None

__all__ = ["TorchRemapPlan", "ieee_matmul"]


class TorchRemapPlan:
    """The grid's DPFT and point-prediction tables on ``device`` (a ``torch.device``), in float32.

    ``grid`` a ``RetinaGrid``. Attributes: ``n_points`` (P: the N_f foveal points, then the periphery
    [k, l] row-major), ``n_half`` (N/2 + 1 angular frequencies of the mirror series).
    """

    def __init__(self, grid: RetinaGrid, device: torch.device) -> None:
        if not isinstance(grid, RetinaGrid):
            raise checks.InputTypeError(f"grid must be a conformal.RetinaGrid; got {type(grid).__name__}")
        if not isinstance(device, torch.device):
            raise checks.InputTypeError(f"device must be a torch.device; got {type(device).__name__}")
        g = self.grid = grid
        self.device = dev = device
        f32 = torch.float32
        self.n_points = g.n_fovea + g.M * g.N

        # --- DPFT (dpft.dpft_prechecked): w e^{u_k} per ring, the phase e^{-i (2 pi m u_0 / T + n theta_0)}
        phase, _, exp_u, _ = dpft_tables(g)
        self._dpft_weight = torch.as_tensor(dpft_weight(g) * np.array(exp_u), dtype=f32, device=dev).view(g.M, 1, 1)
        self._dpft_phase = torch.as_tensor(np.array(phase), dtype=torch.complex64, device=dev).view(g.M, g.N, 1)

        # --- the mirror series (dpft.mirror_map / _mirror_series): H = A F, D[q] = H[q] b1 + conj(H[-q]) b2
        A, b1, b2, neg = mirror_map(g)
        self.n_half = len(b1)
        self._series_A = torch.as_tensor(np.array(A), dtype=torch.complex64, device=dev)
        self._series_b1 = torch.as_tensor(np.array(b1), dtype=torch.complex64, device=dev).view(-1, 1)
        self._series_b2 = torch.as_tensor(np.array(b2), dtype=torch.complex64, device=dev).view(-1, 1)
        self._series_neg = torch.as_tensor(np.array(neg), dtype=torch.int64, device=dev)
        # the angular frequencies n = 0..N/2 and the ring frequencies m = 0..M-1 (kernels.tabulate_angles,
        # kernels.contract_rings: their cos/sin tables at the mapped points)
        self._freq_n = torch.arange(self.n_half, dtype=f32, device=dev).view(-1, 1)
        self._freq_m = torch.arange(g.M, dtype=f32, device=dev).view(-1, 1)
        self._cos_theta0, self._sin_theta0 = math.cos(g.theta[0]), math.sin(g.theta[0])
        self._u0 = float(g.u[0])
        self._t_scale = math.pi / (g.M * g.delta)
        self._t_offset = math.pi / (2 * g.M)

        self._indices: dict[tuple[int, ...], torch.Tensor] = {}

        # --- the output points (RemapPlan: the foveal points, then the periphery) and the validity radii
        z = np.concatenate([g.fovea_points, g.points.ravel()])
        self._zr = torch.as_tensor(z.real, dtype=f32, device=dev)
        self._zi = torch.as_tensor(z.imag, dtype=f32, device=dev)
        self._r0 = float(g.r0)
        self._r0_sq = float(g.r0) ** 2
        self._r_outer_sq = float(g.ring_edges[-1]) ** 2

        # --- the foveal lattice (fovea.fovea_indices): lattice cell -> foveal sample (N_f: a zero)
        rows, cols, size = fovea_indices(g)
        lut = np.full(size * size, g.n_fovea, np.int64)
        lut[rows * size + cols] = np.arange(g.n_fovea)
        self._fovea_size = size
        self._fovea_lut = torch.as_tensor(lut, device=dev)
        self._fovea_spacing = float(g.fovea_spacing)

    def dpft(self, periphery: torch.Tensor) -> torch.Tensor:
        """The DPFT of (..., M, N, C) float32 peripheral samples as complex64 coefficients of the same shape
        (``dpft.dpft_prechecked``: the FFT over (ring, sector) of w e^{u_k} f, times the phase)."""
        weighted = (periphery * self._dpft_weight).to(torch.complex64)
        coeffs = torch.fft.fft2(weighted, dim=(-3, -2))
        coeffs.mul_(self._dpft_phase)
        return coeffs

    def table_bytes(self, n_maps: int, n_channels: int) -> int:
        """The bytes of one eye's largest float32 tables in :meth:`evaluate_prechecked`: cs (J, K P),
        cos(m t) (M, K P), partial (M C, K P), and a margin."""
        return 4 * n_maps * self.n_points * (2 * self.n_half + self.grid.M + self.grid.M * n_channels + 16)

    def evaluate_prechecked(
        self, F: torch.Tensor, fov: torch.Tensor, kinds: tuple[int, ...], params: torch.Tensor
    ) -> tuple[torch.Tensor, torch.Tensor]:
        """``RemapPlan._evaluate`` (pooled=False) for n eyes: F (n, M, N, C) complex64, fov (n, N_f, C),
        params (n, K, 9) float32. Returns values (n, K, P, C) float32 and valid (n, K, P)."""
        g = self.grid
        n, c = F.shape[0], F.shape[3]
        n_maps, n_pts = len(kinds), self.n_points
        # --- map_points: w = map(z) for every map and point, sorted by where it lands
        u = torch.empty((n, n_maps, n_pts), dtype=torch.float32, device=self.device)
        v = torch.empty_like(u)
        ok = torch.empty((n, n_maps, n_pts), dtype=torch.bool, device=self.device)
        x, y = self._zr, self._zi
        for kind in (KIND_PROJECTIVE, KIND_MOBIUS):
            ks = [k for k, kk in enumerate(kinds) if kk == kind]
            if not ks:
                continue
            idx = self._index(tuple(ks))
            p = params[:, idx].unsqueeze(-1)  # (n, K', 9, 1)
            pk = [p[:, :, j] for j in range(9)]  # each (n, K', 1)
            point = homography_point if kind == KIND_PROJECTIVE else mobius_point  # as kernels.map_points
            uu, vv, unseen = point(pk, x, y)  # unseen: a pole, or behind the old eye
            u[:, idx], v[:, idx], ok[:, idx] = uu, vv, ~unseen
        rr = u * u + v * v
        series = ok & (rr >= self._r0_sq) & (rr < self._r_outer_sq)
        in_fovea = ok & (rr < self._r0_sq)
        valid = series | in_fovea

        # --- the old fovea: bilinear on the foveal lattice (zeros off it), as kernels.map_points
        size, half, h = self._fovea_size, self._fovea_size / 2, self._fovea_spacing
        fu = torch.where(in_fovea, u, 0.0)
        fv = torch.where(in_fovea, v, 0.0)
        col = fu / h + (half - 0.5)
        row = (half - 0.5) - fv / h
        c0 = torch.floor(col).clamp_(0, size - 2)
        q0 = torch.floor(row).clamp_(0, size - 2)
        fc = (col - c0).clamp_(0.0, 1.0).unsqueeze(-1)
        fr = (row - q0).clamp_(0.0, 1.0).unsqueeze(-1)
        corner = (q0.long() * size + c0.long()).view(n, n_maps * n_pts)
        fov_ext = torch.cat([fov, fov.new_zeros((n, 1, c))], dim=1)  # (n, N_f + 1, C)

        def lattice(offset: int) -> torch.Tensor:
            i = self._fovea_lut[corner + offset].unsqueeze(-1).expand(-1, -1, c)
            return torch.gather(fov_ext, 1, i).view(n, n_maps, n_pts, c)

        fovea_values = (
            lattice(0) * ((1 - fr) * (1 - fc))
            + lattice(1) * ((1 - fr) * fc)
            + lattice(size) * (fr * (1 - fc))
            + lattice(size + 1) * (fr * fc)
        )

        # --- the series: points not for it sit at w = r0 (as map_points), harmless for the tables
        su = torch.where(series, u, self._r0).view(n, 1, n_maps * n_pts)
        sv = torch.where(series, v, 0.0).view(n, 1, n_maps * n_pts)
        r2 = torch.where(series, rr, self._r0_sq).view(n, 1, n_maps * n_pts)
        # tabulate_angles: y with e^{i y} = (w / |w|) e^{-i theta_0}; rows cos(n y), then sin(n y) (the sign
        # of kernels.tabulate_angles' -sin(n y) is folded into the coefficients below)
        ang = torch.atan2(sv * self._cos_theta0 - su * self._sin_theta0, su * self._cos_theta0 + sv * self._sin_theta0)
        nh = self.n_half
        cs = torch.empty((n, 2 * nh, n_maps * n_pts), dtype=torch.float32, device=self.device)
        torch.mul(self._freq_n, ang, out=cs[:, :nh])  # n y
        torch.sin(cs[:, :nh], out=cs[:, nh:])
        cs[:, :nh].cos_()
        # dpft._mirror_series: H = A F, D[q] = H[q] b1[q] + conj(H[-q]) b2[q]; rows m C + c, columns Re D, -Im D
        H = torch.matmul(self._series_A, F.reshape(n, g.M, g.N * c)).view(n, g.M, g.N, c)
        D = H[:, :, :nh] * self._series_b1 + H[:, :, self._series_neg].conj() * self._series_b2
        Dm = torch.cat([D.real, -D.imag], dim=2).permute(0, 1, 3, 2).reshape(n, g.M * c, 2 * nh)
        partial = torch.bmm(Dm, cs)  # (n, M C, K P): the angular sum
        del cs
        # contract_rings: sum_m cos(m t) partial[m C + c], t = pi (2 (fractional ring index) + 1) / 2M
        t = (0.5 * torch.log(r2) - self._u0) * self._t_scale + self._t_offset
        cos_mt = torch.mul(self._freq_m, t).cos_()  # (n, M, K P)
        partial = partial.view(n, g.M, c, n_maps * n_pts)
        partial.mul_(cos_mt.unsqueeze(2))
        series_values = partial.sum(dim=1).view(n, c, n_maps, n_pts).permute(0, 2, 3, 1)
        values = torch.where(
            series.unsqueeze(-1), series_values, torch.where(in_fovea.unsqueeze(-1), fovea_values, 0.0)
        )
        return values, valid

    def _index(self, ks: tuple[int, ...]) -> torch.Tensor:
        """The models' positions ``ks`` as an index tensor on the device (made once per tuple)."""
        if ks not in self._indices:
            self._indices[ks] = torch.as_tensor(ks, device=self.device)
        return self._indices[ks]


@contextlib.contextmanager
def ieee_matmul(device: torch.device) -> Iterator[None]:
    """Full float32 matrix products on CUDA for the duration (cuBLAS without TF32: TF32's 10-bit mantissa
    would put ~1e-3 relative errors into the series), the caller's setting restored after it. Through
    ``torch.backends.cuda.matmul.fp32_precision`` where torch has it (reading the legacy ``allow_tf32``
    raises once a caller has used that newer API), else ``allow_tf32``."""
    matmul = torch.backends.cuda.matmul  # torch < 2.9 has the legacy flag only
    flag, ieee = ("fp32_precision", "ieee") if hasattr(matmul, "fp32_precision") else ("allow_tf32", False)
    before = getattr(matmul, flag) if device.type == "cuda" else ieee
    if before == ieee:  # not CUDA, or TF32 already off
        yield
        return
    setattr(matmul, flag, ieee)
    try:
        yield
    finally:
        setattr(matmul, flag, before)
