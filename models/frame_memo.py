"""Frames already rendered, found again by what was drawn: a memo of ``EyeRenderer``'s images keyed by
the MuJoCo scene (``mjvScene``) that ``mjr_render`` draws, field by field.

``mjr_render(viewport, scene, context)`` reads nothing but its arguments: the scene holds every drawn
geom (type, size, pose, colour, material, texture), both GL cameras, the lights and the render flags;
the context holds what was uploaded once (meshes, textures). For one renderer (one context, one
viewport) equal scenes give equal pixels, so a frame whose scene was seen before is the image
drawn then. A psychophysics study renders the same scene many times (the flash-free frames and the
post-saccadic target of every flash position and time of a noiseless saccade): there it saves most
renders (``EyeRenderer.remember_frames``; off by default, where states rarely repeat, as in an env).

Scenes with flexes or skins (not used by the heads here) are never memoised. A caller that uploads new
meshes or textures into the renderer's context must call ``EyeRenderer.forget_frames``.
"""

from __future__ import annotations

from collections import OrderedDict
from collections.abc import Callable, Hashable
from operator import attrgetter
from typing import Any

import numpy as np

from conformal import checks

from ._gl import mujoco

__all__ = ["FrameMemo", "MAX_FRAME_MEMO_MB", "check_megabytes", "scene_key"]

#: The largest memo ``remember_frames`` accepts (megabytes).
MAX_FRAME_MEMO_MB = 4096.0


def check_megabytes(megabytes: float) -> float:
    """A memo's size in [0, ``MAX_FRAME_MEMO_MB``] megabytes (0 = no memo); ``ValueError``/``TypeError`` else."""
    return checks.real("megabytes", megabytes, 0.0, MAX_FRAME_MEMO_MB, hint="the memo's size; 0 turns it off")


#: Scene-wide fields that change the drawing (beside geoms, cameras and lights).
_SCENE_FIELDS = ("flags", "framewidth", "framergb", "enabletransform", "translate", "rotate", "scale", "stereo")
_READERS: dict[type, tuple[Callable[[Any], tuple], tuple[int, ...]]] = {}


def _reader(obj) -> tuple[Callable[[Any], tuple], tuple[int, ...]]:
    """For a MuJoCo struct wrapper's type (``MjvGeom``, ``MjvGLCamera``, ``MjvLight``, ``MjvScene``): one
    getter of all its public data fields and the positions of those that are arrays."""
    kind = type(obj)
    if kind not in _READERS:
        names = (
            _SCENE_FIELDS
            if isinstance(obj, mujoco.MjvScene)
            else tuple(a for a in dir(obj) if not a.startswith("_") and not callable(getattr(obj, a)))
        )
        get = attrgetter(*names)
        arrays = tuple(i for i, v in enumerate(get(obj)) if isinstance(v, np.ndarray))
        _READERS[kind] = (get, arrays)
    return _READERS[kind]


def _values(obj) -> tuple:
    get, arrays = _reader(obj)
    vals = list(get(obj))
    for i in arrays:
        vals[i] = vals[i].tobytes()
    return tuple(vals)


def scene_key(scene: mujoco.MjvScene, extra: Hashable = None) -> tuple | None:
    """Everything ``mjr_render`` draws from ``scene``, as one hashable tuple compared exactly: every
    field of each drawn geom, of both GL cameras and of each light, and the scene's flags and
    transform, with ``extra``; None for a scene with flexes or skins (not covered)."""
    if scene.nflex or scene.nskin:
        return None
    return (
        extra,
        _values(scene),
        tuple(_values(g) for g in scene.geoms[: scene.ngeom]),
        tuple(_values(c) for c in scene.camera),
        tuple(_values(li) for li in scene.lights[: scene.nlight]),
    )


class FrameMemo:
    """Least-recently-used images by scene key, up to ``megabytes`` of pixels (and depth maps);
    counts its ``hits`` and ``misses``."""

    def __init__(self, megabytes: float) -> None:
        self.budget = int(megabytes * 2**20)
        self._items: OrderedDict[Hashable, tuple[np.ndarray, np.ndarray | None]] = OrderedDict()
        self._bytes = 0
        self.hits = 0
        self.misses = 0

    def get(self, key: Hashable | None) -> tuple[np.ndarray, np.ndarray | None] | None:
        """Copies of the image (and depth) stored under ``key``, or None."""
        item = self._items.get(key) if key is not None else None
        if key is None or item is None:
            self.misses += 1
            return None
        self.hits += 1
        self._items.move_to_end(key)
        img, dep = item
        return img.copy(), (None if dep is None else dep.copy())

    def put(self, key: Hashable | None, img: np.ndarray, dep: np.ndarray | None) -> None:
        """Keep copies of ``img`` (and ``dep``) under ``key``, dropping the least recently used."""
        size = img.nbytes + (0 if dep is None else dep.nbytes)
        if key is None or size > self.budget or key in self._items:
            return
        self._items[key] = (img.copy(), None if dep is None else dep.copy())
        self._bytes += size
        while self._bytes > self.budget:
            _, (i, d) = self._items.popitem(last=False)
            self._bytes -= i.nbytes + (0 if d is None else d.nbytes)

    def clear(self) -> None:
        self._items.clear()
        self._bytes = 0

    def __len__(self) -> int:
        return len(self._items)
