"""Gaze geometry of N heads at once: fixation angles of targets, targets displaced in Fick angles, and
cyclopean saccade amplitudes -- array code that ``models.Head`` runs for one head (N = 1) and
``models.BatchedPlanner`` for many.

Head frame (``models.eye_kinematics.fick``): x forward, y left, z up; Fick ``h > 0`` right, ``v > 0`` up.
"""

from __future__ import annotations

import numpy as np

from conformal import checks

from .fick import gaze_direction, with_listing
from .motor_noise import MotorNoise
from .ranges import H_RANGE, MIN_TARGET_DISTANCE, NULL_SACCADE, V_RANGE, OculomotorRangeError, check_point

__all__ = ["fixation_angles", "fixation_batch", "displaced", "cyclopean_amplitude", "noisy_endpoints"]


def fixation_angles(target_head: np.ndarray, eye_centres_head: np.ndarray) -> np.ndarray:
    """Fick angles ``(2, 3)`` [eye, (h, v, t)] that make both eyes fixate ``target_head``.

    Each eye's optical axis is aimed from its rotation centre (the nodal point lies on that axis)
    through the target, so vergence follows from depth; torsion obeys Listing's law.
    Raises :class:`OculomotorRangeError` for unreachable or non-finite targets.
    """
    p = check_point(target_head)
    c = checks.array("eye_centres_head", eye_centres_head, kinds="biuf", ndim=2).astype(float)
    if c.shape[1] != 3 or len(c) == 0:
        raise ValueError(f"eye_centres_head must be (n_eyes, 3) points in metres; got shape {c.shape}")
    ang, ok, dist = fixation_batch(p[None], c)
    if ok[0]:
        return ang[0]
    if np.any(dist < MIN_TARGET_DISTANCE):
        raise OculomotorRangeError(
            f"target {p.tolist()} is closer than {MIN_TARGET_DISTANCE} m to an eye; choose a farther point"
        )
    h, v = ang[0, :, 0], ang[0, :, 1]
    raise OculomotorRangeError(
        "target outside the oculomotor range (+-45 deg horizontal, +-35 deg vertical): "
        f"needs h = {np.rad2deg(h).round(1).tolist()} deg, v = {np.rad2deg(v).round(1).tolist()} deg "
        "(left, right eye); move the target or turn the neck"
    )


def fixation_batch(p_head: np.ndarray, centres: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Fick angles (m, 2, 3) that make both eyes (rotation centres ``centres`` (2, 3)) fixate each of
    the head-frame points ``p_head`` (m, 3) -- each eye's optical axis aimed from its rotation centre
    through the point, torsion by Listing's law -- and whether each point is reachable (m,): finite,
    at least ``MIN_TARGET_DISTANCE`` from both eyes and within +-45 deg horizontal / +-35 deg vertical.
    Also returns the distances (m, 2) from the eyes."""
    d = p_head[:, None, :] - centres[None]
    dist = np.linalg.norm(d, axis=2)
    h = np.arctan2(-d[..., 1], d[..., 0])
    v = np.arctan2(d[..., 2], np.hypot(d[..., 0], d[..., 1]))
    ok = (
        np.all(dist >= MIN_TARGET_DISTANCE, axis=1)
        & np.all(np.abs(h) <= H_RANGE + 1e-9, axis=1)
        & np.all(np.abs(v) <= V_RANGE + 1e-9, axis=1)
        & np.isfinite(p_head).all(axis=1)
    )
    return with_listing(np.stack([h, v], -1)), ok, dist


def displaced(c: np.ndarray, p: np.ndarray, dhv: np.ndarray) -> np.ndarray:
    """The points (m, 3) at the distances of ``p`` (m, 3) from ``c`` (3,) whose directions from ``c``
    have Fick angles those of ``p`` plus ``dhv`` (m, 2) (a retinotopic saccade, or an endpoint error)."""
    d = p - c
    dist = np.linalg.norm(d, axis=1)
    g = d / dist[:, None]
    H, V = np.arctan2(-g[:, 1], g[:, 0]), np.arcsin(g[:, 2])
    return c + dist[:, None] * gaze_direction(H + dhv[:, 0], V + dhv[:, 1])


def cyclopean_amplitude(c: np.ndarray, p0: np.ndarray, p1: np.ndarray) -> np.ndarray:
    """Angles (m,) (rad) at ``c`` (3,) between the directions to ``p0`` and ``p1`` (m, 3)."""
    d0, d1 = p0 - c, p1 - c
    d0 = d0 / np.linalg.norm(d0, axis=-1, keepdims=True)
    d1 = d1 / np.linalg.norm(d1, axis=-1, keepdims=True)
    return np.arccos(np.clip((d0 * d1).sum(axis=-1), -1, 1))


def noisy_endpoints(
    c: np.ndarray,
    centres: np.ndarray,
    fix: np.ndarray,
    targets: np.ndarray,
    angles: np.ndarray,
    amp: np.ndarray,
    noise: float | MotorNoise,
    rngs,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Motor error on m planned saccades from the fixation points ``fix`` (m, 3) to the head-frame
    ``targets`` (m, 3) with fixation ``angles`` (m, 2, 3) and cyclopean amplitudes ``amp`` (m,): each
    saccade larger than ``NULL_SACCADE`` draws two standard normals from its own generator ``rngs[k]``
    and lands off its target, about the cyclopean eye ``c``, by ``noise``: a ``MotorNoise`` (scatter
    along and across the saccade's direction, undershoot), or a float ``sd`` (isotropic: Fick errors of
    s.d. ``sd * amp``, horizontal and vertical). An endpoint the eyes cannot reach falls back to the
    target. Returns the executed endpoints (m, 3), their fixation angles (m, 2, 3) and amplitudes (m,)."""
    if not isinstance(noise, MotorNoise):
        noise = MotorNoise.of(noise)
    end_point, end, amp = targets.copy(), angles.copy(), np.array(amp, float)
    draw = np.flatnonzero(amp > NULL_SACCADE) if noise.active else np.zeros(0, np.intp)
    if len(draw):
        if noise.isotropic:
            dhv = np.array([rngs[k].normal(0.0, noise.along * amp[k], size=2) for k in draw])
            moved = displaced(c, targets[draw], dhv)
        else:
            z = np.array([rngs[k].normal(0.0, 1.0, size=2) for k in draw])
            d0, d1 = fix[draw] - c, targets[draw] - c
            dist = np.linalg.norm(d1, axis=1)
            d0 = d0 / np.linalg.norm(d0, axis=1, keepdims=True)
            moved = c + dist[:, None] * noise._directions(d0, d1 / dist[:, None], amp[draw], z)
        ang, ok, _ = fixation_batch(moved, centres)
        end_point[draw[ok]], end[draw[ok]] = moved[ok], ang[ok]
        amp[draw] = cyclopean_amplitude(c, fix[draw], end_point[draw])
    return end_point, end, amp
