"""The default off-screen GL backend, chosen before MuJoCo is imported (no MuJoCo import here)."""

from __future__ import annotations

import os

__all__ = ["set_default_backend"]


def set_default_backend() -> None:
    """``MUJOCO_GL`` defaults to ``egl``; ``PYOPENGL_PLATFORM`` follows it for ``egl`` and ``osmesa``
    (only where unset: what a user set is kept)."""
    os.environ.setdefault("MUJOCO_GL", "egl")
    if os.environ["MUJOCO_GL"].lower() == "osmesa":
        os.environ.setdefault("PYOPENGL_PLATFORM", "osmesa")
    elif os.environ["MUJOCO_GL"].lower() == "egl":
        os.environ.setdefault("PYOPENGL_PLATFORM", "egl")
