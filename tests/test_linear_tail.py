"""The eyes' slow settle in closed form (models.linear_tail) against stepping MuJoCo's physics.

Ground truth: the same head, the same plans and the same controls stepped by ``mujoco.mj_step`` (the
closed form switched off, ``Head(linear_tail=False)``)."""

from __future__ import annotations

import numpy as np
import pytest

import models
from models import LinearTail, linear_tail

TOL_DEG = 1e-4  # the batched-physics issue's bar: eye angles within 1e-4 deg of the reference


def _gaze_shifts(head: models.Head, seed: int, n: int) -> np.ndarray:
    """Eye angles after ``n`` random binocular gaze shifts (near and far, with latencies), read at a
    random instant inside each saccade's tail and 300 ms after its end."""
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(n):
        z = rng.uniform(0.25, 2.0)  # 25 cm to 2 m: vergence changes up to ~14 deg
        target = head.to_world(np.array([z, rng.uniform(-0.4, 0.4) * z, rng.uniform(-0.3, 0.3) * z]))
        plan = head.plan_saccade_to(target, latency_ms=int(rng.integers(0, 50)))
        head.start_saccade(plan)
        for chunk in (int(rng.integers(1, 200)), plan.end_ms - head.time_ms + 300):
            if chunk > 0:
                head.step_ms(chunk)
            out.append(head.eye_angles)
    return np.array(out)


def _head(drive: str, pulse_gain: float, seed: int, linear: bool) -> models.Head:
    kw: dict = {"image_size": 32, "seed": seed, "eye_drive": drive, "linear_tail": linear}
    if drive == "plant":
        kw["plant"] = models.OrbitalPlant(pulse_gain=pulse_gain)
    head = models.Head(**kw)
    head.reset(seed=seed)
    return head


@pytest.mark.parametrize(
    "drive,pulse_gain",
    [("plant", 1.0), ("plant", 1.3), ("plant", 0.8), ("servo", 1.0)],
)
def test_closed_form_tail_matches_stepped_physics(drive, pulse_gain, monkeypatch):
    steps = []
    run = LinearTail.run

    def counting(self, controls, record=False):
        done, states = run(self, controls, record)
        steps.append(done)
        return done, states

    monkeypatch.setattr(LinearTail, "run", counting)
    for seed in (0, 1, 2):
        fast = _gaze_shifts(_head(drive, pulse_gain, seed, True), seed, 5)
        n_closed = sum(steps)
        ref = _gaze_shifts(_head(drive, pulse_gain, seed, False), seed, 5)
        assert sum(steps) == n_closed, "the reference must step every millisecond"
        err = np.degrees(np.abs(fast - ref).max())
        assert err < TOL_DEG, f"{drive} pulse_gain={pulse_gain} seed={seed}: {err:.2e} deg from the stepped physics"
    # the closed form really ran: most of each gaze shift's tail and hold (hundreds of steps each)
    assert sum(steps) > 3 * 5 * 200


def test_time_and_controls_advance_as_stepping():
    a, b = _head("plant", 1.0, 0, True), _head("plant", 1.0, 0, False)
    for head in (a, b):
        head.start_saccade(head.plan_saccade_to(head.to_world(np.array([0.4, -0.1, 0.05]))))
        head.step_ms(900)
    assert a.data.time == pytest.approx(b.data.time, abs=1e-12)
    np.testing.assert_allclose(a.data.ctrl, b.data.ctrl, atol=1e-12)


def test_a_joint_reaching_its_range_is_stepped():
    """Where the map would carry a limited joint to its range (the constraint solver acts there), the
    closed form stops at the step before and leaves the rest to the physics."""
    head = _head("servo", 1.0, 0, True)
    m, d = head.model, head.data
    lin = head._servo.linear
    adr = int(head.eye_joint_addresses[0][0])  # left eye, horizontal
    hi = float(m.jnt_range[m.dof_jntid[adr], 1])
    d.qpos[adr] = hi - np.radians(0.05)
    d.qvel[:] = 0.0
    d.qvel[adr] = np.radians(5.0)  # slow enough for the map, towards the range
    controls = np.tile(head._servo.hold_controls(d.qpos[head.eye_joint_addresses[0]].reshape(2, 3)), (200, 1))
    controls[:, 0] = hi + np.radians(2.0)  # the servo pulls beyond the range
    assert lin.ready()
    done, _ = lin.run(controls)
    assert 1 <= done < 20  # the exact first step, then the map up to the range
    assert d.qpos[adr] < hi
    assert lin.run(controls[done:])[0] <= 1  # no map carries it further: the physics steps on


def test_not_ready_while_fast_or_neck_moving():
    head = _head("plant", 1.0, 0, True)
    lin = head._servo.linear
    assert lin.ready()  # at rest after reset
    head.data.qvel[head.eye_joint_addresses[1][0]] = np.radians(2 * linear_tail.LINEAR_SPEED_DEG_S)
    assert not lin.ready()
    head.data.qvel[:] = 0.0
    head.data.qvel[0] = np.radians(2 * linear_tail.REST_SPEED_DEG_S)  # the neck turning
    assert not lin.ready()
    assert lin.run(np.zeros((100, 18))) == (0, None)


