"""The rival perception theories (``observer``, ``population``): their equations against
independent ground truth (Monte Carlo, direct sums, closed forms), that they never branch on the
condition, and what they predict through the rendered pipeline."""

from __future__ import annotations

import ast
import csv
import dataclasses
import inspect
import math
from pathlib import Path

import numpy as np
import pytest

from experiments.psychophysics import Design, Trial, TrialConfig, TrialRunner
from experiments.psychophysics import observer as obs_mod
from experiments.psychophysics import population as pop_mod

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def runner64():
    return TrialRunner(TrialConfig(image_size=64))


@pytest.fixture(scope="module")
def plan(runner64):
    trial = Design(amplitudes_deg=(20.0,), flash_offsets_deg=((4.0, 3.0),), flash_times_ms=(0,), name="p").trials()[0]
    return runner64.observe(trial).plan


# ------------------------------------------------------------------ observer: eqs. (1)-(3)
@pytest.mark.parametrize("dt", [-150, -20, 0, 30, 80])
def test_eye_estimate_matches_monte_carlo(plan, dt):
    """Eq. (1) by Gauss-Hermite quadrature against direct sampling of the flash's uncertain time."""
    t = plan.onset_ms + dt
    mean, cov = obs_mod.eye_estimate(plan, t, 40.0)
    ts = np.random.default_rng(1).normal(t, 40.0, 400_000)
    a = plan.intended_angles(ts)
    cyc = np.degrees(a[:, :, :2].mean(axis=1))
    assert np.allclose(mean, a.mean(axis=0), atol=8e-4)  # rad (0.05 deg); MC s.e. ~ 0.17 rad / 630 = 3e-4
    assert cov[0, 0] == pytest.approx(np.var(cyc[:, 0]), rel=0.03, abs=0.05)
    if abs(dt) > 140:  # long before the saccade the eye is still: no uncertainty about its position
        assert cov[0, 0] < 0.01  # deg^2: the saccade is ~4 s.d. of the timing uncertainty away


def test_posterior_single_flash_closed_form():
    """One flash: the posterior mean a + s_a^2 / (s_a^2 + s_e^2 + s_r^2) (m - a); flat prior: m."""
    m, vr, ve, rho, sa2 = 7.0, 0.5, 30.0, 2.0, 16.0
    got = obs_mod.posterior_mean(np.array([m]), np.array([vr]), ve, rho, 1 / sa2)[0]
    assert got == pytest.approx(rho + sa2 / (sa2 + ve + vr) * (m - rho), rel=1e-12)
    assert obs_mod.posterior_mean(np.array([m]), np.array([vr]), ve, rho, 0.0)[0] == pytest.approx(m)


def test_posterior_two_flashes_spare_separation():
    """Two flashes sharing the eye-position error: their separation shrinks by s_a^2 / (s_a^2 + s_r^2)
    (the prior on the difference is N(0, 2 s_a^2), its measurement has variance 2 s_r^2), their
    positions by far more -- Reeve, Clark & O'Regan 2008 follows from the shared error."""
    vr, ve, sa2, rho = 0.5, 60.0, 16.0, 0.0
    m = np.array([4.0, 8.0])
    h = obs_mod.posterior_mean(m, np.array([vr, vr]), ve, rho, 1 / sa2)
    assert (h[1] - h[0]) / (m[1] - m[0]) == pytest.approx(sa2 / (sa2 + vr), rel=1e-9)
    single = obs_mod.posterior_mean(m[:1], np.array([vr]), ve, rho, 1 / sa2)[0] / m[0]
    assert single < 0.3 < (h[1] - h[0]) / (m[1] - m[0])


def _grid_posterior_mean(m, vr, ve, rho, lam, n=161):
    """Ground truth for eq. (3) with two flashes: the posterior mean by direct numerical integration
    of prior x likelihood on a grid over both positions and the shared eye-position error ``e``
    (m_k = h_k + e + noise_k, noise_k ~ N(0, vr_k) independent, e ~ N(0, ve), h_k ~ N(rho, 1/lam))."""
    sd = math.sqrt(max(vr) + ve)
    h1 = np.linspace(m[0] - 7 * sd, m[0] + 7 * sd, n)
    h2 = np.linspace(m[1] - 7 * sd, m[1] + 7 * sd, n)
    e = np.linspace(-7 * math.sqrt(ve), 7 * math.sqrt(ve), n)
    H1, H2, E = np.meshgrid(h1, h2, e, indexing="ij")
    logp = (
        -0.5 * lam * ((H1 - rho) ** 2 + (H2 - rho) ** 2)
        - 0.5 * E**2 / ve
        - 0.5 * (m[0] - H1 - E) ** 2 / vr[0]
        - 0.5 * (m[1] - H2 - E) ** 2 / vr[1]
    )
    w = np.exp(logp - logp.max())
    return np.array([np.sum(w * H1), np.sum(w * H2)]) / np.sum(w)


@pytest.mark.parametrize(
    "vr, ve",
    [((0.5, 0.5), 9.0), ((6.0, 9.0), 4.0), ((29.0, 29.0), 0.3)],  # fixation-like; unequal; suppressed
)
def test_two_flash_posterior_matches_numerical_integration(vr, ve):
    """Eq. (3) for two simultaneous flashes (independent sensory noise, one shared eye-position error)
    against the posterior mean integrated numerically over both positions and the eye error."""
    m, rho, lam = np.array([3.0, 7.0]), 1.0, 1 / 16
    got = obs_mod.posterior_mean(m, np.array(vr), ve, rho, lam)
    assert got == pytest.approx(_grid_posterior_mean(m, vr, ve, rho, lam), abs=2e-3)


