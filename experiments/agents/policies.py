"""Saccade policies over the superior-colliculus cell map (``action_mode="cell"``).

Every policy maps an observation of ``BinocularSaccadeEnv(action_mode="cell", cortex="eyes")``
to a peripheral retina cell ``k * N + l``; the env saccades to that cell's centre direction,
like a motor map in the superior colliculus (Robinson 1972; Ottes, van Gisbergen & Eggermont
1986: the SC map is log-polar, as the conformal camera's cortical map).

- :class:`RandomPolicy`: uniform over cells.
- :class:`BrightestCellPolicy`: the heuristic "saccade to the brightest cell" (luminance summed
  over colour channels and both eyes; the fovea is not part of the cell map, so the current
  fixation point's foveal region is excluded by construction).
- :class:`LinearCellPolicy`: logits[cell] = w . phi(obs, cell) with the hand-made per-cell
  features of :func:`cell_features`; acts greedily (temperature 0) or by softmax sampling.
"""

from __future__ import annotations

import json
import zipfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Protocol

import numpy as np

__all__ = [
    "FEATURE_SET",
    "POLICY_FILES",
    "BrightestCellPolicy",
    "LinearCellPolicy",
    "Policy",
    "RandomPolicy",
    "cell_features",
    "feature_names",
    "load_policy",
]

FEATURE_SET = "contrast-v1"
CONTRAST_GAIN = 10.0  # features are contrasts of intensities in [0, 1]; scale them to ~1
POLICY_FILES = ("policy.npz", "policy.json")


def _cortical(obs: dict[str, np.ndarray] | np.ndarray) -> np.ndarray:
    c = obs["cortical"] if isinstance(obs, dict) else obs
    c = np.asarray(c, dtype=np.float64)
    if c.ndim != 4 or c.shape[0] != 2 or c.shape[-1] != 3:
        raise ValueError(f"need cortical samples of shape (2, M, N, 3) (cortex='eyes', colour); got {c.shape}")
    return c


def feature_names(M: int) -> list[str]:
    """Names of the entries of :func:`cell_features`' last axis for an M-ring grid."""
    return ["luminance", "yellow", "red", "binocular_min"] + [f"ring_{k}" for k in range(M)]


def cell_features(obs: dict[str, np.ndarray] | np.ndarray) -> np.ndarray:
    """Per-cell features phi(obs, cell), shape (M * N, 4 + M), cells in action order k * N + l.

    With c the cortical samples (2, M, N, 3) [eye, ring, sector, RGB] and x' = x - (ring mean of x):
    luminance' (mean over eyes of (R+G+B)/3), yellow' ((R+G)/2 - B: the target's colour
    opponency), red' (R - G: the fixation dot), binocular_min (the smaller of the two eyes'
    luminance contrasts: the object is seen by both eyes), each times ``CONTRAST_GAIN``; then a
    one-hot of the ring (an eccentricity bias).
    """
    c = _cortical(obs)
    M, N = c.shape[1:3]
    mean = c.mean(axis=0)  # (M, N, 3)
    lum_eye = c.mean(axis=-1)  # (2, M, N)
    maps = [
        mean.mean(axis=-1),
        (mean[..., 0] + mean[..., 1]) / 2 - mean[..., 2],
        mean[..., 0] - mean[..., 1],
    ]
    contrast = [m - m.mean(axis=1, keepdims=True) for m in maps]
    lum_c = lum_eye - lum_eye.mean(axis=2, keepdims=True)
    contrast.append(lum_c.min(axis=0))
    phi = np.stack(contrast, axis=-1) * CONTRAST_GAIN  # (M, N, 4)
    rings = np.broadcast_to(np.eye(M)[:, None, :], (M, N, M))
    return np.concatenate([phi, rings], axis=-1).reshape(M * N, 4 + M)


class Policy(Protocol):
    """Anything that picks a cell index from an observation."""

    name: str

    def act(self, obs: dict[str, np.ndarray], rng: np.random.Generator) -> int: ...


@dataclass
class RandomPolicy:
    """Uniform over the M * N cells."""

    n_cells: int
    name: str = "random"

    def act(self, obs: dict[str, np.ndarray], rng: np.random.Generator) -> int:
        return int(rng.integers(self.n_cells))


@dataclass
class BrightestCellPolicy:
    """Saccade to the cell with the largest luminance summed over channels and both eyes."""

    name: str = "heuristic"

    def act(self, obs: dict[str, np.ndarray], rng: np.random.Generator) -> int:
        c = _cortical(obs)
        return int(np.argmax(c.sum(axis=(0, 3)).ravel()))


