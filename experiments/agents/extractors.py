"""Networks that read the retina: a convolution that wraps around the cortical map's angular axis.

The cortical observation is the exp-polar (log-polar) retina of both eyes, ``(2, M, N, C)`` [eye,
ring, sector, colour]: rings are log-eccentricity, sectors the polar angle, so the map is periodic
along the sector axis (sector N-1 is next to sector 0) and a rotation of the picture about the fovea
is a roll of the map along it (Schwartz 1977; the conformal camera's log-polar coordinates).
:class:`WrapConv2d` pads that axis circularly (and the ring axis with zeros: the fovea and the
periphery are not neighbours), so a stack of them is *equivariant* to rolls along the sector axis.

- :class:`CorticalEncoder`: both eyes (colour channels and their ring-contrast: each value minus its
  ring's mean) -> a per-cell feature map ``(B, F, M, N)``, a per-cell logit map ``(B, M, N)`` (the
  superior-colliculus motor map of a cell action) and a global vector (mean and max over the map of
  each feature, the fovea and the eye-position signal through small linear layers).
- :class:`SoftArgmaxSaccade`: the saccade vector of a cell-logit map, sum_c softmax(logits)_c * v_c
  (the spatial soft-argmax of Levine, Finn, Darrell & Abbeel 2016), for the continuous ``Box`` action.

Pure torch; :mod:`experiments.agents.sb3` wraps them for Stable-Baselines3, and
:mod:`experiments.agents.skrl_recipe` uses :class:`CorticalEncoder` for the batched engine's learner.
"""

from __future__ import annotations

import numpy as np
import torch
from torch import nn
from torch.nn import functional as F

__all__ = ["CorticalEncoder", "SoftArgmaxSaccade", "WrapConv2d", "cell_saccade_vectors"]


class WrapConv2d(nn.Module):
    """A 2-D convolution over (ring, sector) maps ``(B, C, M, N)`` with stride 1 and 'same' output
    size: the sector axis (last) is padded circularly, the ring axis with zeros. Rolling the input
    by s sectors rolls the output by s sectors (equivariance)."""

    def __init__(self, in_channels: int, out_channels: int, kernel_size: int = 3) -> None:
        super().__init__()
        if kernel_size < 1 or kernel_size % 2 == 0:
            raise ValueError(f"kernel_size must be a positive odd integer (same-size output); got {kernel_size}")
        self.pad = kernel_size // 2
        self.conv = nn.Conv2d(in_channels, out_channels, kernel_size, padding=0)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        p = self.pad
        if p:
            x = F.pad(x, (p, p, 0, 0), mode="circular")  # sectors: periodic
            x = F.pad(x, (0, 0, p, p))  # rings: zeros
        return self.conv(x)


def cell_saccade_vectors(points: np.ndarray, max_amplitude: float) -> np.ndarray:
    """The ``Box`` action (h, v) / max_amplitude that saccades to each retina cell's centre
    (``points``: the grid's complex cell centres (M, N)), clipped to [-1, 1]: (M * N, 2) float32."""
    from envs.actions import cell_angles

    if not max_amplitude > 0:
        raise ValueError(f"max_amplitude must be > 0 (radians); got {max_amplitude!r}")
    return np.clip(cell_angles(points) / max_amplitude, -1.0, 1.0).astype(np.float32)


class SoftArgmaxSaccade(nn.Module):
    """Cell logits ``(B, M * N)`` -> the expected saccade vector under softmax(logits): ``(B, 2)``.
    ``atanh=True`` returns atanh of it (clipped to +-0.995) for policies that squash with tanh (SAC)."""

    vectors: torch.Tensor  #: (n_cells, 2), a registered buffer

    def __init__(self, vectors: np.ndarray, atanh: bool = False) -> None:
        super().__init__()
        v = torch.as_tensor(np.asarray(vectors, np.float32))
        if v.ndim != 2 or v.shape[1] != 2:
            raise ValueError(f"vectors must have shape (n_cells, 2); got {tuple(v.shape)}")
        self.register_buffer("vectors", v)
        self.atanh = atanh

    def forward(self, logits: torch.Tensor) -> torch.Tensor:
        a = torch.softmax(logits, dim=-1) @ self.vectors
        return torch.atanh(a.clamp(-0.995, 0.995)) if self.atanh else a


