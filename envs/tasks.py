"""Tasks: what an episode asks of the head (dm_control style: task separate from the body).

A task chooses its scene, places its objects at the start of an episode (random under the
env's seed), and scores each saccade: the reward is the sum of the task's ``reward_*`` components
(``Task.reward_keys``), which ``score`` reports in its info as Gymnasium's MuJoCo envs do. The
gaze error of an eye is the angle between its optical axis and the direction from its nodal point
to the target; a target is *foveated* when both eyes' errors are below ``tolerance_deg``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar, cast

import numba as nb
import numpy as np

import models
from conformal import checks
from conformal.kernels import DISK_CACHE

from . import core

__all__ = [
    "Task",
    "FixateTask",
    "SearchTask",
    "FreeViewingTask",
    "TASKS",
    "gaze_errors_deg",
    "gaze_errors",
    "make_task",
]


def _check_head(head) -> None:
    if not isinstance(head, models.Head):
        raise checks.InputTypeError(f"head must be a models.Head; got {type(head).__name__}")


def gaze_errors_deg(head: models.Head, point: np.ndarray) -> np.ndarray:
    """Angle (deg) between each eye's optical axis and its line of sight to ``point`` (a finite world
    3-vector, not at an eye's nodal point): shape (2,)."""
    _check_head(head)
    return _gaze_errors_deg(head, checks.array("point", point, kinds="biuf", shape=(3,)))