def test_independent_suppression_noise_would_compress_separation():
    """Eq. (3) with suppression's noise each flash's own (``shared_var`` none): the prior pulls their
    separation in by lam vr / (1 + lam vr) whatever the shared eye error -- the separation keeps only
    the retinal precision, and suppression lowers it (numerically). Before eq. (0b) this made the
    observer compress separation by 0.71 of its localization (Reeve, Clark & O'Regan 2008: weakly)."""
    m, lam, ve = np.array([3.0, 7.0]), 1 / 16, 30.0
    for vr in (0.5, 29.0):  # fixation-like vs suppressed (10^(2 x 0.8) x the fixation variance, eq. 0)
        h = _grid_posterior_mean(m, (vr, vr), ve, 0.0, lam)
        assert (h[1] - h[0]) / (m[1] - m[0]) == pytest.approx(1 / (1 + lam * vr), abs=2e-3)
        assert obs_mod.posterior_mean(m, np.array([vr, vr]), ve, 0.0, lam) == pytest.approx(h, abs=2e-3)


def test_shared_suppression_noise_spares_separation():
    """Eq. (0b): of a suppressed flash's variance vr only vo = vr 10^(2 (0.2 - 0.8) S) is its own; the
    rest is common to the flashes shown with it. Equal shares act as more shared eye error: the
    separation then shrinks by lam vo / (1 + lam vo) only -- against the numerical integration with the
    shared part folded into the eye error."""
    m, lam, ve, vr = np.array([3.0, 7.0]), 1 / 16, 30.0, 29.0
    vo = vr * 10 ** (2 * (0.2 - 0.8))  # S = 1: a 10-fold sensitivity loss
    got = obs_mod.posterior_mean(m, np.array([vr, vr]), ve, 0.0, lam, np.array([vr - vo, vr - vo]))
    assert got == pytest.approx(_grid_posterior_mean(m, (vo, vo), ve + vr - vo, 0.0, lam), abs=2e-3)
    assert (got[1] - got[0]) / (m[1] - m[0]) == pytest.approx(1 / (1 + lam * vo), abs=2e-3)
    alone = obs_mod.posterior_mean(m, np.array([vr, vr]), ve, 0.0, lam)
    assert (alone[1] - alone[0]) < (got[1] - got[0]) < (m[1] - m[0])
    # one flash: its whole variance acts, however it is split
    one = obs_mod.posterior_mean(m[:1], np.array([vr]), ve, 0.0, lam, np.array([vr - vo]))
    assert one == pytest.approx(obs_mod.posterior_mean(m[:1], np.array([vr]), ve, 0.0, lam), rel=1e-12)


def test_unequal_shared_noise_against_the_sampled_generative_model():
    """Eq. (3) with unequal shared parts s_k (two flashes at different eccentricities) against the
    Kalman-gain form E[h | m] = rho + (1/lam) (I/lam + C)^-1 (m - rho) with C estimated from samples
    of the generative model m_k = h_k + e + s_k u + o_k (e, u, o_k independent normals)."""
    rng = np.random.default_rng(7)
    m, lam, rho, ve = np.array([2.0, 9.0]), 1 / 16, 1.0, 4.0
    v_own, v_shared = np.array([0.8, 2.5]), np.array([6.0, 20.0])
    n = 1_000_000
    noise = (rng.normal(0, math.sqrt(ve), n)[:, None] + rng.normal(0, 1, n)[:, None] * np.sqrt(v_shared)
             + rng.normal(0, 1, (n, 2)) * np.sqrt(v_own))
    C = np.cov(noise.T)
    want = rho + np.linalg.solve(np.eye(2) + lam * C, m - rho)
    got = obs_mod.posterior_mean(m, v_own + v_shared, ve, rho, lam, v_shared)
    assert got == pytest.approx(want, abs=0.02)


def test_separation_exponent_from_westheimer_et_al_1999():
    """``separation_contrast_exponent``: separation thresholds rise ~2-fold as Michelson contrast falls
    from ~1 to 0.03, vernier ones 5-6-fold (Westheimer, Brincat & Wehrhahn 1999, Vision Res 39:1631,
    abstract): 2 = (1 / 0.03)^a gives a = 0.20. It cannot exceed the positional exponent; in fixation
    (no suppression) a flash's noise is all its own."""
    p = obs_mod.ObserverParams()
    assert p.separation_contrast_exponent == pytest.approx(math.log10(2) / math.log10(1 / 0.03), abs=0.005)
    assert math.log10(5.5) / math.log10(1 / 0.03) < p.acuity_contrast_exponent  # vernier's is steeper
    assert obs_mod.sensory_sd_deg(10.0, p, 0.0, own=True) == obs_mod.sensory_sd_deg(10.0, p, 0.0)
    assert obs_mod.sensory_sd_deg(10.0, p, 1.0, own=True) == pytest.approx(
        10 ** 0.2 * obs_mod.sensory_sd_deg(10.0, p), rel=1e-12)
    with pytest.raises(ValueError, match="separation_contrast_exponent must be <= acuity_contrast_exponent"):
        obs_mod.ObserverParams(separation_contrast_exponent=0.9)


def test_temporal_sd_from_temporal_order_threshold():
    """``temporal_sd_ms``: two events' order is judged 75 % correct at ~20 ms asynchrony (Hirsh &
    Sherrick 1961); each event's perceived time N(t, s^2) gives P(correct) = Phi(dt / (sqrt 2 s))."""
    from statistics import NormalDist

    s = 20.0 / (math.sqrt(2.0) * NormalDist().inv_cdf(0.75))
    assert obs_mod.ObserverParams().temporal_sd_ms == pytest.approx(s, abs=0.05)
    # the definition checked by simulation: at that s, 20 ms asynchrony is ordered right 75 % of the time
    t = np.random.default_rng(3).normal(0.0, s, (200_000, 2)) + np.array([0.0, 20.0])
    assert np.mean(t[:, 1] > t[:, 0]) == pytest.approx(0.75, abs=0.005)


