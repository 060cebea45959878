"""The orbital plant (``models.plant``): eyes moved by torques through stiffness, viscosity and inertia.

Ground truth is the plant's own differential equation, ``I q'' + B q' + K q = tau`` with roots
``-1/T1``, ``-1/T2`` (Robinson 1964), solved in closed form; and the burst generator's main sequence
(``models.BurstGenerator``) for the executed saccades."""

from __future__ import annotations

import math

import numpy as np
import pytest

import models
from models import BurstGenerator, Head, OrbitalPlant


def _step_response(t, t1, t2):
    """Unit-torque step response of the plant, times K (so it tends to 1): closed form."""
    t = np.maximum(t, 0.0)
    return 1.0 - (t1 * np.exp(-t / t1) - t2 * np.exp(-t / t2)) / (t1 - t2)


def _saccade(head, amp_deg, after_ms=250):
    head.reset(fixate=models.screen_point(math.radians(-amp_deg / 2), 0.0, 1.0))
    plan = head.plan_saccade_to(models.screen_point(math.radians(amp_deg / 2), 0.0, 1.0), latency_ms=20)
    head.start_saccade(plan)
    return plan, head.step_ms(plan.end_ms - head.time_ms + after_ms, record=True)


def test_the_plant_has_robinsons_time_constants():
    """K and B installed in the MJCF give the eye's inertia the roots -1/T1, -1/T2."""
    plant = OrbitalPlant(t1_ms=180.0)
    with Head("dots", image_size=16, plant=plant) as head:
        m = head.model
        jid = [m.joint(n).id for n in ("left_eye_h", "right_eye_v")]
        for j in jid:
            K, B = m.jnt_stiffness[j], m.dof_damping[m.jnt_dofadr[j]]
            M = np.zeros((m.nv, m.nv))
            import mujoco

            d = mujoco.MjData(m)
            mujoco.mj_forward(m, d)
            mujoco.mj_fullM(m, d, M)
            inertia = M[m.jnt_dofadr[j], m.jnt_dofadr[j]]
            roots = np.roots([inertia, B, K]).real
            np.testing.assert_allclose(np.sort(-1.0 / roots), sorted([0.18, head.generator.plant_t2_ms * 1e-3]),
                                       rtol=1e-9)
        # the servos are off: only the torque motors drive the eyes
        pos, vel, _ = head.eye_actuator_ids
        assert not m.actuator_gainprm[np.r_[pos, vel]].any() and not m.actuator_biasprm[np.r_[pos, vel]].any()


@pytest.mark.parametrize("drive", ["plant", "servo"])
def test_a_torque_on_the_globe_moves_the_eye_as_the_plant_equation_says(drive):
    """A 20 ms torque pulse on the right eye's horizontal joint during fixation: with the plant the eye
    moves as the closed-form response of ``I q'' + B q' + K q = tau`` and the orbit's elasticity brings it
    back over T1; the servo (exact pointing) barely lets it move."""
    tau, width = 2e-4, 20
    with Head("dots", image_size=16, eye_drive=drive, timestep_ms=0.1) as head:
        head.reset()
        q0 = head.eye_angles[1, 0]
        dof = head.eye_joint_addresses[1][3]
        head.data.qfrc_applied[dof] = tau
        a = head.step_ms(width, record=True)
        head.data.qfrc_applied[dof] = 0.0
        b = head.step_ms(400, record=True)
        t = np.concatenate([a.times_ms, b.times_ms]) * 1e-3
        t -= t[0] - 1e-4  # the first sample is one 0.1 ms step after the torque starts
        q = np.concatenate([a.angles[:, 1, 0], b.angles[:, 1, 0]]) - q0
        if drive == "servo":
            assert np.abs(q).max() < math.radians(0.002)
            return
        K = head.model.jnt_stiffness[head.model.joint("right_eye_h").id]
        t1, t2 = 0.15, head.generator.plant_t2_ms * 1e-3
        expect = tau / K * (_step_response(t, t1, t2) - _step_response(t - width * 1e-3, t1, t2))
        assert math.degrees(expect.max()) > 0.1  # a visible push (deg)
        np.testing.assert_allclose(q, expect, atol=0.01 * expect.max())
        # the other eye is not touched
        assert np.abs(np.concatenate([a.angles[:, 0, 0], b.angles[:, 0, 0]]) - head.eye_angles[0, 0]).max() < 1e-9


def test_matched_pulse_step_lands_on_the_generator_trajectory():
    """With the pulse matched to the plant the physics follows the generator's trajectory (within its
    settle tolerance, 0.01 deg) and has its main-sequence peak velocity."""
    with Head("dots", image_size=16) as head:
        plan, tr = _saccade(head, 20.0)
        err = np.degrees(np.abs(tr.angles - tr.planned)).max()
        assert err < 1.5 * head.generator.settle_deg, err
        peak = np.degrees(np.abs(tr.velocities[:, 1, 0])).max()  # the right eye abducts
        assert peak == pytest.approx(_abducting_peak(head.generator, plan.amplitude_deg), rel=0.02)