@pytest.mark.parametrize("lib", ["numpy", "torch"])
def test_slow_enough_is_one_test_for_numpy_and_torch(lib):
    """The single head (numpy, one state) and the batched engine (torch, worlds x nv) ask the same
    question of ``slow_enough``; here against the thresholds written out for 3 worlds."""
    eye = np.array([False, True, True, True, True])
    rng = np.random.default_rng(3)
    qv = np.radians(rng.uniform(-1.0, 1.0, (200, 3, 5)) * np.array([1.2 * linear_tail.REST_SPEED_DEG_S] + 4 * [12.0]))
    if lib == "torch":
        torch = pytest.importorskip("torch")
        conv = torch.as_tensor
    else:
        conv = np.asarray
    for q in qv:
        v = np.degrees(np.abs(q))
        expect = bool(
            (v[:, 1:] < linear_tail.LINEAR_SPEED_DEG_S).all() and (v[:, 0] < linear_tail.REST_SPEED_DEG_S).all()
        )
        assert linear_tail.slow_enough(conv(q), conv(eye)) == expect
        expect0 = bool((v[0, 1:] < linear_tail.LINEAR_SPEED_DEG_S).all() and v[0, 0] < linear_tail.REST_SPEED_DEG_S)
        assert linear_tail.slow_enough(conv(q[0]), conv(eye)) == expect0
    assert linear_tail.slow_enough(conv(np.zeros((2, 4))), conv(np.ones(4, bool)))  # eyes only, at rest


@pytest.mark.parametrize("drive", ["plant", "servo"])
def test_step_matrices_match_mujocos_finite_differences(drive):
    """``step_matrices`` against ``mujoco.mjd_transitionFD`` (centred differences) at a posture away from
    primary, mid-tail: ``B`` alike to 1e-9 (relative); ``A`` alike but for the velocity products,
    which ``implicitfast`` leaves out of its implicit part (at 10 deg/s they are < 1e-3 of A's scale)."""
    import mujoco

    head = _head(drive, 1.0, 0, False)
    head.start_saccade(head.plan_saccade_to(head.to_world(np.array([0.5, 0.15, 0.1]))))
    head.step_ms(90)
    m, d = head.model, head.data
    nv = m.nv
    A_fd, B_fd = np.zeros((2 * nv, 2 * nv)), np.zeros((2 * nv, m.nu))
    mujoco.mjd_transitionFD(m, d, 1e-6, True, A_fd, B_fd, None, None)
    mujoco.mj_forward(m, d)
    M = np.zeros((nv, nv))
    mujoco.mj_fullM(m, d, M)
    A, B = linear_tail.step_matrices(M, *linear_tail.linear_forces(m), m.opt.timestep)
    np.testing.assert_allclose(B, B_fd, rtol=0, atol=1e-9 * np.abs(B_fd).max())
    np.testing.assert_allclose(A[:nv], A_fd[:nv], rtol=0, atol=1e-6 * np.abs(A_fd).max())
    assert np.abs(A - A_fd).max() < 1e-3 * np.abs(A_fd).max()
    # the torch form (the batched engine's) is the same numbers
    torch = pytest.importorskip("torch")
    At, Bt = linear_tail.step_matrices(
        torch.as_tensor(M)[None], *(torch.as_tensor(a) for a in linear_tail.linear_forces(m)), m.opt.timestep
    )
    np.testing.assert_allclose(At[0].numpy(), A, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(Bt[0].numpy(), B, rtol=1e-12, atol=1e-15)


def test_models_outside_the_linear_form_are_refused():
    import mujoco

    spec = mujoco.MjSpec.from_string(
        '<mujoco><worldbody><body><joint type="ball"/><geom size="0.1"/></body></worldbody></mujoco>'
    )
    assert linear_tail.linear_forces(spec.compile()) is None
    head = _head("plant", 1.0, 0, True)
    assert linear_tail.linear_forces(head.model) is not None


def test_a_stretch_cut_into_calls_or_recorded_gives_the_same_states():
    """The map in use carries on across calls while nothing else touches the state, so neither how a
    settle is cut into ``step_ms`` calls nor recording it changes a bit of the result."""
    heads = [_head("plant", 1.0, 3, True) for _ in range(3)]
    for h in heads:
        h.start_saccade(h.plan_saccade_to(h.to_world(np.array([0.35, 0.08, -0.05]))))
    heads[0].step_ms(900)
    for n in [37, 1, 1, 2, 120, 3, 300, 436]:
        heads[1].step_ms(n)
    trace = heads[2].step_ms(900, record=True)
    for h in heads[1:]:
        np.testing.assert_array_equal(h.data.qpos, heads[0].data.qpos)
        np.testing.assert_array_equal(h.data.qvel, heads[0].data.qvel)
        assert h.data.time == heads[0].data.time
    np.testing.assert_array_equal(trace.angles[-1], heads[0].eye_angles)
    assert len(trace.times_ms) > 900  # every physics step is in the trace, the closed form's too