def test_motor_scatter_is_two_dimensional_and_absent_in_fixation(plan):
    """Eq. (1b): the eye's motor scatter (s.d. ``motor_weber`` x the displacement made) is the same on
    both axes, 0 long before the saccade, and ``(weber x amplitude)^2`` once it has landed -- against
    the efference copy's own displacement."""
    w = 0.05
    early = obs_mod.motor_cov(plan, plan.onset_ms - 300, 40.0, w)
    assert np.allclose(early, 0.0, atol=1e-9)
    late = obs_mod.motor_cov(plan, plan.end_ms + 400, 40.0, w)
    a0 = np.degrees(plan.intended_angles(np.array([plan.onset_ms - 1.0]))[0, :, :2].mean(axis=0))
    a1 = np.degrees(plan.intended_angles(np.array([plan.end_ms + 400.0]))[0, :, :2].mean(axis=0))
    amp2 = float(np.sum((a1 - a0) ** 2))
    assert amp2 == pytest.approx(20.0 ** 2, rel=0.05)  # the 20 deg saccade
    assert late[0, 0] == pytest.approx(w ** 2 * amp2, rel=1e-6) and late[1, 1] == late[0, 0] and late[0, 1] == 0
    mid = obs_mod.motor_cov(plan, plan.onset_ms, 40.0, w)
    assert 0 < mid[1, 1] < late[1, 1]  # grows with the displacement made


def test_two_d_eye_uncertainty_compresses_across_the_saccade(plan):
    """The across-saccade (vertical) eye-position variance is 0 from timing alone (eq. 1, a horizontal
    saccade), so without eq. (1b) the prior pulls a flash across only by its sensory noise; with it,
    more -- across-compression follows from the 2-D uncertainty (Kaiser & Lappe 2004's across row)."""
    t = plan.onset_ms
    _, cov = obs_mod.eye_estimate(plan, t, 40.0)
    assert cov[1, 1] < 1e-6 * cov[0, 0]
    vy = cov[1, 1] + obs_mod.motor_cov(plan, t, 40.0, 0.05)[1, 1]
    m, vr, lam = np.array([5.0]), np.array([0.25]), 1 / 16
    without = obs_mod.posterior_mean(m, vr, cov[1, 1], 0.0, lam)[0]
    with_2d = obs_mod.posterior_mean(m, vr, vy, 0.0, lam)[0]
    assert with_2d < without < m[0]


def test_suppression_profile_follows_diamond_et_al_2000(plan):
    """Eq. (0): the log10 sensitivity loss is 0 until 50 ms before onset, 1 (10-fold) at onset, half
    way on both flanks, 0 again 50 ms after the saccade's end (Diamond, Ross & Morrone 2000, abstract);
    the positional s.d. grows by 10^(0.8 x loss) (Bradley & Skottun 1987), on both axes alike."""
    p = obs_mod.ObserverParams()
    on, end = float(plan.onset_ms), float(plan.end_ms) + 50.0
    S = [obs_mod.suppression_log10(plan, t, p) for t in (on - 80, on - 50, on - 25, on, (on + end) / 2, end, end + 30)]
    assert S == pytest.approx([0.0, 0.0, 0.5, 1.0, 0.5, 0.0, 0.0], abs=1e-9)
    assert obs_mod.sensory_sd_deg(10.0, p, 1.0) == pytest.approx(10 ** 0.8 * obs_mod.sensory_sd_deg(10.0, p), rel=1e-12)
    assert obs_mod.sensory_sd_deg(10.0, p, 0.0) == pytest.approx(0.1 + 0.05 * 10.0)


def test_landmark_prior_combines_cues_by_their_extent():
    """Eq. (2) against the algebra of independent Gaussian cues N(x_i, prior^2 + s_i^2) per axis."""
    p = obs_mod.ObserverParams()
    v = p.prior_sd_deg**2
    rho, lam = obs_mod.landmark_prior(np.empty((0, 2)), np.empty((0, 2)), 100.0, p)
    assert np.all(rho == 0) and np.all(lam == 0)  # no landmark: a flat prior
    rho, lam = obs_mod.landmark_prior([[3.0, -2.0]], [[0.0, 0.0]], 100.0, p)
    assert rho == pytest.approx([3.0, -2.0]) and lam == pytest.approx([1 / v, 1 / v])
    # a dot at the goal and a 40 deg bar 10 deg below it: along the bar it counts 1 / (v + 40^2 / 12)
    rho, lam = obs_mod.landmark_prior([[0.0, 0.0], [0.0, -10.0]], [[0.0, 0.0], [40.0**2 / 12, 0.0]], 100.0, p)
    assert lam == pytest.approx([1 / v + 1 / (v + 40.0**2 / 12), 2 / v])
    assert rho == pytest.approx([0.0, -5.0])
    rho2, lam2 = obs_mod.landmark_prior([[6.0, 0.0], [0.0, 0.0]], [[0.0, 0.0], [0.0, 0.0]], 100.0, p)
    assert rho2 == pytest.approx([3.0, 0.0]) and lam2 == pytest.approx([2 / v, 2 / v])
    half = obs_mod.landmark_prior([[3.0, -2.0]], [[0.0, 0.0]], 50.0, p)[1]
    assert half == pytest.approx([0.5 / v, 0.5 / v])  # Bloch: half the time, half the precision
    assert obs_mod.landmark_prior([[3.0, -2.0]], [[0.0, 0.0]], 400.0, p)[1] == pytest.approx([1 / v, 1 / v])


