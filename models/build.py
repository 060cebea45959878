"""Compose the head MJCF (``models/head.xml``) with a scene preset and write it out."""

from __future__ import annotations

from pathlib import Path
from typing import Literal, overload

from conformal import checks

from ._gl import mujoco
from .scenes import SCENES, SceneInfo, add_scene

__all__ = [
    "HEAD_XML",
    "QUALITIES",
    "DEFAULT_FOVY_DEG",
    "DEFAULT_IPD",
    "ModelFileError",
    "build_spec",
    "build_model",
    "export_xml",
    "load_model",
]

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
#: The largest off-screen buffer side (pixels) a model may ask for.
MAX_OFFSCREEN_SIDE = 4096


class ModelFileError(OSError):
    """An MJCF file that cannot be read or compiled."""


@overload
def _path(name: str, value, *, allow_none: Literal[False] = False) -> Path: ...
@overload
def _path(name: str, value, *, allow_none: bool) -> Path | None: ...
def _path(name: str, value, *, allow_none: bool = False) -> Path | None:
    """``value`` as a non-empty ``Path`` (``str`` or ``os.PathLike``)."""
    if value is None and allow_none:
        return None
    if not isinstance(value, (str, Path)) and not hasattr(value, "__fspath__"):
        raise checks.InputTypeError(f"{name} must be a file path (str or Path); got {type(value).__name__}")
    if str(value) == "":
        raise ValueError(f"{name} must be a non-empty file path")
    return Path(value)


def _offscreen_size(size) -> tuple[int, int]:
    if isinstance(size, (str, bytes)) or not hasattr(size, "__len__"):
        raise checks.InputTypeError(f"offscreen_size must be a (width, height) pair; got {size!r}")
    if len(size) != 2:
        raise ValueError(f"offscreen_size must be a (width, height) pair; got {tuple(size)!r}")
    w, h = (checks.integer(f"offscreen_size[{i}]", v, 1, MAX_OFFSCREEN_SIDE) for i, v in enumerate(size))
    return w, h


def build_spec(
    scene: str | None = "dots",
    *,
    ipd: float = DEFAULT_IPD,
    fovy_deg: float = DEFAULT_FOVY_DEG,
    quality: str = "fast",
    offscreen_size: tuple[int, int] = (640, 480),
    head_xml: str | Path | None = None,
) -> tuple[mujoco.MjSpec, SceneInfo | None]:
    """Head + scene as an editable ``MjSpec`` and the scene's :class:`SceneInfo`.

    ``scene=None`` gives the head alone. ``ipd`` (m) sets the eye separation, ``fovy_deg`` both
    eye cameras' vertical field of view, ``quality`` one of :data:`QUALITIES`, ``offscreen_size``
    the largest (width, height) the off-screen renderer may use (each in [1, 4096]).
    """
    if scene is not None and scene not in SCENES:
        raise (ValueError if isinstance(scene, str) else checks.InputTypeError)(
            f"unknown scene {scene!r}; choose one of {', '.join(SCENES)}"
        )
    if quality not in QUALITIES:
        raise (ValueError if isinstance(quality, str) else checks.InputTypeError)(
            f"unknown quality {quality!r}; choose one of {', '.join(QUALITIES)}"
        )
    ipd = checks.real("ipd (metres)", ipd, 0.01, 0.15)
    fovy_deg = checks.real("fovy_deg", fovy_deg, 5.0, 170.0)
    width, height = _offscreen_size(offscreen_size)
    path = _path("head_xml", head_xml, allow_none=True) or HEAD_XML
    try:
        spec = mujoco.MjSpec.from_file(str(path))
    except Exception as exc:  # mujoco raises ValueError for missing and malformed files alike
        raise ModelFileError(f"cannot read head model {path}: {exc}; pass a readable MJCF file") from exc
    for side, sign in (("left", 1.0), ("right", -1.0)):
        body = spec.body(f"{side}_eyeball")
        body.pos = [body.pos[0], sign * ipd / 2, body.pos[2]]
        spec.camera(f"{side}_eye").fovy = fovy_deg
    g = spec.visual.global_
    g.offwidth = max(int(g.offwidth), width)
    g.offheight = max(int(g.offheight), height)
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
    path = _path("path", path)
    if path.is_dir():
        raise ValueError(f"path {path} is a folder; give the MJCF file to write, e.g. {path / 'head.xml'}")
    spec, _ = build_spec(scene, **kwargs)
    spec.compile()
    _write_spec(spec, path)
    return path


def _write_spec(spec: mujoco.MjSpec, path: Path) -> None:
    """Write ``spec`` as MJCF to ``path`` and its assets beside it; ``ModelFileError`` if that fails."""
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        for name, data in spec.assets.items():
            (path.parent / name).write_bytes(data)
        path.write_text(spec.to_xml())
    except OSError as exc:
        raise ModelFileError(
            f"cannot write the model to {path}: {exc.strerror or exc}; choose a writable path"
        ) from exc


def load_model(path: str | Path) -> mujoco.MjModel:
    """Load an MJCF file (e.g. one written by :func:`export_xml`) with a clear error if unreadable."""
    path = _path("path", path)
    try:
        return mujoco.MjModel.from_xml_path(str(path))
    except Exception as exc:
        raise ModelFileError(f"cannot load MJCF model {path}: {exc}") from exc