def _abducting_peak(gen, amp_deg):
    """The generator's peak speed (deg/s) of the abducting eye for a saccade of ``amp_deg``."""
    return amp_deg * 1000.0 * gen.profile(amp_deg).rate(np.arange(0.0, 200.0, 0.05), plant=1).max()


@pytest.mark.parametrize("gain", [1.3, 0.7])
def test_a_mismatched_pulse_gives_post_saccadic_drift_with_the_plants_T1(gain):
    """Pulse-step mismatch (Bahill, Clark & Stark 1975; Kapoula, Robinson & Hain 1986): a pulse g times
    the matched one leaves the eye off by about (g - 1) times the amplitude at the saccade's end, in the
    direction of the error (overshoot for g > 1), and it drifts to the step's position with the plant's
    long time constant: the eye is ``(1 + s g T1) / (1 + s T1)`` times the matched trajectory."""
    amp = 10.0
    with Head("dots", image_size=16, plant=OrbitalPlant(pulse_gain=gain)) as head:
        plan, tr = _saccade(head, amp, after_ms=400)
        t = tr.times_ms
        e = np.degrees(tr.angles[:, 1, 0] - tr.planned[:, 1, 0])  # right eye, horizontal (rightward saccade)
        # the closed form: error = (g - 1) T1 d/dt [1/(1 + s T1)] q = (g - 1) (q - low-pass_T1(q))
        q = np.degrees(tr.planned[:, 1, 0])
        lp = np.empty_like(q)
        lp[0] = q[0]
        for i in range(1, len(q)):
            dt = t[i] - t[i - 1]
            lp[i] = q[i] + (lp[i - 1] - q[i]) * math.exp(-dt / 150.0)
        expect = (gain - 1.0) * (q - lp)
        after = t > plan.offset_ms
        assert np.sign(e[after][0]) == np.sign(gain - 1.0)
        assert abs(e[after][0]) > 0.5 * abs(gain - 1.0) * amp
        np.testing.assert_allclose(e, expect, atol=0.03 * abs(gain - 1.0) * amp)
        # drift: after 150 ms (one T1) the error has fallen to about 1/e
        k0 = np.searchsorted(t, plan.end_ms)
        k1 = np.searchsorted(t, plan.end_ms + 150)
        assert e[k1] / e[k0] == pytest.approx(math.exp(-1.0), abs=0.05)


def test_noisy_saccades_keep_the_main_sequence():
    """Motor noise draws each saccade's executed amplitude; the executed saccade is the generator's for
    that amplitude, so peak velocity and duration follow the main sequence of what the eyes did (none
    above the generator's saturation because the noise scaled a profile), and each trial draws anew."""
    gen = BurstGenerator()
    with Head("dots", image_size=16, endpoint_noise=0.15, seed=4) as head:
        amps, peaks = [], []
        for _ in range(6):
            plan, tr = _saccade(head, 30.0, after_ms=0)
            executed = plan.amplitude_deg
            amps.append(executed)
            peak = np.degrees(np.hypot(tr.velocities[:, 1, 0], tr.velocities[:, 1, 1])).max()  # the noise is 2-D
            peaks.append(peak)
            assert plan.peak_velocity == pytest.approx(math.radians(gen.peak_velocity_deg_s(executed)), rel=1e-6)
            assert plan.duration_ms == pytest.approx(gen.duration_ms(executed), abs=0.3)
        assert len(set(np.round(amps, 6))) == len(amps)  # each trial its own noise
        assert max(amps) > 31.0 or min(amps) < 29.0
        for executed, peak in zip(amps, peaks):  # each at the abducting eye's main sequence
            assert peak == pytest.approx(_abducting_peak(gen, executed), rel=0.02)
        assert max(peaks) < 1.02 * _abducting_peak(gen, 60.0)  # none beyond the saturation


def _vertical_saccade(head, amp_deg, after_ms=300):
    """A vertical saccade (the nominal plant moves every vertical component) of ``amp_deg``, recorded."""
    head.reset(fixate=models.screen_point(0.0, math.radians(-amp_deg / 2), 1.0))
    plan = head.plan_saccade_to(models.screen_point(0.0, math.radians(amp_deg / 2), 1.0), latency_ms=20)
    head.start_saccade(plan)
    return plan, head.step_ms(plan.end_ms - head.time_ms + after_ms, record=True)