def test_activity_covariance_of_bars_is_their_second_moment():
    """A uniform bar of n pixels has variance (n^2 - 1) / 12 px^2 along it (L^2 / 12 for a continuous
    one): image plane, 128 px, 90 deg, so f = 64 px."""
    from experiments.psychophysics.decode import activity_covariance

    r = TrialRunner(TrialConfig(image_size=128))
    f = 64.0
    for u0, u1, v0, v1 in ((44, 84, 63, 65), (54, 74, 60, 68), (62, 66, 62, 66)):
        img = np.zeros((128, 128, 3))
        img[v0:v1, u0:u1] = 1.0
        view = r.vision.see(img)
        cov = activity_covariance(
            view.periphery, view.fovea, r.retina_grid, mask=view.mask, fovea_mask=view.fovea_mask, threshold=0.0
        )
        assert cov[0, 0] == pytest.approx(((u1 - u0) ** 2 - 1) / 12 / f**2, rel=0.05)  # n pixels: (n^2 - 1) / 12
        assert abs(cov[0, 1]) < 0.05 * np.sqrt(cov[0, 0] * cov[1, 1])  # no tilt: correlation < 0.05
    assert np.all(np.isnan(activity_covariance(np.zeros_like(view.periphery), np.zeros_like(view.fovea), r.retina_grid)))


# ------------------------------------------------------------------ population
def test_population_estimate_matches_direct_sum():
    """The closed-form population vector against a direct sum over a fine grid of units."""
    w = np.linspace(-7, 7, 1401)
    W = w[:, None] + 1j * w[None, :]
    for wf, S in ((0.8 + 0.3j, 5.0), (-0.5 - 0.6j, 30.0), (1.5 + 0j, 0.0)):
        R = np.exp(-np.abs(W - wf) ** 2 / (2 * 0.6**2))
        g = 1 + S * np.exp(-np.abs(W) ** 2 / (2 * 0.5**2))
        direct = np.sum(W * R * g) / np.sum(R * g)
        assert pop_mod.population_estimate(wf, S, 0.6, 0.5) == pytest.approx(direct, abs=1e-6)


def test_cortical_offset_round_trip():
    goal = 20 + 0j
    for z in (24 + 3j, 12 - 6j, -5 + 2j, 0.5j):
        dw = complex(pop_mod.cortical_offset(np.array([z]), goal, 0.75)[0])
        assert pop_mod.from_cortical_offset(dw, goal, 0.75) == pytest.approx(z, abs=1e-9)


def test_feedback_signal_dynamics(plan):
    """Driven by the burst: nothing before it, peak after the burst's, integral = the amplitude."""
    t = np.arange(plan.onset_ms - 100, plan.onset_ms + 600, 0.5)
    s = pop_mod.feedback_signal(plan, t, 20.0)
    assert np.all(s[t < plan.onset_ms - 1] < 1e-9)
    amp = abs(np.degrees(plan.intended_end_angles[:, 0] - plan.start_angles[:, 0]).mean())
    assert np.trapezoid(s, t) == pytest.approx(amp, rel=0.03)
    assert t[np.argmax(s)] > plan.onset_ms + plan.duration_ms / 2


def _displacement_setup(runner, target_deg: float):
    """A 20 deg saccade from (-10, 0) to (10, 0) deg staged by hand (as ``TrialRunner._run_displacement``)
    with the target dot at (``target_deg``, 0) and never moved: the plan, the times of a look 150 ms
    before onset and one at landing, and each eye's image point of the dot at both."""
    from experiments.psychophysics.trial import FIXATION_MS, _screen_world

    head = runner.head
    head.reset(seed=3, fixate=_screen_world(-10.0, 0.0))
    head.set_visible("screen", False)
    head.set_object_position("fixation", _screen_world(-10.0, 0.0))
    head.set_object_position("target", _screen_world(target_deg, 0.0))
    plan = head.plan_saccade_to(_screen_world(10.0, 0.0), latency_ms=FIXATION_MS)
    head.start_saccade(plan)
    t_pre = int(plan.onset_ms) - 150
    head.step_ms(t_pre - head.time_ms)
    z_pre = runner._target_image_points()
    t_post = int(math.ceil(plan.offset_ms))
    head.step_ms(t_post - head.time_ms)
    return plan, t_pre, z_pre, t_post, runner._target_image_points()


def test_remapped_point_against_the_rendered_target():
    """Remapping through a pose and back is the identity, and the pre-saccadic target remapped
    through the true eye's poses before and after the saccade lands where the retina, rendered,
    sees the unmoved target after it. The dot sits 3 deg short of the saccade's goal, outside the
    retina's 2 deg foveal hole after landing; at 17 deg before the saccade the 256 px retina's
    rings are ~2 deg apart, so its centroid is good to ~1 deg there (against an image shift of
    ~20 deg; a remapping by the wrong pose or sign errs by degrees)."""
    from experiments.psychophysics.theories.population import image_to_deg, remapped_point

    runner = TrialRunner(TrialConfig(image_size=256))
    try:
        plan, t_pre, z_pre, t_post, z_post = _displacement_setup(runner, 7.0)
        pre, post = runner._pose(plan.angles(float(t_pre))), runner._pose(plan.angles(float(t_post)))
        for e in range(2):
            # ~1e-6: the ray's screen plane (TrialRunner) and models.screen_point agree to ~3e-5 deg
            assert remapped_point(runner, e, z_pre[e], pre, pre) == pytest.approx(z_pre[e], abs=1e-5)
            z_hat = remapped_point(runner, e, z_pre[e], pre, post)
            deg = [image_to_deg(np.array([z]))[0][0] for z in (z_pre[e], z_post[e], z_hat)]
            moved, err = abs(deg[0] - deg[1]), abs(deg[2] - deg[1])
            assert moved > 15 and err < 1.0, (e, moved, err)
        assert np.isnan(remapped_point(runner, 0, complex(np.nan, np.nan), pre, post).real)
    finally:
        runner.close()


