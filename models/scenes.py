"""Named scene presets composed with the head through ``mujoco.MjSpec``.

Every scene is placed in front of the head (which faces +x); distances are measured from the
cyclopean eye centre ``CYCLOPEAN_EYE`` (midway between the eyes' rotation centres, head at rest).
Objects the experiments address by name are mocap bodies (movable at run time through
``Head.set_object_position``) carrying a geom of the same name; flashes are switched by the
geom's alpha (alpha 0 is not drawn by MuJoCo).

Presets (``SCENES``):

``bar``      Turski's Fig. 7: a grey square (40 cm) 1.3 m ahead with a red bar (4 x 30 cm) in
             front of it at 1.0 m, on a black background.
``dots``     The flash paradigm of Fig. 11 (after Lappe et al. 2000, Nature 403:892): on a dark
             screen 1 m ahead, a red fixation point straight ahead, a yellow saccade target 10 deg
             to the right and an array of 24 flash dots (6 columns at -5..20 deg x 4 rows at
             +-2.5, +-7.5 deg), all invisible until flashed (~8 ms).
``natural``  A 1/f-noise textured backdrop 4 m ahead and floor, with textured objects at 1.2, 1.8,
             2.6 and 3.2 m. Textures are generated procedurally (seeded), nothing is downloaded.
``search``   Conjunction visual search on a grey screen 1 m ahead: a red sphere (target) among
             green spheres and red cubes (distractors), positions on a jittered 5-deg grid within
             +-20 deg x +-15 deg, re-drawn from the seed at each reset; white fixation point ahead.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from conformal import checks

from ._gl import mujoco
from ._png import encode_png

__all__ = ["SCENES", "SceneInfo", "CYCLOPEAN_EYE", "screen_point", "add_scene", "pink_noise"]

#: Cyclopean eye centre (world, metres) with the neck at rest; matches models/head.xml.
CYCLOPEAN_EYE = np.array([0.082, 0.0, 1.2])
CYCLOPEAN_EYE.setflags(write=False)

SCENES: tuple[str, ...] = ("bar", "dots", "natural", "search")

DOTS_DISTANCE = 1.0
DOTS_TARGET_DEG = 10.0
FLASH_AZIMUTHS_DEG = (-5.0, 0.0, 5.0, 10.0, 15.0, 20.0)
FLASH_ELEVATIONS_DEG = (7.5, 2.5, -2.5, -7.5)
#: The dots scene's ruler: elevation re the target row and half width (deg).
RULER_ELEVATION_DEG, RULER_HALF_WIDTH_DEG = -10.0, 20.0
DOT_RADIUS = 0.008
#: Hidden marker dots of the ``dots`` scene (``marker_00`` ...): extra visual references.
N_MARKERS = 4
SEARCH_DISTANCE = 1.0
SEARCH_N_GREEN_SPHERES = 8
SEARCH_N_RED_CUBES = 8

_G = mujoco.mjtGeom


def screen_point(azimuth: float, elevation: float, distance: float) -> np.ndarray:
    """World point on the frontoparallel plane ``distance`` m ahead of the cyclopean eye, seen at
    ``azimuth`` (radians, > 0 right) and ``elevation`` (radians, > 0 up) along the screen axes, both
    in (-pi/2, pi/2); ``distance`` in (0, 1000] m."""
    azimuth = checks.real("azimuth", azimuth, -np.pi / 2, np.pi / 2, lo_open=True, hi_open=True, hint="radians")
    elevation = checks.real("elevation", elevation, -np.pi / 2, np.pi / 2, lo_open=True, hi_open=True, hint="radians")
    distance = checks.real("distance", distance, 0.0, 1000.0, lo_open=True, hint="metres")
    return CYCLOPEAN_EYE + distance * np.array([1.0, -np.tan(azimuth), np.tan(elevation)])


@dataclass
class SceneInfo:
    """What a scene contains: a description, named object groups, where to fixate by default,
    and (optionally) a seeded layout function re-drawn at reset."""

    name: str
    description: str
    groups: dict[str, tuple[str, ...]] = field(default_factory=dict)
    movable: tuple[str, ...] = ()  #: objects that are mocap bodies (positions settable)
    default_fixation: str | np.ndarray = "fixation"
    layout: Callable[[np.random.Generator], dict[str, np.ndarray]] | None = None
    flashes: tuple[str, ...] = ()  #: objects hidden until flashed

    def __post_init__(self) -> None:
        for name in ("name", "description"):
            if not isinstance(getattr(self, name), str):
                raise checks.InputTypeError(f"{name} must be a str; got {getattr(self, name)!r:.60}")

        def names(what, value) -> tuple[str, ...]:
            if (
                isinstance(value, str)
                or not isinstance(value, (tuple, list))
                or not all(isinstance(n, str) for n in value)
            ):
                raise checks.InputTypeError(f"{what} must be a tuple of object names (str); got {value!r:.60}")
            return tuple(value)

        if not isinstance(self.groups, dict) or not all(isinstance(k, str) for k in self.groups):
            raise checks.InputTypeError(f"groups must be a dict of group name -> object names; got {self.groups!r:.60}")
        self.groups = {k: names(f"groups[{k!r}]", v) for k, v in self.groups.items()}
        self.movable = names("movable", self.movable)
        self.flashes = names("flashes", self.flashes)
        if not isinstance(self.default_fixation, str):
            p = checks.array("default_fixation", self.default_fixation, kinds="biuf", shape=(3,))
            self.default_fixation = p.astype(float)
        if self.layout is not None:
            checks.callable_("layout", self.layout)

    @property
    def objects(self) -> tuple[str, ...]:
        """All named objects."""
        out: list[str] = []
        for names in self.groups.values():
            out.extend(n for n in names if n not in out)
        return tuple(out)


def _mocap(spec, name, pos, **geom) -> None:
    body = spec.worldbody.add_body(name=name, mocap=True, pos=list(map(float, pos)))
    body.add_geom(name=name, contype=0, conaffinity=0, **geom)


def _static(spec, name, pos, **geom) -> None:
    spec.worldbody.add_geom(name=name, pos=list(map(float, pos)), contype=0, conaffinity=0, **geom)


def _screen(spec, distance, rgba, half=(0.9, 0.65)) -> None:
    p = CYCLOPEAN_EYE + np.array([distance + 0.01, 0.0, 0.0])
    _static(spec, "screen", p, type=_G.mjGEOM_BOX, size=[0.002, half[0], half[1]], rgba=list(rgba))


def _bar(spec) -> SceneInfo:
    _static(
        spec, "square", CYCLOPEAN_EYE + [1.3, 0, 0], type=_G.mjGEOM_BOX, size=[0.005, 0.2, 0.2], rgba=[0.5, 0.5, 0.5, 1]
    )
    _static(
        spec,
        "bar",
        CYCLOPEAN_EYE + [1.0, 0, 0],
        type=_G.mjGEOM_BOX,
        size=[0.01, 0.02, 0.15],
        rgba=[0.85, 0.05, 0.05, 1],
    )
    return SceneInfo(
        "bar",
        "Fig. 7: grey square with a red bar in front of it",
        groups={"square": ("square",), "bar": ("bar",)},
        default_fixation=CYCLOPEAN_EYE + np.array([1.0, 0.0, 0.0]),
    )


def _dots(spec) -> SceneInfo:
    _screen(spec, DOTS_DISTANCE, [0.12, 0.12, 0.12, 1])
    dot = dict(type=_G.mjGEOM_SPHERE, size=[DOT_RADIUS, 0, 0])
    _mocap(spec, "fixation", screen_point(0, 0, DOTS_DISTANCE), rgba=[1, 0.1, 0.1, 1], **dot)
    _mocap(spec, "target", screen_point(np.deg2rad(DOTS_TARGET_DEG), 0, DOTS_DISTANCE), rgba=[1, 0.9, 0.1, 1], **dot)
    flash_names: list[str] = []
    for _r, el in enumerate(FLASH_ELEVATIONS_DEG):
        for _c, az in enumerate(FLASH_AZIMUTHS_DEG):
            name = f"flash_{len(flash_names):02d}"
            _mocap(
                spec, name, screen_point(np.deg2rad(az), np.deg2rad(el), DOTS_DISTANCE), rgba=[0.3, 1, 0.3, 0], **dot
            )
            flash_names.append(name)
    flashes = tuple(flash_names)
    # a visual reference (Lappe, Awater & Krekelberg 2000): a horizontal ruler 10 deg below the
    # target, hidden until shown (``Head.set_visible("ruler", True)``); movable like the target
    el = np.deg2rad(RULER_ELEVATION_DEG)
    _mocap(
        spec,
        "ruler",
        screen_point(np.deg2rad(DOTS_TARGET_DEG), el, DOTS_DISTANCE),
        type=_G.mjGEOM_BOX,
        size=[0.002, DOTS_DISTANCE * np.tan(np.deg2rad(RULER_HALF_WIDTH_DEG)), 0.008],
        rgba=[0.9, 0.9, 0.9, 0],
    )
    # extra post-saccadic markers (hidden until shown): visual references away from the target
    markers = tuple(f"marker_{i:02d}" for i in range(N_MARKERS))
    for i, name in enumerate(markers):
        _mocap(
            spec,
            name,
            screen_point(np.deg2rad(DOTS_TARGET_DEG), np.deg2rad(-4.0 * (i + 1)), DOTS_DISTANCE),
            rgba=[0.2, 0.6, 1.0, 0],
            **dot,
        )
    return SceneInfo(
        "dots",
        f"Fig. 11 flash paradigm: fixation, saccade target, 24 flash dots, a ruler and {N_MARKERS} markers (hidden)",
        groups={
            "fixation": ("fixation",),
            "target": ("target",),
            "flashes": flashes,
            "references": ("ruler",),
            "markers": markers,
        },
        movable=("fixation", "target", "ruler") + markers + flashes,
        flashes=flashes,
    )


def pink_noise(shape: tuple[int, int], rng: np.random.Generator, exponent: float = 1.0) -> np.ndarray:
    """Isotropic 1/f^exponent amplitude-spectrum noise scaled to [0, 1] (natural-image statistics,
    Field 1987)."""
    fy = np.fft.fftfreq(shape[0])[:, None]
    fx = np.fft.rfftfreq(shape[1])[None, :]
    f = np.hypot(fy, fx)
    f[0, 0] = 1.0
    spec = (rng.standard_normal(f.shape) + 1j * rng.standard_normal(f.shape)) / f**exponent
    spec[0, 0] = 0
    img = np.fft.irfft2(spec, s=shape)
    img -= img.min()
    return img / max(img.max(), 1e-12)


def _texture(spec, name, rng, c0, c1, size=256) -> str:
    n = pink_noise((size, size), rng)[..., None]
    rgb = (255 * ((1 - n) * np.asarray(c0) + n * np.asarray(c1))).clip(0, 255).astype(np.uint8)
    fname = f"{name}.png"
    spec.assets[fname] = encode_png(rgb)
    ttype = mujoco.mjtTexture.mjTEXTURE_2D if name.endswith("2d") else mujoco.mjtTexture.mjTEXTURE_CUBE
    spec.add_texture(name=name, type=ttype, file=fname)
    spec.add_material(
        name=name, textures=["", name], texrepeat=[1, 1], texuniform=not name.startswith(("backdrop", "floor"))
    )
    return name


def _natural(spec, seed: int = 0) -> SceneInfo:
    rng = np.random.default_rng(seed)
    back = _texture(spec, "backdrop_2d", rng, (0.25, 0.35, 0.2), (0.75, 0.8, 0.65), 512)
    floor = _texture(spec, "floor_2d", rng, (0.3, 0.22, 0.15), (0.7, 0.6, 0.45), 256)
    objs = {
        "box_near": (1.2, 0.25, -0.15, _G.mjGEOM_BOX, [0.08, 0.08, 0.08], ((0.5, 0.1, 0.1), (1, 0.6, 0.4))),
        "sphere_mid": (1.8, -0.35, 0.05, _G.mjGEOM_SPHERE, [0.12, 0, 0], ((0.1, 0.2, 0.5), (0.6, 0.8, 1))),
        "cylinder_far": (2.6, 0.6, -0.2, _G.mjGEOM_CYLINDER, [0.12, 0.35, 0], ((0.4, 0.4, 0.1), (1, 1, 0.6))),
        "box_far": (3.2, -0.9, 0.2, _G.mjGEOM_BOX, [0.25, 0.25, 0.25], ((0.3, 0.1, 0.4), (0.9, 0.7, 1))),
    }
    _static(
        spec,
        "backdrop",
        CYCLOPEAN_EYE + [4.0, 0, 0.3],
        type=_G.mjGEOM_PLANE,
        size=[6.0, 3.0, 0.1],
        zaxis=[-1, 0, 0],
        material=back,
    )
    _static(spec, "floor", [2.1, 0, 0], type=_G.mjGEOM_PLANE, size=[2.0, 6.0, 0.1], material=floor)
    for name, (dx, dy, dz, gtype, size, cols) in objs.items():
        mat = _texture(spec, f"{name}_2d", rng, *cols, size=128)
        _static(spec, name, CYCLOPEAN_EYE + [dx, dy, dz], type=gtype, size=size, material=mat)
    return SceneInfo(
        "natural",
        "1/f-textured backdrop (4 m) and floor with objects at 1.2-3.2 m",
        groups={"backdrop": ("backdrop", "floor"), "objects": tuple(objs)},
        default_fixation=CYCLOPEAN_EYE + np.array([1.8, -0.35, 0.05]),
    )


_SEARCH_CELLS = np.array(
    [(a, e) for a in np.arange(-20, 21, 5.0) for e in np.arange(-15, 16, 5.0) if (a, e) != (0.0, 0.0)]
)
_SEARCH_NAMES = ["target"] + [f"distractor_{i:02d}" for i in range(SEARCH_N_GREEN_SPHERES + SEARCH_N_RED_CUBES)]


class _SearchLayout:
    """Target and distractors in distinct cells of a 5 deg grid (not the centre), jittered by +-1 deg:
    called with a generator, name -> world position; :meth:`many` lays out many worlds at once."""

    names = tuple(_SEARCH_NAMES)

    def _pick(self, rng: np.random.Generator) -> np.ndarray:
        n = len(self.names)
        return _SEARCH_CELLS[rng.choice(len(_SEARCH_CELLS), size=n, replace=False)] + rng.uniform(
            -1.0, 1.0, size=(n, 2)
        )

    @staticmethod
    def _points(pick: np.ndarray) -> np.ndarray:
        """``screen_point`` of each (azimuth, elevation) (..., 2) in degrees, |angles| <= 21 deg (checked
        by construction): (..., 3), elementwise."""
        t = np.tan(np.deg2rad(pick))
        return CYCLOPEAN_EYE + SEARCH_DISTANCE * np.stack([np.ones(t.shape[:-1]), -t[..., 0], t[..., 1]], axis=-1)

    def __call__(self, rng: np.random.Generator) -> dict[str, np.ndarray]:
        return dict(zip(self.names, self._points(self._pick(rng))))

    def many(self, rngs) -> tuple[tuple[str, ...], np.ndarray]:
        """The layouts of many worlds, each drawn from its own generator as a call draws it: the objects'
        names and their positions (len(rngs), objects, 3), the same numbers as calls one by one."""
        picks = np.array([self._pick(rng) for rng in rngs]).reshape(len(rngs), len(self.names), 2)
        return self.names, self._points(picks)


_search_layout = _SearchLayout()


def _search(spec) -> SceneInfo:
    _screen(spec, SEARCH_DISTANCE, [0.45, 0.45, 0.45, 1])
    _mocap(
        spec,
        "fixation",
        screen_point(0, 0, SEARCH_DISTANCE),
        type=_G.mjGEOM_SPHERE,
        size=[0.004, 0, 0],
        rgba=[1, 1, 1, 1],
    )
    layout = _search_layout(np.random.default_rng(0))
    names = list(layout)
    _mocap(spec, "target", layout["target"], type=_G.mjGEOM_SPHERE, size=[0.012, 0, 0], rgba=[0.9, 0.1, 0.1, 1])
    distractors = names[1:]
    for i, nm in enumerate(distractors):
        if i < SEARCH_N_GREEN_SPHERES:
            _mocap(spec, nm, layout[nm], type=_G.mjGEOM_SPHERE, size=[0.012, 0, 0], rgba=[0.1, 0.75, 0.1, 1])
        else:
            _mocap(spec, nm, layout[nm], type=_G.mjGEOM_BOX, size=[0.004, 0.011, 0.011], rgba=[0.9, 0.1, 0.1, 1])
    return SceneInfo(
        "search",
        "Conjunction search: red sphere among green spheres and red cubes",
        groups={"fixation": ("fixation",), "target": ("target",), "distractors": tuple(distractors)},
        movable=("fixation", "target") + tuple(distractors),
        layout=_search_layout,
    )


_BUILDERS: dict[str, Callable] = {"bar": _bar, "dots": _dots, "natural": _natural, "search": _search}


def add_scene(spec, scene: str) -> SceneInfo:
    """Add preset ``scene`` (one of :data:`SCENES`) to a head ``MjSpec``; returns its description.

    To add a scene: write ``_myscene(spec) -> SceneInfo`` adding geoms/mocap bodies to
    ``spec.worldbody`` and register it in ``_BUILDERS`` and ``SCENES``.
    """
    if scene not in _BUILDERS:
        raise ValueError(f"unknown scene {scene!r}; choose one of {', '.join(SCENES)}")
    return _BUILDERS[scene](spec)