@dataclass
class LinearCellPolicy:
    """Softmax policy over cells with logits w . phi(obs, cell) (:func:`cell_features`).

    ``temperature == 0`` acts greedily (argmax; ties to the lowest index); otherwise samples
    from softmax(logits / temperature) with the caller's generator.
    """

    weights: np.ndarray
    temperature: float = 0.0
    metadata: dict[str, Any] = field(default_factory=dict)
    name: str = "linear"

    def __post_init__(self) -> None:
        self.weights = np.asarray(self.weights, dtype=np.float64)
        if self.weights.ndim != 1 or self.weights.size < 5 or not np.all(np.isfinite(self.weights)):
            raise ValueError(f"weights must be a finite vector of length 4 + M; got shape {self.weights.shape}")
        if not (np.isfinite(self.temperature) and self.temperature >= 0):
            raise ValueError(f"temperature must be >= 0; got {self.temperature!r}")

    def logits(self, obs: dict[str, np.ndarray]) -> np.ndarray:
        phi = cell_features(obs)
        if phi.shape[1] != self.weights.size:
            raise ValueError(
                f"policy has {self.weights.size} weights but the observation gives "
                f"{phi.shape[1]} features (a grid with a different number of rings?)"
            )
        return phi @ self.weights

    def act(self, obs: dict[str, np.ndarray], rng: np.random.Generator) -> int:
        z = self.logits(obs)
        if self.temperature == 0:
            return int(np.argmax(z))
        p = np.exp((z - z.max()) / self.temperature)
        return int(rng.choice(z.size, p=p / p.sum()))

    def save(self, directory: str | Path) -> Path:
        """Write ``policy.npz`` (weights) and then ``policy.json`` (metadata and the weights' SHA-256),
        each atomically, into ``directory``."""
        import io

        from ..folders import atomic_write_bytes, write_json
        from .saved import file_sha256

        d = Path(directory)
        d.mkdir(parents=True, exist_ok=True)
        buf = io.BytesIO()
        np.savez(buf, weights=self.weights)
        atomic_write_bytes(d / "policy.npz", buf.getvalue())
        meta = {
            "kind": "linear-cell",
            "feature_set": FEATURE_SET,
            "temperature": self.temperature,
            "features": feature_names(self.weights.size - 4),
            **self.metadata,
            "weights_sha256": file_sha256(d / "policy.npz"),
        }
        write_json(d / "policy.json", meta)  # last: its SHA-256 names the weights it describes
        return d


def load_policy(directory: str | Path) -> LinearCellPolicy:
    """Load a policy saved by :meth:`LinearCellPolicy.save`."""
    d = Path(directory)
    missing = [f for f in POLICY_FILES if not (d / f).is_file()]
    if missing:
        raise FileNotFoundError(f"{d} is not a saved policy: missing {', '.join(missing)}")
    try:
        meta = json.loads((d / "policy.json").read_text())
    except (OSError, json.JSONDecodeError, UnicodeDecodeError) as err:
        raise ValueError(
            f"{d / 'policy.json'} is not valid JSON ({err}); the policy folder is corrupt: retrain"
        ) from None
    if not isinstance(meta, dict):
        raise ValueError(f"{d / 'policy.json'} does not hold a JSON object; the policy folder is corrupt: retrain")
    if meta.get("kind") != "linear-cell" or meta.get("feature_set") != FEATURE_SET:
        raise ValueError(
            f"{d}: unsupported policy kind/feature set "
            f"{meta.get('kind')!r}/{meta.get('feature_set')!r}; expected 'linear-cell'/{FEATURE_SET!r}"
        )
    sha = meta.pop("weights_sha256", None)
    if sha is not None:
        from .saved import check_weights_sha256

        check_weights_sha256(d / "policy.npz", sha, "policy.json")
    try:
        with np.load(d / "policy.npz", allow_pickle=False) as z:
            weights = np.array(z["weights"])
    except (OSError, ValueError, KeyError, TypeError, IndexError, EOFError, zipfile.BadZipFile) as err:
        raise ValueError(
            f"{d / 'policy.npz'} could not be read ({type(err).__name__}: {err}); the policy folder is corrupt: retrain"
        ) from None
    temperature = float(meta.pop("temperature", 0.0))
    for key in ("kind", "feature_set", "features"):
        meta.pop(key, None)
    return LinearCellPolicy(weights, temperature=temperature, metadata=meta)