def test_population_displacement_looks_analytic(runner64, plan):
    """Population's displacement looks (``Population.displacement_looks``) on synthetic image points:
    (a) without feedback, both looks are the plain rays through the eye-position signal; (b) a small
    post-saccadic offset from the goal's remapped position (radial on the map) is seen shrunk by the
    gain field's closed-form factor for small offsets, k = (rf^2 + S c^2 f^2 / (rf^2 + f^2)) /
    (rf^2 + S c^2), c^2 = rf^2 f^2 / (rf^2 + f^2) (Gaussian products; the population vector of
    ``test_population_estimate_matches_direct_sum``), with S the feedback's strength at landing; (c)
    250 ms later the feedback has decayed (S < 1e-3) and the offset is seen in full."""
    from experiments.psychophysics.theories import REGISTRY
    from experiments.psychophysics.theories.population import remapped_point

    pop = REGISTRY["population"]
    cfg = TrialConfig(image_size=64, model="population")
    pp = cfg.population
    t_pre, z_pre = plan.onset_ms - 150, [0.36 + 0.01j, 0.37 + 0.01j]
    for blank, want_s in ((0, None), (250, 0.0)):
        t_post = math.ceil(plan.offset_ms) + blank
        copies = [runner64._pose(plan.intended_angles(t)) for t in (t_pre, t_post)]
        goals = [remapped_point(runner64, e, z_pre[e], *copies) for e in range(2)]
        s = pop_mod.feedback_strength(plan, t_post, pp)
        if want_s is None:
            assert s > 1.0  # the feedback outlasts the burst: it still holds at landing
        else:
            assert s < 1e-3
        rf2, f2 = pp.rf_sd**2, pp.field_sd**2
        c2 = rf2 * f2 / (rf2 + f2)
        k = (rf2 + s * c2 * f2 / (rf2 + f2)) / (rf2 + s * c2)
        d = 1e-4  # image-plane units, radial: a tiny step on the map
        seen = {}
        for name, p in (("feedback", pp), ("none", dataclasses.replace(pp, gain_per_deg=0.0))):
            c = dataclasses.replace(cfg, population=p)
            at_goal = pop.displacement_looks(runner64, plan, ((t_pre, z_pre), (t_post, goals)), c)
            off = [g * (1 + d / abs(g)) for g in goals]
            moved = pop.displacement_looks(runner64, plan, ((t_pre, z_pre), (t_post, off)), c)
            seen[name] = moved[1] - at_goal[1]
            assert at_goal[2] == cfg.report_noise_deg
        eps = runner64._pose(plan.eye_position_signal(t_post + pp.latency_ms))
        plain = np.mean([runner64._ray_to_screen_deg(eps[1][e], eps[0][e], off[e]) for e in range(2)], axis=0)
        plain0 = np.mean([runner64._ray_to_screen_deg(eps[1][e], eps[0][e], goals[e]) for e in range(2)], axis=0)
        assert np.allclose(seen["none"], plain - plain0, atol=1e-9)
        assert np.linalg.norm(seen["feedback"]) / np.linalg.norm(seen["none"]) == pytest.approx(k, rel=2e-3)
        assert k < 0.8 if want_s is None else k == pytest.approx(1.0, abs=1e-3)


@pytest.mark.slow
def test_population_sees_a_step_shrunk_at_landing_not_after_a_blank():
    """Through the rendered pipeline (256 px, no motor noise), population's perceived step of a
    0.5 deg intrasaccadic target step (minus its perceived step of none) is smaller than the paper's
    (the eye-position signal alone) when the target is back at landing, and the same after a 250 ms
    blank (the feedback has decayed). Without motor noise the goal's remapped position is the fovea,
    where the map's polar angle is undefined: the pull is weak there (0.476 against 0.479 deg)."""
    d = Design(amplitudes_deg=(20.0,), flash_offsets_deg=((0.0, 0.0), (0.5, 0.0)), flash_times_ms=(0, 250),
               name="disp")
    seen = {}
    for m in ("population", "paper"):
        r = TrialRunner(TrialConfig(image_size=256, condition="dark", paradigm="displacement", model=m))
        try:
            rows = {(t.flash_time_ms, t.flash_dx_deg): r.run(t)["perceived_step_deg"] for t in d.trials()}
        finally:
            r.close()
        seen[m] = {b: rows[(b, 0.5)] - rows[(b, 0.0)] for b in (0, 250)}
    assert 0 < seen["population"][0] < seen["paper"][0] - 1e-3
    assert seen["population"][250] == pytest.approx(seen["paper"][250], abs=1e-3)  # S ~ 3e-5 by then


# ------------------------------------------------------------------ no outcome switches
def _readout_functions():
    from experiments.psychophysics.theories import mechanistic, observer, paper, population, shift

    return {"Observer.read": observer.Observer.read, "Observer.look": observer.Observer.look,
            "Observer.displacement_looks": observer.Observer.displacement_looks,
            "Population.read": population.Population.read,
            "Population.displacement_looks": population.Population.displacement_looks,
            "Paper.read": paper.Paper.read,
            "Mechanistic.read": mechanistic.Mechanistic.read, "Mechanistic.anchor": mechanistic.Mechanistic.anchor,
            "Mechanistic.stability_weight": mechanistic.Mechanistic.stability_weight,
            "shift_read": shift.shift_read, "readout": TrialRunner.readout,
            "_run_displacement": TrialRunner._run_displacement}


@pytest.mark.parametrize("fn", list(_readout_functions()))
def test_theories_do_not_branch_on_the_condition(fn):
    """A theory's read-out never reads the condition, paradigm or blank: references, blanks and
    markers act through what the eyes see (issue 22, item 2). The displacement paradigm's staging
    reads the blank to schedule the stimulus, but no model decision depends on it."""
    import textwrap

    tree = ast.parse(textwrap.dedent(inspect.getsource(_readout_functions()[fn])))
    names = {n.attr for n in ast.walk(tree) if isinstance(n, ast.Attribute)} | \
        {n.id for n in ast.walk(tree) if isinstance(n, ast.Name)}
    if fn != "_run_displacement":  # the paradigm's staging lays out the stimulus of the condition
        assert not names & {"condition", "paradigm"}, fn
    for node in ast.walk(tree):
        if isinstance(node, (ast.If, ast.IfExp)):
            test = ast.unparse(node.test)
            assert "condition" not in test and "paradigm" not in test, f"{fn} branches on {test}"
            if "blank" in test:  # only the stimulus schedule: hide the target during the blank
                body = [ast.unparse(b) for b in getattr(node, "body", [])]
                assert isinstance(node, ast.If) and all(b.startswith(("head.set_visible(", "raise ValueError"))
                                                        for b in body), \
                    f"{fn} branches on the blank: {test}"
    for mod in (obs_mod, pop_mod):
        code = Path(mod.__file__).read_text()
        body = code[code.index('"""', 3) + 3:]  # past the docstring
        assert "condition" not in body and "paradigm" not in body and "blank" not in body


