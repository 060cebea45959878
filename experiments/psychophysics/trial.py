"""One flash trial through the real pipeline (the paper's §6.5, Fig. 11).

Per trial: place fixation, target and one flash dot on the ``dots`` scene's screen, fixate,
start the saccade, step the simulation to the flash time, render a flash-free and a flash frame
(both eyes, same instants), each integrated over the flash's 8 ms (``Head.render(exposure_ms=8)``:
a flash during the saccade smears along its retinal path), and per eye:

1. the retina samples the difference frame (the flash's activity) and the DPFT transforms it
   (``envs.Vision.see``);
2. the efference copy -- the intended command, not the executed (noisy) movement -- gives the
   eye orientation for the middle of the flash (``plan.intended_angles``), hence the target's
   predicted image position z_T(t) (not measured from the image);
3. the DPFT series is evaluated at z_T(t) + z on a log-polar grid centred on the target
   (``conformal.predict`` with ``target_shift_map(z_T, 0, delta)``): the target-centred map;
4. ``conformal.log_radius_shift`` by gain(t)/delta rings compresses that map towards the target
   (§6.5: f(e^{g} z), distances shrink by e^{-g});
5. the activity centroid of the shifted map (``decode.activity_centroid``) is the perceived
   position relative to the target; z_T(t) + centroid is the perceived image point, which the
   **eye-position signal** turns into a ray: the brain's estimate of the eye's orientation
   (``plan.eye_position_signal``) at the time the flash's response reaches the comparator, the
   flash's middle plus the visual latency (``visual_latency_ms``, default
   ``models.VISUAL_LATENCY_MS``). The ray is intersected with the screen plane and expressed as
   head-centred (cyclopean) azimuth/elevation. ``eye_position="true"`` uses the true eye
   orientation at the flash instead (ground truth: the read-out of the earlier model).

The perceived position is the mean of the two eyes' estimates. The closed-form prediction (the
true image point moved towards z_T by e^{-g}, through the same geometry) is reported beside it.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass
from typing import cast, overload

import numpy as np

import conformal as C
import envs
import models

from .bounds import check_int, check_real
from .decode import activity_centroid, activity_covariance
from .design import Trial
from .mechanisms import CONDITIONS, MECHANISMS, MODELS, PARADIGMS
from .observer import ObserverParams
from .population import PopulationParams
from .snapshots import scene_state
from .targetmap import CentredSamples, TargetCentredMap
from .theories import theory
from .timecourse import RemapTimeCourse
from .trial_fields import TRIAL_CHOICES
from .trial_fields import TRIAL_DEFAULTS as _D

__all__ = [
    "TrialConfig",
    "TrialRunner",
    "Observation",
    "head_angles_deg",
    "ROW_COLUMNS",
    "TEXT_COLUMNS",
    "READOUT_PARAMETERS",
]

#: The displacement report's noise stream, ``default_rng([trial.seed, REPORT_NOISE_STREAM])``: apart
#: from the head's (``default_rng(trial.seed)``: landing scatter), so report and motor errors are independent.
REPORT_NOISE_STREAM = 1


def report_noise(seed: int, sd: float) -> float:
    """The displacement report's noise of the trial seeded ``seed``: N(0, sd^2) from its own stream
    (the head's landing scatter draws from ``default_rng(seed)``; sharing it made report noise cancel
    landing error, r = -0.97 on the scoreboard's tables); 0 when ``sd`` is 0."""
    return float(np.random.default_rng([seed, REPORT_NOISE_STREAM]).normal(0.0, sd)) if sd else 0.0


#: Eye-frame axes (x1 up, x2 optical axis, x3 right) in the head frame (x forward, y left, z up)
#: at zero Fick angles (the README's eye frame; ``models.oculomotor``'s primary position).
_PRIMARY_EYE_BASIS = np.column_stack([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])
#: Poses ``TrialRunner._pose`` remembers before it starts again (about 2.5 MB).
_POSE_CACHE = 4096

SCREEN_DISTANCE = 1.0  # the dots scene's screen, metres ahead of the cyclopean eye
_FLASH = "flash_00"
#: The frames a trial runner keeps (``models.Head.remember_frames``): ~330 frames at 256 px.
FRAME_MEMO_MB = 64.0
_FLASH2 = "flash_01"  # the second flash of the separation paradigm
#: The second flash of ``separation``: this far (azimuth, elevation deg) from the first.
SEPARATION_DEG = (4.0, 0.0)
#: Fixation before saccade onset (ms; longer if a flash comes earlier): onset at the same sim time in every trial.
FIXATION_MS = 200
#: Flash duration (ms); the retina integrates it (``Head.render(exposure_ms=...)``).
FLASH_MS = 8
#: The post-saccadic look at the references: this long after the saccade has settled (ms).
POST_SACCADE_MS = 100
#: A lit dot this close (deg) to a flash may share its image (the flash's radius, the dot's and the
#: eye's travel during the 8 ms flash at up to ~700 deg/s): the flash is then rendered over the dot
#: hidden, as the increment it is (``TrialRunner._increments``).
LIT_NEAR_DEG = 8.0
#: The ruler's elevation re the target (deg), as in the ``dots`` scene.
RULER_ELEVATION_DEG = models.scenes.RULER_ELEVATION_DEG

ROW_COLUMNS = (
    "trial_id",
    "repetition",
    "seed",
    "saccade_amplitude_deg",
    "flash_time_ms",
    "flash_dx_deg",
    "flash_dy_deg",
    "gain",
    "true_x_deg",
    "true_y_deg",
    "perceived_x_deg",
    "perceived_y_deg",
    "target_x_deg",
    "target_y_deg",
    "error_x_deg",
    "error_y_deg",
    "error_toward_x_deg",
    "error_toward_y_deg",
    "closed_form_x_deg",
    "closed_form_y_deg",
    "perceived_left_x_deg",
    "perceived_left_y_deg",
    "perceived_right_x_deg",
    "perceived_right_y_deg",
    "eye_h_left_deg",
    "eye_h_right_deg",
    "saccade_duration_ms",
    "flash_sim_ms",
    "reference_weight",
    "second_true_x_deg",
    "second_true_y_deg",
    "second_perceived_x_deg",
    "second_perceived_y_deg",
    "perceived_step_deg",
    "reported_forward",
    "reference_contrast",
    "reference_ms",
    "target_off_ms",
    "reference_activity",
    "n_markers",
    "ruler",
)
#: Columns that are NaN by design where they do not apply: the second flash of ``separation``, the
#: step of ``displacement``.
OPTIONAL_COLUMNS = {
    "separation": ("second_true_x_deg", "second_true_y_deg", "second_perceived_x_deg", "second_perceived_y_deg"),
    "displacement": ("perceived_step_deg", "reported_forward"),
}
#: Text columns of a trial's row (after ``ROW_COLUMNS``): the perception model, viewing condition, paradigm.
TEXT_COLUMNS = ("model", "condition", "paradigm")
#: Most markers a trial may show (the ``dots`` scene's ``marker_00`` ...).
MAX_MARKERS = models.scenes.N_MARKERS


@dataclass(frozen=True)
class TrialConfig:
    """Everything but the trial that fixes the result: head, retina, time course, read-out.

    image_size, fovy_deg, fovea_deg : eye image side (px), vertical field of view, foveal radius.
    timecourse : the ``paper`` model's remapping gain time course. threshold : centroid threshold.
    endpoint_noise : saccade endpoint noise (fraction of amplitude; 0 = none), seeded per trial.
    saccade_model, eye_drive, generator : the head's saccade model (``"burst"``/``"legacy"``), eye
        drive (``"plant"``/``"servo"``, part of the fingerprint) and burst generator (``models.Head``).
    eye_position : ``"signal"`` (default) or ``"true"`` (an oracle, for comparison) for the read-out.
    visual_latency_ms, eps_sigma_ms, eps_delay_ms : the flash's cortical delay (0-300 ms) and the
        eye-position signal's smoothing and delay (``models.EyePositionSignal``; 50, 50 ms).
    oversample, flash_radius_deg : read-out grid density; flash dot radius.
    model : ``"mechanistic"`` (default; ``feedback_gain``, ``reference_weight``, ``reference_unit``,
        ``disabled``) or ``"paper"`` (``timecourse``): ``mechanisms``.
    condition : ``"references"`` or ``"dark"``. paradigm : ``"localization"``, ``"separation"`` or
        ``"displacement"`` (``stability_tolerance``, ``report_noise_deg``).
    reference_contrast, reference_ms, target_off_ms, markers, ruler : the post-saccadic references.
    observer, population : those models' constants (``ObserverParams``, ``PopulationParams``).

    Bounds (``bounds.LIMITS``): image 32-1024 px, fovy 20-120 deg, fovea 0.25-10 deg (and under a
    quarter of fovy), threshold [0, 1), oversample 1-8, flash radius 0.1-5 deg, endpoint noise 0-0.5.
    Wrong types raise TypeError, values out of bounds ValueError. Each field in full:
    docs/psychophysics/run.md ("Flash localization", section "TrialConfig's fields").
    """

    image_size: int = _D["image_size"]
    fovy_deg: float = _D["fovy_deg"]
    fovea_deg: float = _D["fovea_deg"]
    timecourse: RemapTimeCourse = RemapTimeCourse()
    threshold: float = _D["threshold"]
    endpoint_noise: float = _D["endpoint_noise"]
    oversample: int = _D["oversample"]
    flash_radius_deg: float = _D["flash_radius_deg"]
    saccade_model: str = _D["saccade_model"]
    generator: models.BurstGenerator | None = None
    eye_drive: str = _D["eye_drive"]
    eye_position: str = _D["eye_position"]
    visual_latency_ms: float = _D["visual_latency_ms"]
    model: str = _D["model"]
    condition: str = _D["condition"]
    paradigm: str = _D["paradigm"]
    feedback_gain: float = _D["feedback_gain"]
    reference_weight: float = _D["reference_weight"]
    reference_unit: float = _D["reference_unit"]
    disabled: tuple = _D["disabled"]
    stability_tolerance: float = _D["stability_tolerance"]
    report_noise_deg: float = _D["report_noise_deg"]
    eps_sigma_ms: float = _D["eps_sigma_ms"]
    eps_delay_ms: float = _D["eps_delay_ms"]
    reference_contrast: float = _D["reference_contrast"]
    reference_ms: int = _D["reference_ms"]
    target_off_ms: int = _D["target_off_ms"]
    markers: tuple = _D["markers"]
    ruler: bool = _D["ruler"]
    observer: ObserverParams = ObserverParams()
    population: PopulationParams = PopulationParams()

    def __post_init__(self) -> None:
        # bounds: ``bounds.LIMITS`` (TypeError for wrong types, ValueError for NaN/inf/out of range)
        for name in ("image_size", "oversample", "reference_ms", "target_off_ms"):
            object.__setattr__(self, name, check_int(name, getattr(self, name)))
        for name in (
            "fovy_deg",
            "fovea_deg",
            "threshold",
            "flash_radius_deg",
            "endpoint_noise",
            "visual_latency_ms",
            "feedback_gain",
            "reference_weight",
            "reference_unit",
            "stability_tolerance",
            "report_noise_deg",
            "eps_sigma_ms",
            "eps_delay_ms",
            "reference_contrast",
        ):
            object.__setattr__(self, name, check_real(name, getattr(self, name)))
        object.__setattr__(self, "markers", _markers(self.markers))
        if not isinstance(self.ruler, (bool, np.bool_)):
            raise TypeError(f"ruler must be True or False; got {self.ruler!r:.60}")
        object.__setattr__(self, "ruler", bool(self.ruler))
        for name, kind in (("observer", ObserverParams), ("population", PopulationParams)):
            if not isinstance(getattr(self, name), kind):
                raise TypeError(f"{name} must be a {kind.__name__}; got {getattr(self, name)!r:.60}")
        if not isinstance(self.disabled, (tuple, list)) or not all(isinstance(d, str) for d in self.disabled):
            raise TypeError(
                f"disabled must be a tuple of mechanism names from {', '.join(MECHANISMS)}; got {self.disabled!r:.60}"
            )
        unknown = [d for d in self.disabled if d not in MECHANISMS]
        if unknown:
            raise ValueError(
                f"disabled: unknown mechanism(s) {', '.join(map(repr, unknown))}; choose from {', '.join(MECHANISMS)}"
            )
        object.__setattr__(self, "disabled", tuple(sorted(set(self.disabled))))
        for name, options in (
            ("saccade_model", models.SACCADE_MODELS),
            ("eye_drive", models.EYE_DRIVES),
            ("eye_position", TRIAL_CHOICES["eye_position"]),
            ("model", MODELS),
            ("condition", CONDITIONS),
            ("paradigm", PARADIGMS),
        ):
            value = getattr(self, name)
            if not isinstance(value, str):
                raise TypeError(f"{name} must be one of {', '.join(options)}; got {value!r:.60}")
            if value not in options:
                raise ValueError(f"{name} must be one of {', '.join(options)}; got {value!r:.60}")
        if self.generator is not None and not isinstance(self.generator, models.BurstGenerator):
            raise TypeError(f"generator must be a models.BurstGenerator or None; got {self.generator!r:.60}")
        if self.generator is not None and self.saccade_model != "burst":
            raise ValueError("generator configures saccade_model='burst'; the legacy planner has no burst generator")
        if not isinstance(self.timecourse, RemapTimeCourse):
            raise TypeError(f"timecourse must be a RemapTimeCourse; got {self.timecourse!r}")
        if self.fovea_deg >= self.fovy_deg / 4:
            raise ValueError(
                f"fovea_deg ({self.fovea_deg}) must be less than a quarter of fovy_deg "
                f"({self.fovy_deg}): the retina needs a periphery"
            )


def _markers(value) -> tuple:
    """``markers`` as a tuple of (dx, dy) float pairs, or TypeError/ValueError saying what is wrong."""
    from .design import _OFFSET_LIMIT

    if isinstance(value, (str, bytes, dict)) or not hasattr(value, "__iter__"):
        raise TypeError(f"markers must be a sequence of (dx, dy) pairs (deg from the target); got {value!r:.60}")
    out = []
    for p in value:
        if isinstance(p, (str, bytes)) or not hasattr(p, "__len__") or len(p) != 2:
            raise ValueError(f"markers must hold (dx, dy) pairs (deg from the target); got {p!r:.60}")
        out.append(tuple(check_real("markers", v, _OFFSET_LIMIT) for v in p))
    if len(out) > MAX_MARKERS:
        raise ValueError(f"at most {MAX_MARKERS} markers; got {len(out)}")
    return tuple(out)


#: ``TrialConfig`` fields that only the read-out uses: ``TrialRunner.readout`` may be given a config
#: that differs from the runner's in these (and only these), e.g. by a model fit.
READOUT_PARAMETERS = (
    "timecourse",
    "threshold",
    "eye_position",
    "visual_latency_ms",
    "model",
    "feedback_gain",
    "reference_weight",
    "reference_unit",
    "eps_sigma_ms",
    "eps_delay_ms",
    "observer",
    "population",
)
#: ``READOUT_PARAMETERS`` that ``TrialRunner.observe`` never reads (the others -- the model, the
#: centroid threshold, the eye-position signal's timing -- shape what it stores): an observation
#: cache need not be keyed on them.
READOUT_ONLY = (
    "timecourse",
    "eye_position",
    "visual_latency_ms",
    "feedback_gain",
    "reference_weight",
    "reference_unit",
    "observer",
    "population",
)


@dataclass
class Observation:
    """What ``TrialRunner.observe`` saw of a trial (see there); picklable."""

    trial: Trial
    plan: models.SaccadePlan
    t_abs: int
    t_mid: float
    exposure: float
    copy_pose: tuple
    flashes: list
    target_deg: np.ndarray
    eye_h: np.ndarray
    seen_z: list
    t_post: int
    ref_z: list | None = None  #: each eye's retinal centroid (image plane) of the post-saccadic references' activity
    ref_activity: np.ndarray | None = None  #: (2,) each eye's summed activity of them (image-plane area x intensity)
    ref_on_ms: float = 0.0  #: how long they were on after saccade offset
    #: each eye's landmarks among them (the connected parts of its picture of them): (z (L,) complex
    #: image-plane centroids, cov (L, 2, 2) image-plane covariances of their activity)
    ref_landmarks: list | None = None
    frame: object = None
    reference: object = None
    scene: dict | None = None  #: the MuJoCo scene with the (first) flash shown, and its world position (recordings)


def head_angles_deg(head: models.Head, points_world) -> np.ndarray:
    """Head-centred (azimuth > 0 right, elevation > 0 up) angles in degrees of world points
    (N, 3) from the cyclopean eye, along the screen axes (the inverse of ``models.screen_point``)."""
    p = np.atleast_2d(np.asarray(points_world, float))
    d = np.stack([head.to_head(q) for q in p]) - head.to_head(head.cyclopean_position)
    return np.degrees(np.column_stack([np.arctan2(-d[:, 1], d[:, 0]), np.arctan2(d[:, 2], d[:, 0])]))


def _screen_world(az_deg: float, el_deg: float) -> np.ndarray:
    return models.screen_point(math.radians(az_deg), math.radians(el_deg), SCREEN_DISTANCE)


class TrialRunner:
    """One Head (``dots`` scene) and one ``envs.Vision`` reused for many trials (one per process)."""

    def __init__(self, config: TrialConfig = TrialConfig()) -> None:
        self.config = config
        self.head = models.Head(
            "dots",
            int(config.image_size),
            fovy_deg=config.fovy_deg,
            endpoint_noise=config.endpoint_noise,
            saccade_model=config.saccade_model,
            generator=config.generator,
            eye_drive=config.eye_drive,
            eye_position=models.EyePositionSignal(config.eps_sigma_ms, config.eps_delay_ms),
        )
        # each eye's nodal point relative to its rotation centre, in the eye's own frame (constant)
        states = self.head.eye_states()
        self._centres = self.head.eye_centres_head
        self._poses: dict[bytes, tuple[np.ndarray, np.ndarray]] = {}  # _pose's results by the angles' bytes
        self._cyclopean: tuple[bytes, np.ndarray | None] = (b"", None)  # _ray_to_screen_deg's, by head pose
        R = [models.fick_matrix(*a) for a in self.head.eye_angles]
        self._nodal = [R[e].T @ (self.head.to_head(states[e].camera_position) - self._centres[e]) for e in range(2)]
        h, w = self.head.image_shape
        self.vision = envs.Vision((h, w), self.head.pixels_per_unit, fovea_deg=config.fovea_deg, grayscale=True)
        self.retina_grid = self.vision.grid
        self.map = TargetCentredMap(self.retina_grid, config.oversample)
        self.grid = self.map.grid  # the target-centred (read-out) grid
        # flash and target dots of the flash's size (the scene's default is ~0.46 deg: sub-pixel at 128 px)
        for name in (_FLASH, _FLASH2, "target"):
            self.head.set_sphere_radius(name, SCREEN_DISTANCE * math.tan(math.radians(config.flash_radius_deg)))
        # the flash-free and post-saccadic frames recur across a study's flashes: drawn once each
        self.head.remember_frames(FRAME_MEMO_MB)
        self.last: dict | None = None  # the last trial's frames and maps (for recordings)

    def close(self) -> None:
        self.head.close()

    # ------------------------------------------------------------------ geometry helpers
    def _pose(self, angles: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Head-frame eye axes (2, 3, 3) (columns x1, x2, x3) and nodal points (2, 3) for Fick angles (2, 3)
        (read-only arrays, remembered by the angles' bytes: a fit reads the same trials' poses out at
        every evaluation)."""
        a = np.asarray(angles, np.float64)
        key = a.tobytes()
        pose = self._poses.get(key)
        if pose is None:
            R = models.fick_matrix(a[:, 0], a[:, 1], a[:, 2])
            origins = np.stack([self._centres[e] + R[e] @ self._nodal[e] for e in range(2)])
            pose = (R @ _PRIMARY_EYE_BASIS, origins)
            for arr in pose:
                arr.setflags(write=False)
            if len(self._poses) >= _POSE_CACHE:
                self._poses.clear()
            self._poses[key] = pose
        return pose

    def _ray_to_screen_deg(self, origin_head: np.ndarray, axes: np.ndarray, z: complex) -> np.ndarray:
        """Head-centred angles (deg) where the ray of image point z (eye axes ``axes``) meets the screen."""
        d = axes @ np.array([z.imag, 1.0, z.real])
        x, R = self.head.head_pose()
        key = x.tobytes() + R.tobytes()
        if self._cyclopean[0] != key:  # the cyclopean eye in the head frame, for this head pose
            self._cyclopean = (key, self.head.to_head(self.head.cyclopean_position))
        c = cast(np.ndarray, self._cyclopean[1])
        s = (c[0] + SCREEN_DISTANCE - origin_head[0]) / d[0]
        p = origin_head + s * d - c
        return np.degrees([math.atan2(-p[1], p[0]), math.atan2(p[2], p[0])])

    # ------------------------------------------------------------------ one trial
    def _show(self, t_ms: float, plan: models.SaccadePlan, references: bool | None = None) -> None:
        """The stimulus schedule's visible objects at ``t_ms``: in the dark the screen is black and the
        target goes off at saccade onset; with references the target is lit until ``target_off_ms``
        after onset (at ``reference_contrast`` from onset), and the ruler and markers appear at
        saccade offset, for ``reference_ms``. ``references`` overrides whether the post-saccadic
        references are on (for rendering them with and without)."""
        cfg, head = self.config, self.head
        dark = cfg.condition == "dark"
        rel = t_ms - plan.onset_ms
        post_window = plan.offset_ms <= t_ms < plan.offset_ms + cfg.reference_ms
        target_on = (not (dark and rel >= 0)) and rel < cfg.target_off_ms and (t_ms < plan.offset_ms or post_window)
        post_on = (not dark) and post_window
        if references is not None:
            post_on = references and not dark and cfg.reference_ms > 0
            target_on = (
                references and not dark and cfg.target_off_ms > plan.offset_ms - plan.onset_ms and cfg.reference_ms > 0
            )
        # MuJoCo blends a transparent geom's back and front faces: opacity a shows 1 - (1 - a)^2 of its
        # contrast, so contrast c needs a = 1 - sqrt(1 - c) (tests/test_perception_theories.py measures it)
        alpha = 1.0 - math.sqrt(1.0 - cfg.reference_contrast)
        head.set_opacity("target", (alpha if rel >= 0 else 1.0) if target_on else 0.0)
        head.set_opacity("ruler", alpha if post_on and cfg.ruler else 0.0)
        for i in range(MAX_MARKERS):
            head.set_opacity(f"marker_{i:02d}", alpha if post_on and i < len(cfg.markers) else 0.0)

    def _references_seen(self, plan: models.SaccadePlan) -> tuple[list[complex], np.ndarray, list]:
        """Each eye's retinal centroid and summed activity of the post-saccadic references as they
        are shown after saccade offset (rendered with them minus without them), at the current time;
        and each eye's landmarks: the connected parts of its picture of them (8-connected pixels the
        references brighten), each one's centroid and covariance (``decode.activity_covariance``)."""
        head = self.head
        t = float(head.time_ms)
        self._show(t, plan, references=True)
        lit = head.render()
        self._show(t, plan, references=False)
        unlit = head.render()
        self._show(t, plan)
        zs, act, landmarks = [], [], []
        areas = self.retina_grid.cell_areas()[:, None]
        for a, b in ((lit.left, unlit.left), (lit.right, unlit.right)):
            diff = np.clip(a.image.astype(float) - b.image.astype(float), 0, None) / 255.0
            view = self.vision.see(diff)
            zs.append(self._centroid(view, self.retina_grid))
            per = np.where(view.mask, view.periphery.sum(axis=-1), 0.0)
            fov = np.where(view.fovea_mask, view.fovea.sum(axis=-1), 0.0)
            act.append(float((per * areas).sum() + fov.sum() * self.retina_grid.fovea_spacing**2))
            landmarks.append(self._landmarks(diff))
        return zs, np.array(act), landmarks

    def _landmarks(self, diff: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The connected parts of a picture of increments (H, W, 3): each one's retinal centroid (L,)
        and activity covariance (L, 2, 2) in the image plane; parts the retina does not sample (off
        its field) are left out."""
        from scipy import ndimage

        labels, n = ndimage.label(diff.mean(axis=-1) > 0, structure=np.ones((3, 3), bool))
        zs, covs = [], []
        for k in range(1, n + 1):
            view = self.vision.see(np.where((labels == k)[..., None], diff, 0.0))
            # all of its light (threshold 0): a picture's samples do not ring as a remapped map does, and
            # a cut at a share of the peak would drop a long thin landmark's dim peripheral cells
            z = self._centroid(view, self.retina_grid, threshold=0.0)
            if np.isfinite(z.real):
                zs.append(z)
                covs.append(
                    activity_covariance(
                        view.periphery,
                        view.fovea,
                        self.retina_grid,
                        mask=view.mask,
                        fovea_mask=view.fovea_mask,
                        threshold=0.0,
                    )
                )
        return np.array(zs, complex), np.array(covs, float).reshape(-1, 2, 2)

    @overload
    def _centroid(
        self, view, grid, centred: None = None, shift_rings: float = 0.0, threshold: float | None = None
    ) -> complex: ...
    @overload
    def _centroid(
        self, view, grid, centred: CentredSamples, shift_rings: float = 0.0, threshold: float | None = None
    ) -> tuple[complex, np.ndarray]: ...
    def _centroid(
        self,
        view,
        grid,
        centred: CentredSamples | None = None,
        shift_rings: float = 0.0,
        threshold: float | None = None,
    ) -> complex | tuple[complex, np.ndarray]:
        """Activity centroid of a view (retina grid) or of a target-centred map shifted by ``shift_rings``."""
        thr = self.config.threshold if threshold is None else threshold
        if centred is None:
            return activity_centroid(
                view.periphery, view.fovea, grid, mask=view.mask, fovea_mask=view.fovea_mask, threshold=thr
            )
        per = C.log_radius_shift(centred.periphery, grid, shift_rings) if shift_rings else centred.periphery
        return activity_centroid(per, centred.fovea, grid, fovea_mask=centred.fovea_mask, threshold=thr), per

    def _seen_target_retina(self, plan: models.SaccadePlan) -> tuple[list[complex], int]:
        """After the saccade (100 ms after it has settled): each eye's retinal image point of the
        target (NaN where the retina saw none), and that time. Steps the head on to it."""
        head = self.head
        t_post = max(head.time_ms, plan.end_ms + POST_SACCADE_MS)
        head.step_ms(t_post - head.time_ms)
        self._show(t_post, plan)
        zs = self._target_image_points()
        self._show(t_post, plan)
        return zs, int(t_post)

    def _place_markers(self, trial: Trial) -> None:
        for i, (dx, dy) in enumerate(self.config.markers):
            self.head.set_object_position(
                f"marker_{i:02d}", _screen_world(trial.target_deg[0] + dx, trial.target_deg[1] + dy)
            )

    def _target_image_points(self) -> list[complex]:
        """Each eye's retinal image point of the target as the scene is now: the centroid of the
        retina's response to the target (a render with it minus one without; NaN where the retina
        sees none, e.g. when it is off). Leaves the target shown."""
        head = self.head
        lit = head.render()
        head.set_visible("target", False)
        unlit = head.render()
        head.set_visible("target", True)
        zs = []
        for a, b in ((lit.left, unlit.left), (lit.right, unlit.right)):
            diff = np.clip(a.image.astype(float) - b.image.astype(float), 0, None) / 255.0
            zs.append(self._centroid(self.vision.see(diff), self.retina_grid))
        return zs

    def run(self, trial: Trial) -> dict:
        """Run one trial; returns its table row (see ``ROW_COLUMNS`` and ``TEXT_COLUMNS``):
        ``readout(observe(trial))``."""
        if self.config.paradigm == "displacement":
            return self._run_displacement(trial)
        return self.readout(self.observe(trial))

    def stage(self, trial: Trial) -> tuple[models.SaccadePlan, int, tuple]:
        """Put the head where the trial's flash finds it: the scene laid out, the saccade started,
        the simulation stepped to the flash's onset (the flash itself not shown). Returns the plan,
        the flash's sim time and the world positions of target, flash and second flash."""
        head, cfg = self.head, self.config
        fix_w = _screen_world(*trial.fixation_deg)
        tgt_w = _screen_world(*trial.target_deg)
        fl_w = _screen_world(*trial.flash_deg)
        fl2_w = _screen_world(trial.flash_deg[0] + SEPARATION_DEG[0], trial.flash_deg[1] + SEPARATION_DEG[1])
        latency = max(FIXATION_MS, 1 - int(trial.flash_time_ms))
        head.reset(seed=trial.seed, fixate=fix_w)
        head.set_visible("screen", cfg.condition != "dark")
        head.set_object_position("fixation", fix_w)
        head.set_object_position("target", tgt_w)
        head.set_object_position("ruler", _screen_world(trial.target_deg[0], trial.target_deg[1] + RULER_ELEVATION_DEG))
        head.set_object_position(_FLASH, fl_w)
        head.set_object_position(_FLASH2, fl2_w)
        self._place_markers(trial)
        plan = head.plan_saccade_to(tgt_w, latency_ms=latency)
        head.start_saccade(plan)
        t_abs = plan.onset_ms + int(trial.flash_time_ms)
        head.step_ms(t_abs - head.time_ms)
        self._show(t_abs, plan)
        return plan, t_abs, (tgt_w, fl_w, fl2_w)

    def observe(self, trial: Trial) -> Observation:
        """The stimulus and the retina's response to it: everything of a trial that the read-out's
        parameters (``READOUT_PARAMETERS``) do not change -- the saccade, the rendered and
        integrated frames, each flash's retina, DPFT and target-centred map, the post-saccadic
        retinal image of the target."""
        if self.config.paradigm == "displacement":
            raise ValueError(
                "observe/readout split the localization and separation paradigms; "
                "the displacement paradigm runs with run()"
            )
        head, cfg = self.head, self.config
        mech_smear = theory(cfg.model).mechanisms_on(cfg)["smear"]
        two = cfg.paradigm == "separation"
        plan, t_abs, (tgt_w, fl_w, fl2_w) = self.stage(trial)
        exposure = FLASH_MS if mech_smear else 0
        ref = head.render(exposure_ms=exposure)
        frames = []
        scene = None
        names = (_FLASH, _FLASH2) if two else (_FLASH,)
        for name in names:  # simultaneous flashes, read out one by one
            head.flash(name, FLASH_MS)
            frames.append(head.render(exposure_ms=exposure))
            if scene is None:
                scene = {**scene_state(head), "flash_world": np.asarray(fl_w, float)}
            head.hide_flashes()
        increments = self._increments(trial, names, exposure) if self._lit_near(trial, two) else (ref, frames)
        eye_h = np.degrees(head.eye_angles[:, 0])
        t_mid = t_abs + exposure / 2  # the middle of the flash's retinal image
        copy_pose = self._pose(plan.intended_angles(t_mid))  # efference copy: where the target is
        tgt_h = head.to_head(plan.intended_target)
        flashes = []
        inc_ref, inc_frames = increments
        for frame, w in zip(inc_frames, (fl_w, fl2_w)):
            eyes = []
            for e, (img, img0) in enumerate(((frame.left, inc_ref.left), (frame.right, inc_ref.right))):
                diff = np.clip(img.image.astype(float) - img0.image.astype(float), 0, None) / 255.0
                view = self.vision.see(diff)
                ca, co = copy_pose[0][e], copy_pose[1][e]
                xt = ca.T @ (tgt_h - co)
                z_t = complex(xt[2], xt[0]) / xt[1]
                eyes.append((view, self.map.sample(view.coeffs, view.fovea, z_t), z_t))
            flashes.append({"eyes": eyes, "head": head.to_head(w), "true_deg": head_angles_deg(head, w)[0]})
        seen_z, t_post = self._seen_target_retina(plan)
        ref_z, ref_act, landmarks = self._references_seen(plan)
        return Observation(
            trial=trial,
            plan=plan,
            t_abs=t_abs,
            t_mid=t_mid,
            exposure=exposure,
            copy_pose=copy_pose,
            flashes=flashes,
            target_deg=head_angles_deg(head, tgt_w)[0],
            eye_h=eye_h,
            seen_z=seen_z,
            t_post=t_post,
            frame=frames[0],
            reference=ref,
            ref_z=ref_z,
            ref_activity=ref_act,
            ref_landmarks=landmarks,
            ref_on_ms=float(min(cfg.reference_ms, 1000)),
            scene=scene,
        )

    def _lit_near(self, trial: Trial, two: bool) -> list[str]:
        """The lit dots (fixation point, target, markers: opacity > 0 now) whose direction lies within
        ``LIT_NEAR_DEG`` of a flash of the trial: where their image and the flash's can overlap."""
        flashes = [np.array(trial.flash_deg)]
        if two:
            flashes.append(flashes[0] + np.array(SEPARATION_DEG))
        dots = {"fixation": trial.fixation_deg, "target": trial.target_deg}
        dots.update(
            {
                f"marker_{i:02d}": (trial.target_deg[0] + dx, trial.target_deg[1] + dy)
                for i, (dx, dy) in enumerate(self.config.markers)
            }
        )
        rgba = self.head.model.geom_rgba
        return [
            n
            for n, d in dots.items()
            if rgba[self.head.model.geom(n).id, 3] > 0 and min(math.dist(d, f) for f in flashes) < LIT_NEAR_DEG
        ]

    def _increments(self, trial: Trial, names: tuple, exposure: float) -> tuple:
        """The flash-free frame and each flash's frame with the lit dots near a flash hidden (the same
        instants): their difference is the flash's luminance increment, also where it falls on a lit
        dot -- a flash on the fixation point or target is seen, as it is by a person (the
        renderer's saturated white would otherwise hide it). The dots' opacities are restored."""
        head = self.head
        near = self._lit_near(trial, len(names) > 1)
        rgba = head.model.geom_rgba
        saved = {n: float(rgba[head.model.geom(n).id, 3]) for n in near}
        for n in near:
            head.set_opacity(n, 0.0)
        try:
            ref = head.render(exposure_ms=exposure)
            frames = []
            for name in names:
                head.flash(name, FLASH_MS)
                frames.append(head.render(exposure_ms=exposure))
                head.hide_flashes()
        finally:
            for n, a in saved.items():
                head.set_opacity(n, a)
        return ref, frames

    def readout(self, obs: Observation, config: TrialConfig | None = None) -> dict:
        """The perceived position(s) of an observed trial under ``config`` (default: the runner's;
        only its ``READOUT_PARAMETERS`` may differ from the runner's): the trial's table row."""
        cfg = config or self.config
        trial, plan = obs.trial, obs.plan
        eps = models.EyePositionSignal(cfg.eps_sigma_ms, cfg.eps_delay_ms)
        if plan.eye_position != eps:
            plan = plan.with_eye_position(eps)  # the same validated plan, read through another signal timing
        true_pose = self._pose(plan.angles(obs.t_mid))
        reads, gain, weight = theory(cfg.model).read(self, obs, plan, true_pose, cfg)
        perceived, closed, maps = reads[0]
        self.last = dict(frame=obs.frame, reference=obs.reference, maps=maps, plan=plan, scene=obs.scene)

        true, target = obs.flashes[0]["true_deg"], obs.target_deg
        p = _mean_of_eyes(perceived)
        cf = np.mean(np.array(closed), axis=0)
        err = p - true
        toward = np.sign(target - true) * err
        if len(obs.flashes) > 1:
            true2, p2 = obs.flashes[1]["true_deg"], _mean_of_eyes(reads[1][0])
        else:
            true2 = p2 = np.full(2, np.nan)  # one flash: the second-flash columns do not apply
        eye_h = obs.eye_h
        return {
            "trial_id": trial.trial_id,
            "repetition": trial.repetition,
            "seed": trial.seed,
            "saccade_amplitude_deg": trial.amplitude_deg,
            "flash_time_ms": int(trial.flash_time_ms),
            "flash_dx_deg": trial.flash_dx_deg,
            "flash_dy_deg": trial.flash_dy_deg,
            "gain": gain,
            "true_x_deg": true[0],
            "true_y_deg": true[1],
            "perceived_x_deg": p[0],
            "perceived_y_deg": p[1],
            "target_x_deg": target[0],
            "target_y_deg": target[1],
            "error_x_deg": err[0],
            "error_y_deg": err[1],
            "error_toward_x_deg": toward[0],
            "error_toward_y_deg": toward[1],
            "closed_form_x_deg": cf[0],
            "closed_form_y_deg": cf[1],
            "perceived_left_x_deg": perceived[0][0],
            "perceived_left_y_deg": perceived[0][1],
            "perceived_right_x_deg": perceived[1][0],
            "perceived_right_y_deg": perceived[1][1],
            "eye_h_left_deg": eye_h[0],
            "eye_h_right_deg": eye_h[1],
            "saccade_duration_ms": plan.duration_ms,
            "flash_sim_ms": obs.t_abs,
            "reference_weight": weight,
            "second_true_x_deg": true2[0],
            "second_true_y_deg": true2[1],
            "second_perceived_x_deg": p2[0],
            "second_perceived_y_deg": p2[1],
            "perceived_step_deg": float("nan"),
            "reported_forward": float("nan"),
            **self._stimulus_columns(cfg, obs.ref_activity),
        }

    def _stimulus_columns(self, cfg: TrialConfig, activity) -> dict:
        """The row's stimulus description: reference visibility and timing, markers, the labels."""
        act = float(np.nanmean(activity)) if activity is not None and np.isfinite(activity).any() else 0.0
        return {
            "reference_contrast": cfg.reference_contrast,
            "reference_ms": cfg.reference_ms,
            "target_off_ms": cfg.target_off_ms,
            "reference_activity": act,
            "model": cfg.model,
            "condition": cfg.condition,
            "paradigm": cfg.paradigm,
            "n_markers": len(cfg.markers),
            "ruler": float(cfg.ruler),
        }

    # ------------------------------------------------------------------ the theories' read-outs
    def plain_maps(self, flash: dict, threshold: float) -> list:
        """Each eye's maps of a flash, as the shift read-out gives them for recordings: the retina's view, the
        target-centred map (unshifted: the theories do not shift it), the predicted target point and
        the flash's unremapped position relative to it (the activity centroid above ``threshold``)."""
        out = []
        for view, centred, z_t in flash["eyes"]:
            z_rel, per = self._centroid(view, self.grid, centred, 0.0, threshold)
            out.append((view, centred, per, z_t, z_rel))
        return out

    def _target_seen(
        self, t_ms: int, plan: models.SaccadePlan, latency: float, true_eye: bool = False
    ) -> tuple[np.ndarray, float, list[complex]]:
        """Step to ``t_ms``; the target's head-centred position (deg, mean of the eyes) as seen then
        through the eye-position signal of ``t_ms + latency`` (or the true eye), its retinal offset
        from the fovea (deg), and each eye's retinal image point of it."""
        self.head.step_ms(t_ms - self.head.time_ms)
        zs = self._target_image_points()
        axes, origins = self._pose(plan.angles(float(t_ms)) if true_eye else plan.eye_position_signal(t_ms + latency))
        pos, off = [], []
        for e, z in enumerate(zs):
            pos.append(self._ray_to_screen_deg(origins[e], axes[e], z) if np.isfinite(z.real) else np.full(2, np.nan))
            off.append(math.degrees(math.atan(abs(z))) if np.isfinite(z.real) else np.nan)
        return _mean_of_eyes(pos), float(np.nanmean(off)) if np.isfinite(off).any() else float("nan"), zs

    def _run_displacement(self, trial: Trial) -> dict:
        """Saccadic suppression of displacement (Bridgeman, Hendry & Stark 1975; Deubel, Schneider &
        Bridgeman 1996): the target steps by ``trial.flash_dx_deg`` (deg along the saccade) 10 ms
        after saccade onset and, with a blank, is off from then until ``trial.flash_time_ms`` after
        the saccade's offset. The step's perceived size compares the target seen after the saccade
        (through the eye-position signal) with the target seen before it; with ``references`` on, a
        target seen at landing within the range of normal landing errors (``stability_tolerance`` x
        amplitude, as a Gaussian weight) is taken as stable -- the anchored route: no step -- the
        stability assumption of Deubel et al. 1996, whenever the target is seen (blank or not).
        Reports "forward" when the perceived step plus Gaussian report noise (``report_noise_deg``,
        seeded per trial) is positive. The ``observer`` model compares the target's positions
        through its own eye-position estimate (``observer.eye_estimate``) and its noise is its own:
        the sensory and eye-position variances of both looks."""
        head, cfg = self.head, self.config
        model = theory(cfg.model)
        on = model.mechanisms_on(cfg)
        blank = int(trial.flash_time_ms)
        if blank < 0:
            raise ValueError(f"the displacement paradigm's flash_times_ms are blank durations (ms >= 0); got {blank}")
        latency = cfg.visual_latency_ms if on["latency"] else 0.0
        fix_w = _screen_world(*trial.fixation_deg)
        tgt_w = _screen_world(*trial.target_deg)
        step_w = _screen_world(trial.target_deg[0] + trial.flash_dx_deg, trial.target_deg[1] + trial.flash_dy_deg)
        head.reset(seed=trial.seed, fixate=fix_w)
        head.set_visible("screen", cfg.condition != "dark")
        head.set_object_position("fixation", fix_w)
        head.set_object_position("target", tgt_w)
        plan = head.plan_saccade_to(tgt_w, latency_ms=FIXATION_MS)
        head.start_saccade(plan)
        use_eps = cfg.eye_position == "signal" and on["eye_position_signal"]
        t_pre = plan.onset_ms - 150
        pre, _, pre_z = self._target_seen(t_pre, plan, latency, not use_eps)  # before the saccade: settled
        head.step_ms(plan.onset_ms + 10 - head.time_ms)
        head.set_object_position("target", step_w)
        if blank:
            head.set_visible("target", False)
        t_seen = int(math.ceil(plan.offset_ms)) + blank
        head.step_ms(t_seen - head.time_ms)
        head.set_visible("target", True)
        post, mismatch, post_z = self._target_seen(t_seen, plan, latency, not use_eps)
        sd = cfg.report_noise_deg
        looks = model.displacement_looks(self, plan, ((t_pre, pre_z), (t_seen, post_z)), cfg)
        if looks is not None:  # the theory's own looks and noise on the step
            pre, post, sd = looks
        weight = model.stability_weight(cfg, mismatch, trial.amplitude_deg, on)
        step = (1.0 - weight) * float(post[0] - pre[0])
        noise = report_noise(trial.seed, sd)
        true = head_angles_deg(head, step_w)[0]
        target = head_angles_deg(head, tgt_w)[0]
        err = post - true
        eye_h = np.degrees(head.eye_angles[:, 0])
        self.last = dict(plan=plan, report_sd_deg=float(sd))  # the report's s.d. (crossval's P(forward))
        return {
            "trial_id": trial.trial_id,
            "repetition": trial.repetition,
            "seed": trial.seed,
            "saccade_amplitude_deg": trial.amplitude_deg,
            "flash_time_ms": blank,
            "flash_dx_deg": trial.flash_dx_deg,
            "flash_dy_deg": trial.flash_dy_deg,
            "gain": 0.0,
            "true_x_deg": true[0],
            "true_y_deg": true[1],
            "perceived_x_deg": post[0],
            "perceived_y_deg": post[1],
            "target_x_deg": target[0],
            "target_y_deg": target[1],
            "error_x_deg": err[0],
            "error_y_deg": err[1],
            "error_toward_x_deg": np.sign(target[0] - true[0]) * err[0],
            "error_toward_y_deg": np.sign(target[1] - true[1]) * err[1],
            "closed_form_x_deg": true[0],
            "closed_form_y_deg": true[1],
            "perceived_left_x_deg": post[0],
            "perceived_left_y_deg": post[1],
            "perceived_right_x_deg": post[0],
            "perceived_right_y_deg": post[1],
            "eye_h_left_deg": eye_h[0],
            "eye_h_right_deg": eye_h[1],
            "saccade_duration_ms": plan.duration_ms,
            "flash_sim_ms": t_seen,
            "reference_weight": weight,
            "second_true_x_deg": float("nan"),
            "second_true_y_deg": float("nan"),
            "second_perceived_x_deg": float("nan"),
            "second_perceived_y_deg": float("nan"),
            "perceived_step_deg": step,
            # a target the theory lost after the saccade (no activity to read out) gives no report, not "backward"
            "reported_forward": float(step + noise > 0) if math.isfinite(step) else float("nan"),
            **self._stimulus_columns(cfg, None),
        }


def _mean_of_eyes(perceived: list) -> np.ndarray:
    with warnings.catch_warnings():  # both eyes lost the flash: NaN, reported by the study, not a warning
        warnings.simplefilter("ignore", RuntimeWarning)
        return np.nanmean(np.array(perceived), axis=0)