class CorticalEncoder(nn.Module):
    """Both eyes' cortical maps -> per-cell features, per-cell logits and a global feature vector.

    ``cortical_shape`` (2, M, N, C); ``fovea_shape`` (2, N_f, C) or None; ``eyes_dim`` (6) or 0.
    ``channels``: widths of the :class:`WrapConv2d` layers (3 x 3, ReLU); ``logit_gain``: a fixed factor on
    the logit map (with Adam, it scales how fast the logits can move: 10 lets a policy over hundreds of cells
    sharpen within a few thousand steps). ``forward(obs)`` takes a
    dict of tensors with a batch axis and returns ``(logits (B, M*N), global (B, global_dim))``.
    """

    def __init__(
        self,
        cortical_shape: tuple[int, ...],
        fovea_shape: tuple[int, ...] | None = None,
        eyes_dim: int = 0,
        channels: tuple[int, ...] = (32, 32),
        fovea_dim: int = 32,
        logit_gain: float = 1.0,
    ) -> None:
        super().__init__()
        if not (np.isfinite(logit_gain) and logit_gain > 0):
            raise ValueError(f"logit_gain must be a positive number; got {logit_gain!r}")
        self.logit_gain = float(logit_gain)
        if len(cortical_shape) != 4 or cortical_shape[0] != 2:
            raise ValueError(f"cortical_shape must be (2, M, N, C) (cortex='eyes'); got {tuple(cortical_shape)}")
        if not channels or min(channels) < 1:
            raise ValueError(f"channels must be a non-empty tuple of positive widths; got {channels!r}")
        _, self.M, self.N, self.C = (int(s) for s in cortical_shape)
        layers: list[nn.Module] = []
        c_in = 4 * self.C  # both eyes, raw and ring-contrast
        for c in channels:
            layers += [WrapConv2d(c_in, c, 3), nn.ReLU()]
            c_in = c
        self.conv = nn.Sequential(*layers)
        self.logit = nn.Conv2d(c_in, 1, 1)
        self.fovea = None
        g = 2 * c_in
        if fovea_shape is not None:
            self.fovea = nn.Sequential(nn.Flatten(), nn.Linear(int(np.prod(fovea_shape)), fovea_dim), nn.ReLU())
            g += fovea_dim
        self.eyes_dim = int(eyes_dim)
        g += self.eyes_dim
        self.global_dim = g
        self.n_cells = self.M * self.N

    def feature_map(self, cortical: torch.Tensor) -> torch.Tensor:
        """(B, 2, M, N, C) -> (B, F, M, N): the wrap-around convolutions' output."""
        x = cortical.permute(0, 1, 4, 2, 3).reshape(cortical.shape[0], 2 * self.C, self.M, self.N)
        x = torch.cat([x, x - x.mean(dim=3, keepdim=True)], dim=1)  # raw and ring contrast
        return self.conv(x)

    def forward(self, obs: dict[str, torch.Tensor]) -> tuple[torch.Tensor, torch.Tensor]:
        _, logits, g = self.encode(obs)
        return logits, g

    def encode(self, obs: dict[str, torch.Tensor]) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        """:meth:`forward` with the feature map too: ``(h (B, F, M, N), logits, global)``."""
        h = self.feature_map(obs["cortical"].float())
        logits = self.logit_gain * self.logit(h).flatten(1)
        parts = [h.mean(dim=(2, 3)), h.amax(dim=(2, 3))]
        if self.fovea is not None:
            parts.append(self.fovea(obs["fovea"].float()))
        if self.eyes_dim:
            parts.append(obs["eyes"].float().flatten(1))
        return h, logits, torch.cat(parts, dim=1)