@pytest.mark.parametrize("amp", [5.0, 20.0])
def test_the_move_after_the_offset_is_the_plants_T2_tail_and_the_eye_holds_after_the_plan(amp):
    """The 0.19-0.25 deg each saccade moves after its offset (the 30 deg/s crossing) is not a move after
    the plan: it is Robinson's (1964) fast time constant. The burst has stopped; the eye approaches its
    step as ``exp(-t / T2)`` (the plant's equation with the step alone), so from the threshold speed v
    it has ``v T2`` (30 deg/s x 7.4 ms = 0.22 deg) to go. The plan ends (``end_ms``) once it is within
    ``settle_deg``; after that the eye moves less than ``settle_deg``. The servo drive, tracking the
    same command, makes the same tail: it is in the command, not in the plant's hold rule."""
    gen = BurstGenerator()
    t2 = gen.plant_t2_ms
    tails = {}
    for drive in ("plant", "servo"):
        with Head("dots", image_size=16, eye_drive=drive) as head:
            plan, tr = _vertical_saccade(head, amp)
            t, v = tr.times_ms, np.degrees(tr.angles[:, :, 1])  # (K, 2) both eyes' vertical angles
            left = np.degrees(plan.end_angles[:, 1])[None, :] - v  # still to go (positive: an upward saccade)
            tail = (t >= plan.offset_ms) & (t <= plan.offset_ms + 3 * t2)
            for e in range(2):  # a single exponential of time constant T2: log-linear, slope -1/T2
                slope, _ = np.polyfit(t[tail], np.log(left[tail, e]), 1)
                assert -1.0 / slope == pytest.approx(t2, rel=0.01)
            at_offset = left[np.searchsorted(t, plan.offset_ms)]
            # the threshold's speed times T2 (the offset is the first table step below 30 deg/s)
            assert np.all((0.8 * 30.0 * t2 * 1e-3 < at_offset) & (at_offset < 1.05 * 30.0 * t2 * 1e-3)), at_offset
            assert np.all((0.19 <= at_offset) & (at_offset <= 0.25))  # the audit's 0.19-0.25 deg
            k = np.searchsorted(t, plan.end_ms)
            assert np.abs(v[k:] - v[k]).max() < gen.settle_deg  # after the plan: no extra move
            tails[drive] = at_offset
    np.testing.assert_allclose(tails["plant"], tails["servo"], atol=1e-3)


def test_bad_drive_arguments_are_refused():
    with pytest.raises(ValueError, match="eye_drive"):
        Head("dots", image_size=16, eye_drive="muscle")
    with pytest.raises(ValueError, match="plant configures eye_drive='plant'"):
        Head("dots", image_size=16, eye_drive="servo", plant=OrbitalPlant())
    with pytest.raises(TypeError, match="plant must be a models.OrbitalPlant"):
        Head("dots", image_size=16, plant="fast")
    for bad in ({"t1_ms": 5.0}, {"t2_ms": 0.0}, {"pulse_gain": float("nan")}, {"pulse_gain": 10.0}):
        with pytest.raises(ValueError):
            OrbitalPlant(**bad)


@pytest.mark.parametrize("plant", [False, True])
def test_setpoints_hold_the_endpoint_from_the_snap_on_in_numpy_and_torch(plant):
    """``servo_setpoints(..., end=e)``: the steps after the endpoint (and, with the plant, the snap step
    that ends on it) hold it: position set-point the endpoint, no velocity, feed-forward 0 (servo) or the
    step ``K q_end`` alone (plant); the other steps are the law's own. The same numbers from torch
    tensors (the batched engine) as from numpy (the CPU head), to rounding."""
    rng = np.random.default_rng(1)
    n, T = 3, 12
    q = np.cumsum(rng.normal(size=(n, T + 2, 6)) * 0.01, axis=1)
    end = np.array([T + 1, 5, 1])
    for w, e in enumerate(end):
        q[w, e:] = q[w, e]
    dt = np.full(T + 1, 1e-3)
    I, K, B = np.eye(6) * 3e-5, np.eye(6) * 0.02 + 1e-3, np.eye(6) * 4e-4
    kw = {"stiffness": K, "damping": B} if plant else {}
    free = models.servo_setpoints(q, dt, I, **kw)
    u = models.servo_setpoints(q, dt, I, end=end, **kw)
    for w, e in enumerate(end):
        first = e - (2 if plant else 1)
        for j in range(T):
            if j >= first:
                assert np.array_equal(u[w, j, :6], q[w, e]) and not u[w, j, 6:12].any()
                assert np.allclose(u[w, j, 12:], K @ q[w, e] if plant else 0.0, rtol=0, atol=1e-15)
            else:
                assert np.array_equal(u[w, j], free[w, j])
    if plant:  # the default end is the last boundary: the last step is the snap, held
        assert np.allclose(free[:, -1, 12:], q[:, -1] @ K.T, rtol=0, atol=1e-15) and not free[:, -1, 6:12].any()
    torch = pytest.importorskip("torch")
    kt = {k: torch.as_tensor(v) for k, v in kw.items()}
    ut = models.servo_setpoints(torch.as_tensor(q), torch.as_tensor(dt), torch.as_tensor(I),
                                torch.empty((n, T, 18), dtype=torch.float64), end=torch.as_tensor(end), **kt)
    assert np.allclose(ut.numpy(), u, rtol=1e-12, atol=1e-15)  # BLAS sums in its own order
