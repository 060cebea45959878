"""models: the burst-generator saccades against the published main sequence, the honest efference
copy and motor noise, the eye-position signal, vergence and the smear of a flash on the retina.

Every expectation comes from a published number (cited beside the assertion) or a geometric
construction, measured on the physics traces (``Head.step_ms(record=True)``), never from the
generator's own formulas.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import models
from models import BurstGenerator, Head
from models.saccade_generator import PARAMETER_BOUNDS, simulate

THRESHOLD = 30.0  # deg/s: saccade detection threshold (e.g. EyeLink's default)


@pytest.fixture(scope="module")
def head():
    with Head("dots", image_size=32, seed=0) as h:
        yield h


def run(head: Head, start_deg, end_deg, distance: float = 1.0, end_distance: float | None = None):
    """Fixate ``start_deg`` (azimuth, elevation) and saccade to ``end_deg``; returns the plan and the trace."""
    head.reset(fixate=models.screen_point(*np.radians(start_deg), distance))
    target = models.screen_point(*np.radians(end_deg), distance if end_distance is None else end_distance)
    plan = head.plan_saccade_to(target, latency_ms=20)
    head.start_saccade(plan)
    tr = head.step_ms(plan.end_ms - head.time_ms + 30, record=True)
    return plan, tr


def kinematics(tr, eye: int, comp: slice | int = 0) -> dict:
    """Peak speed, duration and skewness of one eye from a trace (threshold crossings)."""
    w = np.degrees(tr.velocities[:, eye, comp])
    speed = np.abs(w) if w.ndim == 1 else np.hypot(w[:, 0] * np.cos(tr.angles[:, eye, 1]), w[:, 1])
    t = tr.times_ms
    above = np.flatnonzero(speed > THRESHOLD)
    t0, t1 = t[above[0]], t[above[-1]]
    return {"peak": speed.max(), "duration": t1 - t0, "skew": (t[np.argmax(speed)] - t0) / (t1 - t0),
            "speed": speed, "t": t, "t0": t0, "t1": t1}


AMPS = (2, 5, 10, 20, 30, 40, 50)


@pytest.fixture(scope="module")
def horizontal(head):
    """Rightward horizontal saccades centred on straight ahead, both eyes."""
    out = {}
    for a in AMPS:
        plan, tr = run(head, (-a / 2, 0.0), (a / 2, 0.0))
        out[a] = (plan, tr, [kinematics(tr, e) for e in range(2)])
    return out


def vw_vo_peak(a):
    """Van Wetter & Van Opstal (2008), J Vision 8(14):8: Vpk (1 - exp(-A/m0)), 0.525 deg/ms, m0 7 deg."""
    return 525.0 * (1 - math.exp(-a / 7.0))


@pytest.mark.parametrize("a", AMPS)
def test_peak_velocity_follows_the_main_sequence(horizontal, a):
    plan, tr, k = horizontal[a]
    peak = np.mean([k[0]["peak"], k[1]["peak"]])
    assert peak < 700.0  # the default generator: an average person (Collewijn et al. 1988: ~500 deg/s)
    if a >= 40:
        # Collewijn, Erkelens & Steinman (1988), J Physiol 404:157, abstract: peak velocity saturates
        # at 502 +- 32 (SD) deg/s for saccades of 40 deg and larger; we accept +-2 SD
        assert abs(peak - 502.0) < 64.0, peak
    # Van Wetter & Van Opstal (2008): their fitted human main sequence, within 15 %
    assert abs(peak / vw_vo_peak(a) - 1) < 0.15, (peak, vw_vo_peak(a))


@pytest.mark.parametrize("a", AMPS)
def test_duration_is_linear_in_amplitude(horizontal, a):
    plan, tr, k = horizontal[a]
    dur = np.mean([k[0]["duration"], k[1]["duration"]])
    # Carpenter (1988), Movements of the Eyes, 2nd ed.: D = 2.2 A + 21 ms; +-20 % covers the spread
    # between subjects and recording methods (Collewijn et al. 1988: duration linear up to 50 deg)
    assert abs(dur / (2.2 * a + 21.0) - 1) < 0.20, (dur, 2.2 * a + 21.0)


def test_skewness_falls_with_amplitude(horizontal):
    skew = {a: np.mean([horizontal[a][2][e]["skew"] for e in range(2)]) for a in AMPS}
    # Collewijn et al. (1988), abstract: skewness (acceleration time / duration) about 0.45 for
    # saccades up to 10 deg, falling to about 0.20 for 50 deg and larger; tolerance +-0.08
    for a in (2, 5, 10):
        assert abs(skew[a] - 0.45) < 0.08, skew
    assert abs(skew[50] - 0.20) < 0.08, skew
    assert skew[10] > skew[20] > skew[30] > skew[40] > skew[50], skew


@pytest.mark.parametrize("a", (2, 5, 10))
def test_velocity_is_a_bell_peaking_before_mid_saccade(horizontal, a):
    """Small saccades: one velocity peak, rising and falling smoothly (no jump at onset, unlike
    the legacy E(t)), for each eye; the version velocity (mean of the eyes) peaks before the middle
    of the movement (skewness ~0.45 < 0.5, Collewijn et al. 1988)."""
    plan, tr, ks = horizontal[a]
    for k in ks:
        sp, t = k["speed"], k["t"]
        i = np.argmax(sp)
        inside = (t >= k["t0"]) & (t <= k["t1"])
        rise, fall = np.diff(sp[: i + 1][inside[: i + 1]]), np.diff(sp[i:][inside[i:]])
        assert np.all(rise > -1e-6) and np.all(fall < 1e-6)  # unimodal
        # the first physics step after onset moves at well under the peak speed (a gradual start)
        assert sp[np.searchsorted(t, plan.onset_ms + 0.25)] < 0.2 * sp[i]
    version = np.abs(np.degrees(tr.velocities[:, :, 0].mean(axis=1)))
    t = tr.times_ms
    above = np.flatnonzero(version > THRESHOLD)
    assert t[np.argmax(version)] < 0.5 * (t[above[0]] + t[above[-1]])


@pytest.mark.parametrize("a", (5, 10, 20, 30, 40, 50))
def test_abducting_eye_is_faster_and_shorter(horizontal, a):
    """Collewijn et al. (1988), abstract: the abducting eye's saccade has a higher peak velocity and
    a shorter duration than the adducting eye's, so the eyes diverge transiently (up to a few
    degrees); both land together. Rightward: the right eye abducts. (Their abducting saccades are
    also larger and more skewed; the model's are not -- see models.saccade_generator.)"""
    plan, tr, (left, right) = horizontal[a]
    assert right["peak"] > left["peak"] and right["duration"] < left["duration"]
    h = np.degrees(tr.angles[:, :, 0])
    divergence = (h[:, 1] - h[:, 0]) - (h[0, 1] - h[0, 0])
    assert 0.2 < divergence.max() < 3.5, divergence.max()
    assert abs(divergence[-1] - np.degrees(np.diff(plan.end_angles[:, 0]) - np.diff(plan.start_angles[:, 0]))[0]) < 0.01


@pytest.mark.parametrize("a", (2, 10, 30, 50))
def test_oblique_saccades_are_straight_and_share_one_burst(head, a):
    """A 45-deg oblique saccade: one vector burst drives both components (component stretching:
    Van Gisbergen, Van Opstal & Schoenmakers 1985), so the path is nearly straight and the vector
    main sequence matches the horizontal one (same amplitude: same peak speed within 15 %)."""
    c = a / math.sqrt(2) / 2
    plan, tr = run(head, (-c, -c), (c, c))
    for e in range(2):
        k = kinematics(tr, e, slice(0, 2))
        assert k["peak"] < 700
        assert abs(k["peak"] / vw_vo_peak(a) - 1) < 0.15
        hv = np.degrees(tr.angles[:, e, :2])
        d = hv[-1] - hv[0]
        u = d / np.linalg.norm(d)
        off = np.abs(u[0] * (hv[:, 1] - hv[0, 1]) - u[1] * (hv[:, 0] - hv[0, 0]))  # distance from the chord
        assert off.max() < 0.05 * a, off.max()


def test_tracking_error_stays_small(horizontal):
    for a in AMPS:
        plan, tr, _ = horizontal[a]
        assert np.degrees(np.abs(tr.angles - tr.planned)).max() < 0.01  # the servo follows the command


def test_the_default_stays_average_and_the_family_reaches_fast_people():
    """The default generator is an average person: below 700 deg/s at every amplitude (Collewijn,
    Erkelens & Steinman 1988: saturation at 502 +- 32 deg/s). The family's ceiling is not a person's:
    hand-labelled EyeLink saccades reach 540-690 deg/s at 13-20 deg (issue 35), so a generator within
    ``PARAMETER_BOUNDS`` must reach ~700 deg/s at 20 deg and load; one past the family's ceiling
    (``models.MAX_PEAK_VELOCITY_DEG_S``, the eye-tracker reader's plausibility limit) is refused when
    its table is built."""
    for a in np.linspace(0.1, 90.0, 25):
        assert BurstGenerator().profile(float(a)).peak_velocity_deg_s < 700.0
    fast = BurstGenerator(burst_max_deg_s=1050.0, burst_scale_deg=1.0)
    assert 700.0 <= fast.profile(20.0).peak_velocity_deg_s < 760.0
    assert max(fast.profile(float(a)).peak_velocity_deg_s for a in (40.0, 60.0, 90.0)) < models.MAX_PEAK_VELOCITY_DEG_S
    for name, value in (("burst_max_deg_s", 1050.0), ("burst_scale_deg", 1.0)):
        lo, hi = PARAMETER_BOUNDS[name]
        assert lo < value < hi
    g = BurstGenerator(burst_max_deg_s=1800.0, adaptation_gain=0.0)
    with pytest.raises(ValueError, match="1000 deg/s"):
        g.profile(30.0)


def test_the_ceiling_is_the_readers_plausibility_limit():
    """One number: a saccade the eye-tracker reader keeps is never faster than the family can go."""
    from experiments.oculomotor.eyetracking import MAX_PLAUSIBLE_VELOCITY_DEG_S

    assert models.MAX_PEAK_VELOCITY_DEG_S == MAX_PLAUSIBLE_VELOCITY_DEG_S


@pytest.mark.slow
def test_profile_table_matches_a_direct_simulation():
    """The per-process table interpolated in amplitude agrees with the loop simulated for that amplitude."""
    g = BurstGenerator()
    for a in (0.6, 3.1, 12.37, 47.9, 88.0):
        pos, _ = simulate(g, np.array([a]), every=5)
        t = np.arange(pos.shape[1]) * 0.25
        p = g.profile(a)
        for plant in range(3):
            assert np.abs(pos[plant, :, 0] - a * p.position(t, plant)).max() < 0.011  # incl. the 0.01 deg settle snap


# ------------------------------------------------------------------ noise and efference copy
def test_efference_copy_is_the_intended_command_not_the_noisy_movement():
    plans = {}
    for noise in (0.0, 0.1):
        with Head("dots", image_size=16, seed=7, endpoint_noise=noise) as h:
            h.reset()
            plan = h.plan_saccade(math.radians(15.0), math.radians(5.0))
            h.start_saccade(plan)
            tr = h.step_ms(plan.end_ms - h.time_ms + 5, record=True)
            plans[noise] = (plan, tr, h.eye_angles)
    (p0, _, _), (p1, tr1, eyes1) = plans[0.0], plans[0.1]
    assert np.allclose(p0.efference_copy, p1.efference_copy, atol=1e-12)  # unchanged by the noise
    assert np.allclose(p0.executed_rotation, p0.efference_copy, atol=1e-12)
    assert not np.allclose(p1.executed_rotation, p1.efference_copy, atol=1e-4)
    # the eye really lands on the executed endpoint, the reported error is its distance from the intended one
    assert np.degrees(np.abs(eyes1 - p1.end_angles)).max() < 0.02
    g_true = models.gaze_direction(eyes1[:, 0], eyes1[:, 1])
    g_int = models.gaze_direction(p1.intended_end_angles[:, 0], p1.intended_end_angles[:, 1])
    err = np.degrees(np.arccos(np.clip((g_true * g_int).sum(1), -1, 1)))
    assert np.allclose(err, p1.endpoint_error_deg, atol=0.02) and err.min() > 0.05
    # traces carry both commands: the executed one (planned) and the intended one
    assert np.allclose(tr1.intended[-1], p1.intended_end_angles) and np.allclose(tr1.planned[-1], p1.end_angles)


def test_endpoint_scatter_grows_with_amplitude_and_is_seeded():
    """Signal-dependent noise: the s.d. of the endpoint error is a fixed fraction of the amplitude
    (van Beers 2007, J Neurosci 27:8757; Kowler & Blaser 1995, Vision Res 35:1741: ~5-10 %)."""
    sd = {}
    for a in (4.0, 16.0):
        errs = []
        with Head("dots", image_size=16, seed=3, endpoint_noise=0.08) as h:
            for i in range(120):
                h.reset(seed=i)
                errs.append(h.plan_saccade(math.radians(a), 0.0).endpoint_error_deg.mean())
        sd[a] = float(np.sqrt(np.mean(np.square(errs)) / 2))  # radial error -> per-axis s.d.
    assert abs(sd[4.0] / (0.08 * 4.0) - 1) < 0.3 and abs(sd[16.0] / (0.08 * 16.0) - 1) < 0.3, sd
    assert 2.5 < sd[16.0] / sd[4.0] < 5.5, sd
    a, b = (Head("dots", image_size=16, seed=11, endpoint_noise=0.05) for _ in range(2))
    with a, b:
        assert np.array_equal(a.plan_saccade(0.2, 0.0).end_angles, b.plan_saccade(0.2, 0.0).end_angles)


# ------------------------------------------------------------------ eye-position signal
def test_eye_position_signal_is_slow_and_ends_on_the_intended_endpoint():
    """In flash time (the signal paired with a flash at t is the one at t + visual latency), the
    signal starts to move ~100 ms before the saccade and settles ~100+ ms after it: Honda (1991),
    Vision Res 31:1915; Dassonville, Schlag & Schlag-Rey (1992), Vis Neurosci 9:261 ("a damped
    representation"). It comes from the command, so after a noisy saccade it is off the true eye."""
    with Head("dots", image_size=16, seed=5, endpoint_noise=0.1) as h:
        h.reset()
        plan = h.plan_saccade(math.radians(20.0), 0.0, latency_ms=200)
        h.start_saccade(plan)
        h.step_ms(plan.end_ms - h.time_ms + 400)
        lat, on = models.VISUAL_LATENCY_MS, plan.onset_ms
        t = on + np.arange(-300, 401, 1.0)
        eps = plan.eye_position_signal(t + lat)[:, :, 0]
        frac = (eps - plan.start_angles[:, 0]) / (plan.intended_end_angles[:, 0] - plan.start_angles[:, 0])
        frac = frac.mean(axis=1)
        rel = t - on
        start, half = rel[np.argmax(frac > 0.05)], rel[np.argmax(frac > 0.5)]
        end = rel[np.argmax(frac > 0.95)]
        assert -160 <= start <= -50, start  # begins ~100 ms before onset
        assert -50 <= half <= 50, half  # half-way around onset
        assert plan.offset_ms - on + 20 <= end <= 250, end  # settles ~100 ms after onset, well after the saccade
        # the true eye moves only from onset on; the signal at the comparator lags it
        assert np.allclose(plan.angles(on - 1.0), plan.start_angles)
        # after the saccade: the signal holds the intended endpoint, the eye the executed one
        assert np.allclose(h.eye_position_signal(), plan.intended_end_angles, atol=1e-9)
        assert np.degrees(np.abs(h.eye_position_signal() - h.eye_angles)).max() > 0.1


def test_next_saccade_signal_starts_where_the_last_signal_ended():
    with Head("dots", image_size=16, seed=5, endpoint_noise=0.1) as h:
        h.reset()
        first = h.saccade_to(h.object_position("target"), after_ms=300)
        second = h.plan_saccade(-0.1, 0.0)
        assert np.allclose(second.signal_start_angles, first.intended_end_angles, atol=1e-9)
        assert np.allclose(second.start_angles, first.end_angles)


# ------------------------------------------------------------------ vergence
def test_vergence_is_slower_than_version_and_sped_up_by_the_saccade(head):
    """A gaze shift from far (1 m) to near (0.3 m) and 10 deg right. Disparity vergence takes
    several hundred ms (Rashbass & Westheimer 1961, J Physiol 159:339), much longer than the
    saccade; during a saccade it is faster than alone (Enright 1984, J Physiol 350:9; Zee et al.
    1992, J Neurophysiol 68:1624)."""
    plan, tr = run(head, (0.0, 0.0), (10.0, 0.0), distance=1.0, end_distance=0.3)
    h = np.degrees(tr.angles[:, :, 0])
    verg = h[:, 0] - h[:, 1]  # convergence (left eye turns right)
    t = tr.times_ms - plan.onset_ms
    frac = (verg - verg[0]) / (verg[-1] - verg[0])
    k = kinematics(tr, 0)
    t90_verg = t[np.argmax(frac > 0.9)]
    assert verg[-1] - verg[0] > 5.0  # converging by several degrees
    assert t90_verg > 200 and t90_verg > 3 * (k["t1"] - plan.onset_ms), t90_verg
    # facilitation: by the saccade's offset more of the vergence is done than in a pure vergence
    # movement (the same depth change straight ahead, no saccade) in the same time (Enright 1984)
    t_off = k["t1"] - plan.onset_ms
    at_off = frac[np.argmax(t >= t_off)]
    pure, trp = run(head, (0.0, 0.0), (0.0, 0.0), distance=1.0, end_distance=0.3)
    hp = np.degrees(trp.angles[:, :, 0])
    vp = hp[:, 0] - hp[:, 1]
    fp = (vp - vp[0]) / (vp[-1] - vp[0])
    assert vp[-1] - vp[0] > 5.0
    assert at_off > fp[np.argmax(trp.times_ms - pure.onset_ms >= t_off)] + 0.1
    # the legacy planner moves vergence at saccadic speed (the defect the burst model fixes)
    with Head("dots", image_size=16, saccade_model="legacy") as old:
        p2, tr2 = run(old, (0.0, 0.0), (10.0, 0.0), distance=1.0, end_distance=0.3)
        h2 = np.degrees(tr2.angles[:, :, 0])
        v2 = h2[:, 0] - h2[:, 1]
        f2 = (v2 - v2[0]) / (v2[-1] - v2[0])
        assert tr2.times_ms[np.argmax(f2 > 0.9)] - p2.onset_ms < 80


# ------------------------------------------------------------------ persistence and smear
def _blob_width_deg(head, frame, ref) -> float:
    """Horizontal extent (deg) of the flash's activity in the left eye's difference image."""
    d = np.clip(frame.left.image.astype(float) - ref.left.image.astype(float), 0, None).sum(-1)
    cols = np.flatnonzero(d.max(0) > 0.1 * d.max())
    return (cols[-1] - cols[0] + 1) / head.pixels_per_unit  # image-plane units ~ radians near the axis


def test_a_flash_during_a_saccade_smears_by_the_eye_sweep():
    """The retina integrates the flash over its duration: the flash's image is stretched along
    the saccade by the eye's rotation during the flash (geometric ground truth: the sweep of the
    planned gaze), and not at all during fixation."""
    with Head("dots", image_size=256, fovy_deg=40.0, seed=0) as h:
        h.reset()
        c = h.object_position("fixation")
        h.set_object_position("flash_00", c + np.array([0.0, 0.0, 0.02]))  # just above fixation
        plan = h.plan_saccade(math.radians(20.0), 0.0, latency_ms=30)
        h.start_saccade(plan)
        h.step_ms(25)  # fixation: 5 ms before onset
        ref = h.render(exposure_ms=8)
        h.flash("flash_00", 8)
        fl = h.render(exposure_ms=8)
        still = _blob_width_deg(h, fl, ref)
        h.hide_flashes()
        t_peak = plan.onset_ms + 20  # near peak velocity of a 20 deg saccade
        h.step_ms(t_peak - h.time_ms)
        time_before, q_before = h.time_ms, h.data.qpos.copy()
        ref = h.render(exposure_ms=8)
        h.flash("flash_00", 8)
        fl = h.render(exposure_ms=8)
        assert h.time_ms == time_before and np.array_equal(h.data.qpos, q_before)  # rendering moves nothing
        moving = _blob_width_deg(h, fl, ref)
        a = plan.angles(np.array([t_peak + 0.5, t_peak + 7.5]))[:, 0, 0]  # first and last sample
        sweep = abs(a[1] - a[0])
        assert sweep > math.radians(2.0)  # the eye moves > 2 deg during the flash
        assert abs((moving - still) - sweep) < 0.3 * sweep + 2 / h.pixels_per_unit, (moving, still, sweep)
