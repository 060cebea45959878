"""DrQ-style image augmentation of the cortical map (Kostrikov, Yarats & Fergus 2021, "Image augmentation
is all you need"; Laskin et al. 2020, RAD): each sample of a batch is shifted by a random whole number of
cells, at most ``pad`` in each direction.

DrQ pads a Cartesian image by replicating its edge pixels and crops it back at a random offset. The
cortical map ``(B, 2, M, N, C)`` [batch, eye, ring, sector, colour] is exp-polar: its sector axis is the
polar angle and wraps around, so the shift along it is a circular roll (a rotation of the picture about
the fovea); its ring axis is log-eccentricity with two ends (fovea and periphery), so the shift along it
replicates the end ring, as DrQ's padded crop does (a scaling of the picture about the fovea). Both eyes
get the same shift (one scene). Random draws come from torch's generator (``generator`` or the global
one), so a run is deterministic under its seed and resumes exactly when that generator's state is saved.
"""

from __future__ import annotations

import torch

__all__ = ["random_shifts", "shift_cortical"]


def shift_cortical(cortical: torch.Tensor, rings: torch.Tensor, sectors: torch.Tensor) -> torch.Tensor:
    """``cortical`` (B, E, M, N, C) with sample b moved by ``rings[b]`` cells outwards (edge ring
    replicated) and ``sectors[b]`` cells along the angle (circular): out[b, :, m, n] =
    in[b, :, clip(m - rings[b], 0, M - 1), (n - sectors[b]) mod N]."""
    if cortical.ndim != 5:
        raise ValueError(f"cortical must be (batch, eye, ring, sector, colour); got shape {tuple(cortical.shape)}")
    B, _, M, N, _ = cortical.shape
    rings, sectors = torch.as_tensor(rings).long().reshape(-1), torch.as_tensor(sectors).long().reshape(-1)
    if rings.shape[0] != B or sectors.shape[0] != B:
        raise ValueError(
            f"rings and sectors need one shift per sample ({B}); got {rings.shape[0]} and {sectors.shape[0]}"
        )
    ri = (torch.arange(M)[None, :] - rings[:, None]).clamp(0, M - 1)  # (B, M)
    si = torch.remainder(torch.arange(N)[None, :] - sectors[:, None], N)  # (B, N)
    b = torch.arange(B)[:, None, None]
    x = cortical.permute(0, 2, 3, 1, 4)  # (B, M, N, E, C)
    return x[b, ri[:, :, None], si[:, None, :]].permute(0, 3, 1, 2, 4)


def random_shifts(cortical: torch.Tensor, pad: int, generator: torch.Generator | None = None) -> torch.Tensor:
    """:func:`shift_cortical` by independent uniform whole shifts in [-pad, pad] along rings and
    sectors for each sample; ``pad=0`` returns the input unchanged."""
    if isinstance(pad, bool) or not isinstance(pad, int) or pad < 0:
        raise ValueError(f"pad must be a whole number of cells >= 0; got {pad!r}")
    if pad == 0:
        return cortical
    s = torch.randint(-pad, pad + 1, (2, cortical.shape[0]), generator=generator)
    return shift_cortical(cortical, s[0], s[1])
