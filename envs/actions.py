"""The saccade action of one world or of many, decoded by one function for both envs.

Continuous (``Box``): (horizontal, vertical[, vergence]) in [-1, 1] -- the Fick increments as a
fraction of the env's ``max_amplitude``, and the fixation distance scaled by ``2 ** vergence``.
Cell (``Discrete``): the index of a retina cell (ring-major); the saccade goes to its centre.
"""

from __future__ import annotations

import numpy as np

from conformal import checks

__all__ = ["cell_angles", "decode_actions"]


def cell_angles(points: np.ndarray) -> np.ndarray:
    """Fick increments (h, v) (rad) that bring each retina cell centre ``points`` (complex image-plane
    points, any shape) to the fovea: (n_cells, 2) in ravelled order."""
    z = np.asarray(points).ravel()
    return np.stack([np.arctan(z.real), np.arctan2(z.imag, np.hypot(1.0, z.real))], axis=1)


def decode_actions(
    actions,
    shape: tuple[int, ...],
    *,
    cells: np.ndarray | None,
    max_amplitude: float,
    vergence: bool,
    who: str = "action",
) -> tuple[np.ndarray, np.ndarray]:
    """Actions of ``shape`` -- the action space's shape, with a leading world axis for many worlds --
    as (n, 2) Fick increments (rad) and (n,) fixation-distance factors; ``cells``: the
    :func:`cell_angles` of a cell action space (else None: continuous). A bad action raises an error
    that names ``who`` and, for many worlds, the first world at fault."""
    batched = who != "action"

    def at(bad: np.ndarray, a: np.ndarray) -> str:
        i = int(bad[0])
        return f"world {i} has {a[i].tolist()}" if batched else f"got {a.tolist()}"

    kind = (
        f"an integer cell index in [0, {len(cells)}){' per world' if batched else ''}"
        if cells is not None
        else f"{shape[-1] if shape else 1} real numbers in [-1, 1]"
    )
    try:
        a = np.asarray(actions)
    except Exception:  # e.g. a ragged list
        raise (checks.InputTypeError if cells is not None else ValueError)(
            f"{who} must be {kind}; got {actions!r:.60}"
        ) from None
    if cells is not None:
        k = len(cells)
        if a.dtype.kind not in "iu":
            raise checks.InputTypeError(f"{who} must be {kind}; got {actions!r:.60} ({a.dtype}, shape {a.shape})")
        if a.shape != shape:
            raise ValueError(
                f"{who} must have shape {shape} (a cell index{' per world' if batched else ''}); got {a.shape}"
            )
        bad = np.flatnonzero((a < 0) | (a >= k))
        if bad.size:
            raise ValueError(f"{who} must be a cell index in [0, {k}); {at(bad, a.reshape(-1))}")
        idx = a.reshape(-1).astype(np.int64)
        return cells[idx], np.ones(len(idx))
    if a.dtype.kind not in "iuf":  # complex ([1j, 0] would silently lose its imaginary part), bool, str, object
        raise checks.InputTypeError(f"{who} must be {kind}; got {actions!r:.60} of dtype {a.dtype}")
    if a.shape != shape:
        raise ValueError(f"{who} must have shape {shape}; got {a.shape}")
    a = a.astype(np.float64).reshape(-1, shape[-1])
    bad = np.flatnonzero(~np.isfinite(a).all(axis=1))
    if bad.size:
        raise ValueError(f"{who} contains NaN or infinity: {at(bad, a)}")
    bad = np.flatnonzero((np.abs(a) > 1.0 + 1e-6).any(axis=1))
    if bad.size:
        raise ValueError(f"{who} components must lie in [-1, 1]; {at(bad, a)}")
    factor = 2.0 ** a[:, 2] if vergence else np.ones(len(a))
    return a[:, :2] * max_amplitude, factor