# ------------------------------------------------------------------ paradigm options
def test_paradigm_options_validate():
    with pytest.raises(ValueError, match="at most 4 markers"):
        TrialConfig(markers=((1.0, 2.0),) * 5)
    with pytest.raises(TypeError, match="markers"):
        TrialConfig(markers="left")
    with pytest.raises(ValueError, match="pairs"):
        TrialConfig(markers=((1.0,),))
    with pytest.raises(ValueError):
        TrialConfig(reference_contrast=1.5)
    with pytest.raises(ValueError):
        TrialConfig(target_off_ms=2000)
    with pytest.raises(ValueError, match="whole"):
        TrialConfig(reference_ms=12.5)
    with pytest.raises(TypeError, match="ObserverParams"):
        TrialConfig(observer={"prior_sd_deg": 3})
    with pytest.raises(ValueError):
        obs_mod.ObserverParams(prior_sd_deg=0)
    with pytest.raises(TypeError):
        pop_mod.PopulationParams(tau_ms=float("nan"))


def test_reference_activity_graded_and_recorded():
    """The references' retinal activity grows with their contrast, is 0 in the dark, and the row
    records the stimulus; the default's activity is the mechanistic model's ``reference_unit`` (256
    px). Their landmarks are the objects each eye sees: target and ruler, a marker too, none in the
    dark."""
    trial = Design(amplitudes_deg=(20.0,), flash_offsets_deg=((4.0, 3.0),), flash_times_ms=(0,), name="r").trials()[0]
    acts = []
    for c in (0.25, 0.5, 1.0):
        r = TrialRunner(TrialConfig(image_size=256, reference_contrast=c, markers=((-10.0, 0.0),), model="observer"))
        o = r.observe(trial)
        acts.append(float(np.mean(o.ref_activity)))
        row = r.readout(o)
        assert row["reference_contrast"] == c and row["n_markers"] == 1
    assert acts[0] < acts[1] < acts[2]
    assert acts[0] / acts[2] == pytest.approx(0.25, abs=0.05)  # the retina's activity ~ contrast
    assert acts[1] / acts[2] == pytest.approx(0.5, abs=0.05)
    assert [len(z) for z, _ in o.ref_landmarks] == [3, 3]  # target, ruler, marker
    plain = TrialRunner(TrialConfig(image_size=256)).observe(trial)
    assert float(np.mean(plain.ref_activity)) == pytest.approx(TrialConfig().reference_unit, rel=0.1)
    assert [len(z) for z, _ in plain.ref_landmarks] == [2, 2]
    for _z, cov in plain.ref_landmarks:  # the ruler (40 deg long, ~1 deg tall) spreads along x only
        ruler = int(np.argmax(cov[:, 0, 0]))
        assert cov[ruler, 0, 0] > 50 * cov[ruler, 1, 1] and cov[1 - ruler, 0, 0] < 0.01 * cov[ruler, 0, 0]
    dark = TrialRunner(TrialConfig(image_size=256, condition="dark")).observe(trial)
    assert np.all(dark.ref_activity == 0) and [len(z) for z, _ in dark.ref_landmarks] == [0, 0]


# ------------------------------------------------------------------ predictions through the pipeline
OFFSETS = ((-8.0, 3.0), (8.0, -3.0), (-4.0, -6.0), (4.0, 6.0), (-12.0, 3.0), (2.0, -4.0), (6.0, 0.0), (-6.0, 0.0))


@pytest.fixture(scope="module")
def small_study():
    """Observations of a small design at 128 px, with references and in the dark."""
    d = Design(amplitudes_deg=(20.0,), flash_offsets_deg=OFFSETS, flash_times_ms=(-150, -50, 0), name="s")
    out = {}
    for cond in ("references", "dark"):
        r = TrialRunner(TrialConfig(image_size=128, condition=cond))
        out[cond] = (r, [r.observe(t) for t in d.trials()])
    return out


def _ci(rows, time, axis=None):
    sel = [r for r in rows if r["flash_time_ms"] == time]
    keys = [("perceived_x_deg", "true_x_deg"), ("perceived_y_deg", "true_y_deg")]
    keys = keys if axis is None else [keys[axis]]
    num = sum(np.var([r[p] for r in sel]) for p, _ in keys)
    den = sum(np.var([r[q] for r in sel]) for _, q in keys)
    return 1 - math.sqrt(num / den)


def _read(small_study, cond, model):
    r, obs = small_study[cond]
    cfg = dataclasses.replace(r.config, model=model)
    return [r.readout(o, cfg) for o in obs]


