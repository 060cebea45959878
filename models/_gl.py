"""Import MuJoCo with an off-screen GL backend chosen before the import.

``MUJOCO_GL`` defaults to ``egl`` (Mesa's software EGL works without a GPU); set
``MUJOCO_GL=osmesa`` to use OSMesa instead. This only takes effect if ``mujoco`` has not been
imported yet by someone else.
"""

from __future__ import annotations

import os

from ._gl_default import set_default_backend

set_default_backend()

__all__ = ["mujoco", "GLBackendError", "gl_install_hint"]

_HINTS = {
    "egl": "apt-get install libegl1 libegl-mesa0 libgl1-mesa-dri",
    "osmesa": "apt-get install libosmesa6",
}


def gl_install_hint(backend: str | None = None) -> str:
    """Which Debian packages provide the off-screen GL backend ``backend`` (a name such as ``"egl"``;
    default: MUJOCO_GL)."""
    if backend is not None and not isinstance(backend, str):
        raise TypeError(f"backend must be a GL backend name (str) or None; got {type(backend).__name__}")
    backend = (backend or os.environ.get("MUJOCO_GL", "egl")).lower()
    return _HINTS.get(
        backend,
        f"MUJOCO_GL={backend!r} is not an off-screen backend; use MUJOCO_GL=egl ({_HINTS['egl']}) "
        f"or MUJOCO_GL=osmesa ({_HINTS['osmesa']})",
    )


class GLBackendError(RuntimeError):
    """No usable off-screen OpenGL context; the message says which Debian packages to install."""


try:
    import mujoco
except (ImportError, AttributeError, OSError) as _exc:  # PyOpenGL fails inside mujoco's import
    raise GLBackendError(
        f"cannot import mujoco with MUJOCO_GL={os.environ['MUJOCO_GL']!r} ({type(_exc).__name__}: {_exc}). "
        f"Install the backend's Debian packages: {gl_install_hint()}"
    ) from _exc
