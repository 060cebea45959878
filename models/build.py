"""Compose the head MJCF (``models/head.xml``) with a scene preset and write it out."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ._gl import mujoco
from .scenes import SCENES, SceneInfo, add_scene

__all__ = ["HEAD_XML", "QUALITIES", "DEFAULT_FOVY_DEG", "DEFAULT_IPD", "ModelFileError",
           "build_spec", "build_model", "export_xml", "load_model"]

HEAD_XML = Path(__file__).with_name("head.xml")
#: Rendering quality presets: "fast" (no shadow map, no multisampling; the default, ~0.5 ms per
#: 128 px frame on Mesa) and "default" (MuJoCo's defaults: 4096 shadow map, 4x multisampling,
#: shadows on; ~20-30 ms per frame on Mesa).
QUALITIES: tuple[str, ...] = ("fast", "default")
#: Vertical (= horizontal, square images) field of view of each eye camera: +-35 deg around the
#: optical axis, covering flashes and targets up to ~24 deg from fixation after a 10 deg saccade.
DEFAULT_FOVY_DEG = 70.0
DEFAULT_IPD = 0.064
EYES = ("left_eye", "right_eye")


class ModelFileError(OSError):
    """An MJCF file that cannot be read or compiled."""


def _finite(x, name, lo, hi) -> float:
    x = float(x)
    if not np.isfinite(x) or not (lo <= x <= hi):
        raise ValueError(f"{name} must be a finite number in [{lo}, {hi}], got {x}")
    return x


def build_spec(scene: str | None = "dots", *, ipd: float = DEFAULT_IPD, fovy_deg: float = DEFAULT_FOVY_DEG,
               quality: str = "fast", offscreen_size: tuple[int, int] = (640, 480),
               head_xml: str | Path | None = None) -> tuple[mujoco.MjSpec, SceneInfo | None]:
    """Head + scene as an editable ``MjSpec`` and the scene's :class:`SceneInfo`.

    ``scene=None`` gives the head alone. ``ipd`` (m) sets the eye separation, ``fovy_deg`` both
    eye cameras' vertical field of view, ``quality`` one of :data:`QUALITIES`, ``offscreen_size``
    the largest (width, height) the off-screen renderer may use.
    """
    if scene is not None and scene not in SCENES:
        raise ValueError(f"unknown scene {scene!r}; choose one of {', '.join(SCENES)}")
    if quality not in QUALITIES:
        raise ValueError(f"unknown quality {quality!r}; choose one of {', '.join(QUALITIES)}")
    ipd = _finite(ipd, "ipd (metres)", 0.01, 0.15)
    fovy_deg = _finite(fovy_deg, "fovy_deg", 5.0, 170.0)
    path = Path(head_xml) if head_xml is not None else HEAD_XML
    try:
        spec = mujoco.MjSpec.from_file(str(path))
    except Exception as exc:  # mujoco raises ValueError for missing and malformed files alike
        raise ModelFileError(f"cannot read head model {path}: {exc}; pass a readable MJCF file") from exc
    for side, sign in (("left", 1.0), ("right", -1.0)):
        body = spec.body(f"{side}_eyeball")
        body.pos = [body.pos[0], sign * ipd / 2, body.pos[2]]
        spec.camera(f"{side}_eye").fovy = fovy_deg
    g = spec.visual.global_
    g.offwidth = max(int(g.offwidth), int(offscreen_size[0]))
    g.offheight = max(int(g.offheight), int(offscreen_size[1]))
    if quality == "default":
        spec.visual.quality.shadowsize = 4096
        spec.visual.quality.offsamples = 4
        for light in spec.lights:
            light.castshadow = True
    info = add_scene(spec, scene) if scene is not None else None
    return spec, info


def build_model(scene: str = "dots", **kwargs) -> mujoco.MjModel:
    """Compiled head + ``scene`` (one of :data:`SCENES`), fast rendering quality by default.

    The eye cameras are named ``left_eye`` and ``right_eye``; keyword arguments as
    :func:`build_spec`.
    """
    spec, _ = build_spec(scene, **kwargs)
    return spec.compile()


def export_xml(scene: str | None, path: str | Path, **kwargs) -> Path:
    """Write head + ``scene`` as one MJCF file (textures as PNG files beside it) that MuJoCo's own
    viewer opens: ``python -m mujoco.viewer --mjcf=PATH``."""
    spec, _ = build_spec(scene, **kwargs)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    for name, data in spec.assets.items():
        (path.parent / name).write_bytes(data)
    spec.compile()
    path.write_text(spec.to_xml())
    return path


def load_model(path: str | Path) -> mujoco.MjModel:
    """Load an MJCF file (e.g. one written by :func:`export_xml`) with a clear error if unreadable."""
    path = Path(path)
    try:
        return mujoco.MjModel.from_xml_path(str(path))
    except Exception as exc:
        raise ModelFileError(f"cannot load MJCF model {path}: {exc}") from exc