def test_observer_predictions(small_study):
    ref, dark = _read(small_study, "references", "observer"), _read(small_study, "dark", "observer")
    # Lappe, Awater & Krekelberg 2000 (Nature 403:892, Fig. 2): compression with references, none in the dark
    assert _ci(ref, 0) - _ci(dark, 0) > 0.2
    assert abs(_ci(dark, 0) - _ci(dark, -150)) < 0.05
    # in the dark, 50 ms before onset is 2.4 s.d. of the flash's time (21 ms, eq. 1) from the saccade:
    # the eye estimate barely leads the eye, so the forward shift Honda 1991 measured there is NOT
    # predicted (the scoreboard's shift_dark_presaccadic_deg row fails for this reason)
    shift = np.mean([r["error_x_deg"] for r in dark if r["flash_time_ms"] == -50]) - \
        np.mean([r["error_x_deg"] for r in dark if r["flash_time_ms"] == -150])
    assert abs(shift) < 0.3
    # Kaiser & Lappe 2004 (Neuron 41:293, Fig. 3): stronger along the saccade than across (the timing
    # uncertainty, eq. 1, lies along it; the scoreboard's range: along - across >= 0.05), and across
    # it too (suppression, eq. 0, the 2-D motor scatter, eq. 1b, and the ruler: a full cue across,
    # a weak one along its 40 deg, eq. 2) -- but not in fixation, where neither acts
    assert _ci(ref, 0, 0) - _ci(ref, 0, 1) > 0.05
    assert _ci(ref, 0, 1) - _ci(ref, -150, 1) > 0.1


def test_population_predictions(small_study):
    ref, dark = _read(small_study, "references", "population"), _read(small_study, "dark", "population")
    # Compression near onset (Morrone et al. 1997), from the gain field alone ...
    assert _ci(ref, -50) - _ci(ref, -150) > 0.2
    # ... hence as strong in the dark: the theory has no reference term, contrary to Lappe et al. 2000
    # (a failure of the theory that the scoreboard reports; this asserts that it is still there)
    assert abs(_ci(ref, -50) - _ci(dark, -50)) < 0.05


# ------------------------------------------------------------------ the committed scoreboard
def _scoreboard() -> dict:
    return {(r["phenomenon"], r["model"]): r for r in
            csv.DictReader((ROOT / "experiments" / "data" / "phenomena.csv").open())}


def test_observer_predictions_in_the_scoreboard_against_published_values():
    """The committed 256 px scoreboard's rows that count for the observer (predicted, diagnostic),
    against the published ranges, on their CIs: what the README says it gets right and wrong."""
    rows = _scoreboard()

    def ci(name, model="observer"):
        r = rows[(name, model)]
        assert r["role"] == "predicted" and r["diagnostic"] == "yes", r
        return float(r["ci_low"]), float(r["ci_high"])

    # Lappe, Awater & Krekelberg 2000 (Nature 403:892, Fig. 2): compression needs references (>= 0.2)
    assert ci("compression_needs_references")[0] > 0.2
    # Kaiser & Lappe 2004 (Neuron 41:293, Fig. 3): stronger along the saccade than across
    assert ci("compression_along_minus_across")[0] > 0.05
    # Reeve, Clark & O'Regan 2008 (J Vis 8(13):5, abstract): separation compresses much less than
    # localization (<= 0.5): most of what suppression adds is common to the two flashes (eq. 0b,
    # Westheimer, Brincat & Wehrhahn 1999), so the prior moves them together
    assert -1.0 < ci("separation_over_localization")[0] and ci("separation_over_localization")[1] < 0.5
    # Deubel, Schneider & Bridgeman 1996 (Vision Res 36:985, Fig. 2): a 250 ms blank lowers the threshold
    # several-fold (>= 2) -- the observer's blank helps (CI above 1) but less (a failure, since the
    # report noise has its own stream: it used to cancel the landing scatter)
    assert ci("displacement_blank_ratio")[0] > 1 and ci("displacement_blank_ratio")[0] < 2
    # Honda 1989 (Percept Psychophys 45:162, abstract): in the dark, backward at the saccade's end;
    # forward before onset -- not predicted: 50 ms is 2.4 s.d. of the flash's time (21 ms) away (a failure)
    assert ci("shift_dark_reversal_deg")[1] < -0.5
    assert ci("shift_dark_presaccadic_deg")[1] < 0.5
    # Kaiser & Lappe 2004: compression across the saccade too (suppression, eq. 0, and the 2-D motor
    # scatter, eq. 1b)
    assert ci("compression_across")[0] > 0.05
    # Zimmermann, Morrone & Burr 2014 (J Vis 14(12):13, abstract): with the target gone at onset, the
    # focus moves to a marker (0.5-1.5 of the way), and a memory-guided saccade compresses less (>= 0.05):
    # each landmark seen after the saccade is a cue of its own (eq. 2), a marker as much as the target
    assert 0.5 < ci("focus_toward_reference")[0] and ci("focus_toward_reference")[1] < 1.5
    assert ci("memory_guided_reduction")[0] > 0.05
    # population: compression regardless of references, contrary to Lappe et al. 2000
    assert ci("compression_needs_references", "population")[1] < 0.2
    # population: separation compressed like localization, contrary to Reeve et al. 2008
    assert ci("separation_over_localization", "population")[0] > 0.5


def test_psychometric_fit_flags_non_monotonic_data_and_has_cis():
    """The audit's example (P("forward") 0, .33, .33, .17, .17, .83, 1 at -2..+4 deg, 6 reports
    each) is flagged; a clean cumulative Gaussian is not, and its CIs bracket the generating values."""
    from scipy.stats import norm

    from experiments.psychophysics import displacement_psychometrics

    steps = np.repeat(np.arange(-2.0, 5.0), 6)
    p = [0, 2, 2, 1, 1, 5, 6]
    fwd = np.concatenate([[1.0] * k + [0.0] * (6 - k) for k in p])
    bad = displacement_psychometrics({"flash_dx_deg": steps, "flash_time_ms": np.zeros(steps.size),
                                      "reported_forward": fwd})[0]
    assert not bad["monotonic"] and 0 < bad["monotone_p"] <= 1
    rng = np.random.default_rng(3)
    steps = np.repeat(np.linspace(-3, 3, 9), 40)
    fwd = (rng.random(steps.size) < 0.01 + 0.98 * norm.cdf((steps - 0.5) / 1.2)).astype(float)
    good = displacement_psychometrics({"flash_dx_deg": steps, "flash_time_ms": np.zeros(steps.size),
                                       "reported_forward": fwd}, n_boot=200)[0]
    assert good["monotone_p"] > 0.05
    assert good["pse_ci"][0] < 0.5 < good["pse_ci"][1] and good["threshold_ci"][0] < 1.2 < good["threshold_ci"][1]


