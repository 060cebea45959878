"""The scene's objects as a head sees them: positions, movable objects, flashes and visibility
(``SceneObjects``, a part of ``models.Head``).

Objects are MuJoCo geoms named in the scene (``Head.scene.objects``, groups in ``Head.scene.groups``);
movable ones are mocap bodies (``Head.scene.movable``). A flash is shown for whole milliseconds of
simulation time and hidden by ``Head.step_ms`` when it is due; ``set_visible`` / ``set_opacity``
change an object's alpha until ``Head.reset`` (or ``Head.set_state``) restores the scene's own.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from conformal import checks

from ._gl import mujoco
from .eye_kinematics.ranges import check_point
from .servo import _ms

if TYPE_CHECKING:
    from .scenes import SceneInfo

__all__ = ["SceneObjects"]

#: Largest radius ``set_sphere_radius`` accepts (m): a bound on a typing error, not a physical limit.
_MAX_RADIUS = 100.0


class SceneObjects:
    """Scene objects, flashes and visibility of a ``models.Head`` (which provides ``model``, ``data``,
    ``scene``, ``time_ms`` and the flash/visibility bookkeeping ``_flash_off``, ``_alpha0``)."""

    # the host's attributes this part uses (declarations for the type checker; ``Head`` sets them)
    model: mujoco.MjModel
    data: mujoco.MjData
    scene: SceneInfo
    time_ms: int
    _flash_off: dict[int, int]  #: geom id -> the time (ms) its flash ends
    _alpha0: dict[int, float]  #: geom id -> the scene's own alpha of an object set_visible/set_opacity changed

    def _name(self, what: str, name, kind: str = "an object") -> str:
        if not isinstance(name, str):
            raise checks.InputTypeError(
                f"{what} must be the name (str) of {kind} of scene {self.scene.name!r}; got {name!r:.60}"
            )
        return name

    def _geom_id(self, name) -> int:
        """The geom id of scene object ``name`` (a ``KeyError`` naming the scene's objects if none)."""
        name = self._name("name", name)
        gid = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_GEOM, name)
        if gid < 0:
            raise KeyError(
                f"scene {self.scene.name!r} has no object {name!r}; objects: {', '.join(self.scene.objects)}"
            )
        return gid

    def object_position(self, name: str) -> np.ndarray:
        """World position of the scene object (geom) ``name``."""
        return self.data.geom_xpos[self._geom_id(name)].copy()

    def object_positions(self, group: str) -> dict[str, np.ndarray]:
        """Positions of all objects in ``group`` (e.g. ``"flashes"``, ``"distractors"``)."""
        group = self._name("group", group, "a group")
        if group not in self.scene.groups:
            raise KeyError(f"scene {self.scene.name!r} has no group {group!r}; groups: {', '.join(self.scene.groups)}")
        return {n: self.object_position(n) for n in self.scene.groups[group]}

    def _set_mocap(self, name: str, pos) -> None:
        name = self._name("name", name)
        bid = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_BODY, name)
        if bid < 0 or self.model.body_mocapid[bid] < 0:
            raise KeyError(
                f"{name!r} is not a movable object of scene {self.scene.name!r}; movable: {', '.join(self.scene.movable)}"
            )
        self.data.mocap_pos[self.model.body_mocapid[bid]] = check_point(pos, name)

    def set_object_position(self, name: str, pos) -> None:
        """Move a movable scene object (mocap body) to world ``pos``."""
        self._set_mocap(name, pos)
        mujoco.mj_forward(self.model, self.data)

    def flash(self, names: str | Sequence[str], duration_ms: int = 8) -> None:
        """Show flash object(s) now for ``duration_ms`` whole milliseconds of simulation time (1..60,000)."""
        if not isinstance(names, str) and not (isinstance(names, (list, tuple)) and names):
            raise checks.InputTypeError(f"names must be a flash name or a non-empty list of them; got {names!r:.60}")
        names = [names] if isinstance(names, str) else [self._name("each of names", n, "a flash") for n in names]
        duration_ms = _ms("duration_ms", duration_ms, 1)
        for n in names:
            if n not in self.scene.flashes:
                raise KeyError(f"{n!r} is not a flash of scene {self.scene.name!r}")
            gid = self.model.geom(n).id
            self.model.geom_rgba[gid, 3] = 1.0
            self._flash_off[gid] = self.time_ms + duration_ms

    def set_visible(self, name: str, visible: bool) -> None:
        """Show or hide the scene object (geom) ``name`` from now on (its alpha 1 or 0): e.g. the
        ``dots`` scene's ``ruler``, ``target`` or ``screen`` for the conditions of a paradigm.
        ``reset`` restores the scene's own visibility."""
        gid = self._geom_id(name)
        visible = checks.flag("visible", visible)
        if gid not in self._alpha0:
            self._alpha0[gid] = float(self.model.geom_rgba[gid, 3])
        self.model.geom_rgba[gid, 3] = 1.0 if visible else 0.0

    def set_opacity(self, name: str, opacity: float) -> None:
        """Show scene object (geom) ``name`` at ``opacity`` in [0, 1] from now on: its alpha, blended
        over what lies behind it, so that its contrast against the background scales with
        ``opacity`` (e.g. references of graded visibility). ``reset`` restores the scene's own."""
        gid = self._geom_id(name)
        opacity = checks.real("opacity", opacity, 0.0, 1.0, hint="0 = invisible, 1 = full contrast")
        if gid not in self._alpha0:
            self._alpha0[gid] = float(self.model.geom_rgba[gid, 3])
        self.model.geom_rgba[gid, 3] = opacity

    def set_sphere_radius(self, name: str, radius: float) -> None:
        """Resize the sphere scene object (geom) ``name`` to ``radius`` (scene units, metres; in
        (0, 100]): e.g. a paradigm's flash dots of a given visual angle. Only the drawn size changes
        (a model property: ``reset`` keeps it). ``ValueError`` for an object that is not a sphere."""
        gid = self._geom_id(name)
        radius = checks.real("radius", radius, 0.0, _MAX_RADIUS, lo_open=True, hint="a sphere radius in metres")
        if self.model.geom_type[gid] != mujoco.mjtGeom.mjGEOM_SPHERE:
            raise ValueError(
                f"name {name!r} is not a sphere of scene {self.scene.name!r} "
                f"(type {mujoco.mjtGeom(self.model.geom_type[gid]).name}): only a sphere has one radius"
            )
        self.model.geom_size[gid, 0] = radius

    def hide_flashes(self) -> None:
        for gid in self._flash_off:
            self.model.geom_rgba[gid, 3] = 0.0
        self._flash_off.clear()

    @property
    def visible_flashes(self) -> tuple[str, ...]:
        return tuple(self.model.geom(g).name for g in self._flash_off)
