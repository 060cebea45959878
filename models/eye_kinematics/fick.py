"""Eye orientation in Fick angles: rotation matrices, gaze directions, Listing's law.

Head frame: x forward (primary gaze direction), y to the head's left, z up.  Eye orientation is
given as Fick angles ``(h, v, t)`` -- the gimbal of ``models/head.xml``::

    R = rot(-z, h) @ rot(-y, v) @ rot(+x, t)

``h > 0`` turns the gaze to the right, ``v > 0`` up, ``t > 0`` turns the top of the eye to the
subject's right.  ``R`` maps eye coordinates at primary position to head coordinates; the eye
frame of the README's conventions is ``x2 = R[:, 0]`` (optical axis), ``x3 = -R[:, 1]`` (right),
``x1 = R[:, 2]`` (up).

Listing's law: every eye orientation is reached from primary position by a rotation about an
axis in Listing's plane (the frontal plane, orthogonal to the primary direction); Fick torsion
is then ``tan(t/2) = tan(h/2) tan(v/2)`` with the signs above (Tweed & Vilis 1990; Haslwanter
1995, Vision Res. 35:1727).
"""

from __future__ import annotations

import numpy as np

from conformal import checks

from .._plan_kernels import listing_torsion as _listing_formula  # the formula's one home

__all__ = [
    "PRIMARY_EYE_BASIS",
    "fick_matrix",
    "gaze_direction",
    "fick_angles",
    "listing_torsion",
    "with_listing",
    "rotation_vector",
    "eye_frame_basis",
]

_X = np.array([1.0, 0.0, 0.0])
_Y = np.array([0.0, 1.0, 0.0])
_Z = np.array([0.0, 0.0, 1.0])

#: Columns are the head-frame directions of the eye axes (README, conventions) (x1, x2, x3) at primary position.
PRIMARY_EYE_BASIS = np.column_stack([_Z, _X, -_Y])


_I3 = np.eye(3)
_SKEW: dict[bytes, tuple[np.ndarray, np.ndarray]] = {}  # each axis' cross-product matrix K and K @ K


def _rot(axis: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """Rotation matrices about a fixed unit ``axis`` by ``angle`` (any shape) -> (..., 3, 3):
    Rodrigues' ``I + sin(a) K + (1 - cos(a)) K^2``, K and K^2 made once per axis."""
    angle = np.asarray(angle, dtype=float)
    c, s = np.cos(angle)[..., None, None], np.sin(angle)[..., None, None]
    key = np.asarray(axis, float).tobytes()  # by bytes: -0.0 and 0.0 make different K (signed zeros)
    kk = _SKEW.get(key)
    if kk is None:
        k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
        kk = _SKEW.setdefault(key, (k, k @ k))
    return _I3 + s * kk[0] + (1 - c) * kk[1]


def _angles(**named) -> list[np.ndarray]:
    """Finite real angle arrays (radians) whose shapes broadcast together."""
    out = [checks.array(name, a, kinds="biuf").astype(float) for name, a in named.items()]
    try:
        np.broadcast_shapes(*(a.shape for a in out))
    except ValueError:
        raise ValueError(
            f"{', '.join(named)} must have shapes that broadcast; got {', '.join(str(a.shape) for a in out)}"
        ) from None
    return out


def _rotations(name: str, R, single: bool = False) -> np.ndarray:
    """Finite rotation matrices (..., 3, 3) (orthogonal to 1e-6, det +1), or one (3, 3) if ``single``."""
    r = checks.array(name, R, kinds="biuf", ndim=2 if single else None).astype(float)
    if r.shape[-2:] != (3, 3):
        raise ValueError(
            f"{name} must be {'a 3x3 rotation matrix' if single else 'rotation matrices (..., 3, 3)'}; "
            f"got shape {r.shape}"
        )
    if r.size and (np.abs(r @ np.swapaxes(r, -1, -2) - np.eye(3)).max() > 1e-6 or np.linalg.det(r).min() < 0):
        raise ValueError(f"{name} must hold proper rotation matrices (orthogonal, det +1)")
    return r


def fick_matrix(h, v, t) -> np.ndarray:
    """Eye-in-head rotation ``rot(-z,h) rot(-y,v) rot(x,t)`` for finite Fick angles (vectorised)."""
    h, v, t = _angles(h=h, v=v, t=t)
    return _rot(-_Z, h) @ _rot(-_Y, v) @ _rot(_X, t)


def gaze_direction(h, v) -> np.ndarray:
    """Unit gaze (optical-axis) direction in the head frame for finite Fick angles ``h, v``."""
    h, v = np.broadcast_arrays(*_angles(h=h, v=v))
    return np.stack([np.cos(h) * np.cos(v), -np.sin(h) * np.cos(v), np.sin(v)], axis=-1)


def fick_angles(R: np.ndarray) -> np.ndarray:
    """Fick angles ``(h, v, t)`` of eye-in-head rotation(s) ``R`` (..., 3, 3) -> (..., 3)."""
    R = _rotations("R", R)
    g = R[..., :, 0]
    h = np.arctan2(-g[..., 1], g[..., 0])
    v = np.arcsin(np.clip(g[..., 2], -1.0, 1.0))
    M = np.swapaxes(_rot(-_Z, h) @ _rot(-_Y, v), -1, -2) @ R
    t = np.arctan2(M[..., 2, 1], M[..., 1, 1])
    return np.stack([h, v, t], axis=-1)


def listing_torsion(h, v) -> np.ndarray:
    """Fick torsion that puts the eye in Listing's plane: ``tan(t/2) = tan(h/2) tan(v/2)``.

    Derived from the rotation about the axis ``primary x gaze`` (which lies in Listing's plane);
    the tests check it against that construction, not against this formula.
    """
    h, v = _angles(h=h, v=v)
    return np.asarray(_listing_formula(h, v), float)


def rotation_vector(R: np.ndarray) -> np.ndarray:
    """Rotation vector (axis * angle, radians) of rotation matrix ``R`` (3, 3)."""
    R = _rotations("R", R, single=True)
    angle = np.arccos(np.clip((np.trace(R) - 1) / 2, -1.0, 1.0))
    w = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
    if angle < 1e-9:
        return 0.5 * w
    return angle * w / (2 * np.sin(angle))


def eye_frame_basis(R: np.ndarray) -> np.ndarray:
    """Head-frame directions of the eye axes (x1 up, x2 optical axis, x3 right) as columns."""
    return np.asarray(R) @ PRIMARY_EYE_BASIS


def with_listing(hv: np.ndarray) -> np.ndarray:
    """Append Listing torsion to (..., 2) Fick (h, v) -> (..., 3)."""
    return np.concatenate([hv, _listing_formula(hv[..., :1], hv[..., 1:])], axis=-1)