def gaze_errors(positions: np.ndarray, axes: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Angles (deg) between optical axes and the lines of sight to points, for any number of heads:
    eye positions and unit optical axes (..., 2, 3), points (..., 3) -> (..., 2). ``atan2(|a x d|,
    a . d)``: accurate near 0, where ``acos`` of the dot product is not."""
    pos = np.asarray(positions, float)
    lead = pos.shape[:-2]
    pts = np.asarray(points, float)
    if pts.shape[:-1] != lead:
        pts = np.broadcast_to(pts, lead + (3,))
    out = np.empty(lead + (2,))
    _gaze_errors(
        pos.reshape(-1, 2, 3), np.asarray(axes, float).reshape(-1, 2, 3), pts.reshape(-1, 3), out.reshape(-1, 2)
    )
    return out


@nb.njit(cache=DISK_CACHE, nogil=True)
def _gaze_errors(pos, axes, points, out):  # pragma: no cover - compiled
    for w in range(pos.shape[0]):
        for e in range(2):
            dx, dy, dz = points[w, 0] - pos[w, e, 0], points[w, 1] - pos[w, e, 1], points[w, 2] - pos[w, e, 2]
            ax, ay, az = axes[w, e, 0], axes[w, e, 1], axes[w, e, 2]
            cross = math.sqrt((ay * dz - az * dy) ** 2 + (az * dx - ax * dz) ** 2 + (ax * dy - ay * dx) ** 2)
            out[w, e] = math.degrees(math.atan2(cross, ax * dx + ay * dy + az * dz))


def _gaze_errors_deg(head: models.Head, point: np.ndarray) -> np.ndarray:
    """``gaze_errors_deg`` for a head and a point that the caller knows to be valid (a finite
    3-vector from the head itself: an object's position, a saccade's target)."""
    p = np.asarray(point, dtype=float)
    left, right = head.eye_states()
    if min(math.dist(p, left.camera_position), math.dist(p, right.camera_position)) < 1e-9:
        raise ValueError("point lies at an eye's nodal point, where no line of sight is defined")
    out = np.empty((1, 2))
    _gaze_errors(
        np.array([[left.camera_position, right.camera_position]]),
        np.array([[left.eye_axes[:, 1], right.eye_axes[:, 1]]]),
        p.reshape(1, 3),
        out,
    )
    return out[0]


@dataclass
class Task:
    """Base task. ``scene`` is the ``models`` scene it runs in; ``max_saccades`` the budget (an
    integer in [1, 10000]: the env truncates the episode after that many saccades); ``tolerance_deg``
    in (0, 45]; ``saccade_cost`` in [0, 10].

    ``score`` returns the reward and, in its info, each additive component of it under the names in
    ``reward_keys`` (``reward_*``, as Gymnasium's MuJoCo envs report ``reward_ctrl``...): the
    components sum to the reward.
    """

    scene: str = "dots"
    max_saccades: int = 5
    tolerance_deg: float = 2.0
    saccade_cost: float = 0.05

    name = "task"
    #: The ``reward_*`` info keys of ``score``: the additive components of its reward.
    reward_keys: ClassVar[tuple[str, ...]] = ()

    #: The largest saccade budget of an episode.
    MAX_SACCADES = 10_000

    def __post_init__(self) -> None:
        if self.scene not in models.SCENES:
            raise (ValueError if isinstance(self.scene, str) else checks.InputTypeError)(
                f"scene must be one of {', '.join(models.SCENES)}; got {self.scene!r}"
            )
        self.max_saccades = checks.integer("max_saccades", self.max_saccades, 1, self.MAX_SACCADES)
        self.tolerance_deg = checks.real("tolerance_deg", self.tolerance_deg, 0.0, 45.0, lo_open=True)
        self.saccade_cost = checks.real("saccade_cost", self.saccade_cost, 0.0, 10.0)

    def check_scene(self, head: models.Head) -> None:
        """Raise ValueError if ``head``'s scene lacks what this task needs."""
        _check_head(head)
        if "target" not in head.scene.objects:
            raise ValueError(
                f"task {self.name!r} needs a 'target' object; scene {head.scene.name!r} has none "
                f"(use scene 'dots' or 'search', or task 'free')"
            )

    def initialize_episode(self, head: models.Head, rng: np.random.Generator) -> None:
        """Place the task's objects (the head has just been reset; ``rng`` a ``numpy.random.Generator``):
        each of :meth:`placements` with ``Head.set_object_position``."""
        _check_head(head)
        for name, pos in self.placements(rng).items():
            head.set_object_position(name, pos)

    def placements(self, rng: np.random.Generator) -> dict[str, np.ndarray]:
        """The world positions of the task's objects for a new episode, drawn from ``rng`` (a
        ``numpy.random.Generator``): movable object name -> position (none by default). The batched env
        places them in many worlds at once (``models.BatchedPlanner.take_settled``)."""
        if not isinstance(rng, np.random.Generator):
            raise checks.InputTypeError(f"rng must be a numpy.random.Generator; got {type(rng).__name__}")
        return {}

    def target_position(self, head: models.Head) -> np.ndarray:
        _check_head(head)
        return head.object_position("target")

    def score(self, head: models.Head) -> tuple[float, bool, dict]:
        """(reward, terminated, info) after a saccade has landed; info holds the ``reward_keys``
        components, which sum to the reward, the success and the mean gaze error to the target
        (``target_error_deg``). :meth:`score_errors` for one head."""
        err = _gaze_errors_deg(head, self.target_position(head))  # (target_position checks head)
        reward, success, parts = self.score_errors(err[None])
        info = core.task_info(bool(success[0]), {k: float(v[0]) for k, v in parts.items()}, float(err.mean()))
        return float(reward[0]), bool(success[0]), info

    def score_errors(self, err_deg: np.ndarray) -> tuple[np.ndarray, np.ndarray, dict[str, np.ndarray]]:
        """Rewards (N,), successes (N,) and the rewards' ``reward_keys`` components (each (N,), summing to
        the reward) of N heads whose eyes' gaze errors to the target are ``err_deg`` (N, 2) degrees --
        the scoring of both the single and the batched env."""
        raise NotImplementedError

    @staticmethod
    def _total(parts: dict[str, np.ndarray]) -> np.ndarray:
        """The reward: the sum of its components (in their order, so the sum is the same float)."""
        return cast(np.ndarray, sum(parts.values()))  # a sum of arrays (typeshed's sum allows the int 0)


@dataclass
class FixateTask(Task):
    """``fixate``: a salient target appears in the periphery of the ``dots`` screen, at an
    eccentricity uniform in [min_ecc_deg, max_ecc_deg] and a direction uniform on the circle.

    Reward per saccade: exp(-(e / tolerance)^2 / 2) - saccade_cost, e the mean gaze error (deg):
    ``reward_target`` (the first term, in (0, 1]) plus ``reward_saccade`` (-saccade_cost); the
    episode ends when the target is foveated or after ``max_saccades`` saccades.
    """

    scene: str = "dots"
    min_ecc_deg: float = 5.0
    max_ecc_deg: float = 20.0
    name = "fixate"
    reward_keys = ("reward_target", "reward_saccade")

    def __post_init__(self) -> None:
        super().__post_init__()
        # the dots screen (1 m ahead) spans about +-33 deg vertically
        self.min_ecc_deg = checks.real("min_ecc_deg", self.min_ecc_deg, 0.0, 30.0)
        self.max_ecc_deg = checks.real(
            "max_ecc_deg", self.max_ecc_deg, self.min_ecc_deg, 30.0, hint="and >= min_ecc_deg"
        )

    def check_scene(self, head) -> None:
        super().check_scene(head)
        if "target" not in head.scene.movable:
            raise ValueError(f"task 'fixate' moves the target; in scene {head.scene.name!r} it is fixed")

    def placements(self, rng) -> dict[str, np.ndarray]:
        super().placements(rng)
        ecc = math.radians(rng.uniform(self.min_ecc_deg, self.max_ecc_deg))
        ang = rng.uniform(0, 2 * math.pi)
        az, el = math.atan(math.tan(ecc) * math.cos(ang)), math.atan(math.tan(ecc) * math.sin(ang))
        return {"target": models.screen_point(az, el, 1.0)}

    def score_errors(self, err_deg):
        success = np.all(err_deg <= self.tolerance_deg, axis=1)
        parts = {
            "reward_target": np.exp(-0.5 * (err_deg.mean(axis=1) / self.tolerance_deg) ** 2),
            "reward_saccade": np.full(len(err_deg), -self.saccade_cost),
        }
        return self._total(parts), success, parts


@dataclass
class SearchTask(Task):
    """``search``: find the red sphere among green spheres and red cubes (``search`` scene,
    layout re-drawn from the seed each episode). Reward 1 for foveating the target
    (``reward_target``), minus ``saccade_cost`` per saccade (``reward_saccade``); ends on success or
    after ``max_saccades``."""

    scene: str = "search"
    max_saccades: int = 10
    tolerance_deg: float = 2.5
    name = "search"
    reward_keys = ("reward_target", "reward_saccade")

    def score_errors(self, err_deg):
        success = np.all(err_deg <= self.tolerance_deg, axis=1)
        parts = {
            "reward_target": np.where(success, 1.0, 0.0),
            "reward_saccade": np.full(len(err_deg), -self.saccade_cost),
        }
        return self._total(parts), success, parts


@dataclass
class FreeViewingTask(Task):
    """``free``: free viewing of any scene (e.g. ``bar`` or ``natural``): no target, reward 0 (no
    components: no ``reward_*`` keys; ``saccade_cost`` is not charged), never terminates; truncated
    after ``max_saccades``. For experiments and visualisation."""

    scene: str = "natural"
    max_saccades: int = 20
    name = "free"

    def check_scene(self, head) -> None:
        _check_head(head)

    def score(self, head) -> tuple[float, bool, dict]:
        _check_head(head)
        return 0.0, False, core.task_info(False, {})  # no target: no target_error_deg

    def score_errors(self, err_deg):
        n = len(err_deg)
        return np.zeros(n), np.zeros(n, bool), {}


TASKS: dict[str, type[Task]] = {"fixate": FixateTask, "search": SearchTask, "free": FreeViewingTask}


def make_task(task: str | Task, **kwargs) -> Task:
    """A task by name (``"fixate"``, ``"search"``, ``"free"``) with its keyword arguments, or a ready
    ``Task`` instance (then no keyword arguments)."""
    if isinstance(task, Task):
        if kwargs:
            raise ValueError(
                f"keyword arguments ({', '.join(kwargs)}) configure a task given by name; "
                f"{type(task).__name__} is already built: set them on it instead"
            )
        return task
    if task not in TASKS:
        raise (ValueError if isinstance(task, str) else checks.InputTypeError)(
            f"unknown task {task!r}; choose one of {', '.join(TASKS)} or pass a Task"
        )
    fields = set(TASKS[task].__dataclass_fields__)
    unknown = sorted(set(kwargs) - fields)
    if unknown:
        raise ValueError(
            f"task {task!r} has no argument {', '.join(unknown)}; its arguments: {', '.join(sorted(fields))}"
        )
    return TASKS[task](**kwargs)
