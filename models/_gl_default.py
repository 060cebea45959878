"""The default off-screen GL backend, chosen before MuJoCo is imported (no MuJoCo import here)."""

from __future__ import annotations

import os

__all__ = ["set_default_backend"]


def set_default_backend() -> None:
    """``MUJOCO_GL`` defaults to ``egl``; ``PYOPENGL_PLATFORM`` follows it for ``egl`` and ``osmesa``;
    ``LP_NUM_THREADS`` (Mesa's software rasterizer, llvmpipe) defaults to 0: each render rasterized in the
    calling thread, without llvmpipe's thread per core. The same pixels; for the eyes' small images
    (<= 256 px) 1.0-2.1x faster on an idle 2-core machine, and no extra threads beside the parallel
    workers; at 512 px threads are faster on an idle machine (set ``LP_NUM_THREADS`` to the cores).
    Only where unset: what a user set is kept. GPU drivers ignore ``LP_NUM_THREADS``."""
    os.environ.setdefault("LP_NUM_THREADS", "0")
    os.environ.setdefault("MUJOCO_GL", "egl")
    if os.environ["MUJOCO_GL"].lower() == "osmesa":
        os.environ.setdefault("PYOPENGL_PLATFORM", "osmesa")
    elif os.environ["MUJOCO_GL"].lower() == "egl":
        os.environ.setdefault("PYOPENGL_PLATFORM", "egl")