def test_a_lost_target_gives_no_displacement_report():
    """A trial whose target a theory loses after the saccade (perceived step NaN) reports nothing --
    ``reported_forward`` NaN, not "backward" -- and the psychometric fit leaves it out and counts it:
    the same fit as without that trial."""
    from experiments.psychophysics import displacement_psychometrics

    steps = np.repeat(np.arange(-2.0, 3.0), 4)
    fwd = (np.arange(steps.size) % 4 < np.repeat([0, 1, 2, 3, 4], 4)).astype(float)
    table = {"flash_dx_deg": steps, "flash_time_ms": np.zeros(steps.size), "reported_forward": fwd}
    lost = dict(table, reported_forward=np.where(np.arange(steps.size) == 19, np.nan, fwd))
    kept = {k: v[:19] for k, v in table.items()}
    a, b = displacement_psychometrics(lost)[0], displacement_psychometrics(kept)[0]
    assert a["lost"] == 1 and b["lost"] == 0
    np.testing.assert_array_equal(a["p_forward"], b["p_forward"])
    assert a["pse_deg"] == b["pse_deg"] and a["threshold_deg"] == b["threshold_deg"]
    # a real one: at 64 px the 3 deg step seen at landing (no blank) falls where no theory reads activity
    r = TrialRunner(TrialConfig(image_size=64, condition="dark", paradigm="displacement", model="paper"))
    try:
        row = r.run(Trial(0, 20.0, 3.0, 0.0, 0, 0, 0))
    finally:
        r.close()
    assert math.isnan(row["perceived_step_deg"]) and math.isnan(row["reported_forward"])


def test_a_blank_whose_every_target_is_lost_has_no_fit_and_says_so():
    """Every trial of one blank lost (``phenomena --image-size 48`` did this and crashed in ``np.ptp``):
    that blank's proportions, fit and CIs are NaN with its trials counted as lost, the other blank is
    fitted as alone, and the scoreboard's note names the blank instead of calling the data non-monotone."""
    from experiments.psychophysics import displacement_psychometrics
    from experiments.psychophysics.phenomena import _note

    steps = np.tile(np.repeat(np.arange(-2.0, 3.0), 4), 2)
    blank = np.repeat([0.0, 250.0], 20)
    fwd = np.tile((np.arange(20) % 4 < np.repeat([0, 1, 2, 3, 4], 4)).astype(float), 2)
    fwd[20:] = np.nan  # blank 250 ms: the target lost in every trial
    table = {"flash_dx_deg": steps, "flash_time_ms": blank, "reported_forward": fwd}
    fits = displacement_psychometrics(table, n_boot=20)
    alone = displacement_psychometrics({k: v[:20] for k, v in table.items()})[0]
    assert fits[0]["pse_deg"] == alone["pse_deg"] and fits[0]["threshold_deg"] == alone["threshold_deg"]
    lost = fits[250]
    assert lost["lost"] == 20 and np.isnan(lost["p_forward"]).all() and len(lost["steps_deg"]) == 5
    assert math.isnan(lost["pse_deg"]) and math.isnan(lost["threshold_deg"]) and math.isnan(lost["pse_ci"][0])
    note = _note("displacement_blank_ratio", "observer", {"displacement": table}, float("nan"), (np.nan, np.nan))
    assert "blank 250 ms: the target lost in all 20 trials (no reports): no fit" in note
    assert "not monotone" not in note


@pytest.mark.parametrize("model", ["population", "mechanistic", "paper"])
def test_other_models_rows_that_count_against_published_values(model):
    """The committed scoreboard's rows that count (predicted, diagnostic, tested) for the other
    models: the documented failures of each theory (README: "What each theory gets right and wrong")
    lie wholly outside the published ranges, on their CIs."""
    rows = _scoreboard()
    counted = {n: r for (n, m), r in rows.items() if m == model and r["role"] == "predicted"
               and r["diagnostic"] == "yes" and r["reproduced"] in ("yes", "no")}
    assert counted

    def ci(name):
        r = counted[name]
        return float(r["ci_low"]), float(r["ci_high"])

    # Reeve, Clark & O'Regan 2008 (J Vis 8(13):5, abstract): separation spared (ratio <= 0.5) -- an
    # isotropic pull or a gain field moves both flashes alike
    assert ci("separation_over_localization")[0] > 0.5
    # Zimmermann, Morrone & Burr 2014 (J Vis 14(12):13, abstract): focus towards the marker (>= 0.5): none
    assert ci("focus_toward_reference")[1] < 0.5
    if model in ("population", "paper"):
        # Lappe, Awater & Krekelberg 2000 (Nature 403:892, Fig. 2): no compression in the dark -- these have it
        assert ci("compression_needs_references")[1] < 0.2
        # Deubel, Schneider & Bridgeman 1996 (Vision Res 36:985, Fig. 2): no blank effect -- paper has no
        # theory of it; population's gain-field pull at landing is weak near the fovea (docs: step 6)
        assert ci("displacement_blank_ratio")[1] < 2
    if model == "mechanistic":
        assert ci("compression_needs_references")[0] > 0.2  # by the anchored route
        # the graded reference weight: the target alone anchors little, so the memory-guided
        # reduction (>= 0.05, Zimmermann et al. 2014) is no longer reproduced
        assert ci("memory_guided_reduction")[1] < 0.05
        # the isotropic log-radius shift: no anisotropy (Kaiser & Lappe 2004, Fig. 3: >= 0.05)
        assert ci("compression_along_minus_across")[0] < 0.05
