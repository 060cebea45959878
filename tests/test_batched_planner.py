"""The vectorised planner of the batched env (``models.planner``) against the per-world objects it
batches: ``models.BurstGenerator.profile`` for every amplitude, and ``models.Head`` + ``models.SaccadePlan``
(the single env's planning, ``models.plan_clipped``) over sequences of saccades: plans,
command tables, times, efference copies and the eye-position signal. Pure numpy (no GPU extra)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import envs
import models
from models import BatchedPlanner, plan_clipped
from models import profiles as burst_profiles

PROFILE_FIELDS = ("onset_ms", "offset_ms", "duration_ms", "settle_ms", "peak_velocity_deg_s")


@settings(max_examples=60, deadline=None)
@given(st.lists(st.floats(0.0, 90.0, allow_nan=False), min_size=1, max_size=12))
@pytest.mark.slow
def test_profiles_equal_the_generators(amps):
    """Detected onset/offset, settle time, peak speed and positions of every plant equal
    ``BurstGenerator.profile``'s exactly (the same arithmetic, batched; the table's bounds only skip
    entries that cannot matter)."""
    gen = models.BurstGenerator()
    amps = np.array(amps + [0.0, 0.25, 90.0, 1e-7])
    batch = burst_profiles(gen, amps)
    t = np.linspace(-1.0, 330.0, 400)
    for k, a in enumerate(amps):
        ref = gen.profile(a)
        for name in PROFILE_FIELDS:
            assert getattr(batch, name)[k] == getattr(ref, name), (a, name)
    for plant in range(3):
        ref = np.stack([gen.profile(a).position(t, plant) for a in amps])
        np.testing.assert_array_equal(batch.position(np.broadcast_to(t, ref.shape), plant), ref)


@settings(max_examples=8, deadline=None)
@given(st.sampled_from([dict(burst_max_deg_s=600.0, settle_deg=0.3, abducting_t2_ms=4.0), dict(settle_deg=1.0),
                        dict(settle_deg=1e-4, burst_lag_ms=20.0), dict(plant_t2_ms=15.0, burst_lag_ms=4.0)]),
       st.lists(st.floats(0.0, 90.0, allow_nan=False), min_size=1, max_size=20))
@pytest.mark.slow
def test_profiles_of_other_generators(params, amps):
    """Other generators, the settle margin included from 1e-4 to 1 deg (where the table's bounds on
    the computed steps are the tightest)."""
    gen = models.BurstGenerator(**params)
    amps = np.array(amps + [0.0, 0.1, 3.0, 17.3, 44.0, 88.8])
    batch = burst_profiles(gen, amps)
    for k, a in enumerate(amps):
        ref = gen.profile(a)
        for name in PROFILE_FIELDS:
            assert getattr(batch, name)[k] == getattr(ref, name), (a, name)


def _step(head: models.Head, ms: int, pose: np.ndarray) -> None:
    """Step the head's physics ``ms`` and put its neck back where ``pose`` (qpos) had it: the planner
    takes the head's pose at reset (the env never moves the neck; under the physics it drifts by
    ~1e-7 m, which this comparison of the planning arithmetic leaves out)."""
    import mujoco

    head.step_ms(ms)
    eyes = head.data.qpos[head._qadr].copy()
    head.data.qpos[:] = pose
    head.data.qpos[head._qadr] = eyes
    mujoco.mj_forward(head.model, head.data)


def _planner(n: int, seed: int, **kw) -> BatchedPlanner:
    """A planner of n worlds, world i reset as Head.reset(seed=seed + i) resets a head."""
    head = models.Head("dots", 16, seed=0, **kw)
    planner = BatchedPlanner(head, n)
    for i in range(n):
        head.reset(seed=seed + i)
        planner.take_reset(i)
    return planner


def _heads(n: int, seed: int, **kw) -> list[models.Head]:
    heads = [models.Head("dots", 16, seed=seed + i, **kw) for i in range(n)]
    for i, h in enumerate(heads):
        h.reset(seed=seed + i)
    return heads


CASES = {
    "burst": {},
    "legacy": {"saccade_model": "legacy"},
    "noise": {"endpoint_noise": 0.15},
    "motor": {"motor_noise": models.HUMAN_MOTOR_NOISE},  # anisotropic scatter and undershoot
}


@pytest.mark.parametrize("case", sorted(CASES))
@pytest.mark.parametrize("vergence", [False, True])
def test_planner_follows_the_heads(case, vergence):
    """Four worlds, five steps, each planning a shuffled subset of the worlds (the others wait), against
    a ``models.Head`` per world stepping its physics: the same plans and clipping, command tables
    (< 1e-9 rad), end times (exact), efference copies, eye-position signal during and after, and the
    generators' states. World 1 is sent far beyond the range (clipped by bisection) and then further
    out from the edge (no attempt reachable: a null saccade); world 2 makes a zero saccade; with
    vergence, world 0's factor is exactly 1 (with noise: planned in the batch beside worlds planned
    by the single env's code)."""
    kw = CASES[case]
    n, fixation_ms = 4, 40
    ref = _heads(n, 11, **kw)
    poses = [h.data.qpos.copy() for h in ref]
    planner = _planner(n, 11, **kw)
    rng = np.random.default_rng(5)
    nulls = 0
    for step in range(5):
        worlds = rng.permutation(n)[: n - step % 2]
        hv = rng.uniform(-0.35, 0.35, (n, 2))
        hv[2] = 0.0 if step == 1 else hv[2]
        if step in (2, 3):
            hv[1] = [1.4, -0.2]  # far beyond the 45 deg range: clipped; then pushed out from the edge
            worlds = np.union1d(worlds, [1])[::-1]
        factor = 2.0 ** rng.uniform(-0.6, 0.6, n) if vergence else np.ones(n)
        factor[0] = 1.0
        plans, clipped = planner.plan(worlds, hv[worlds], factor[worlds])
        table, rows = planner.commands(plans)
        advance = plans.end_ms - planner.time_ms[worlds] + fixation_ms
        for k, i in enumerate(worlds):
            head = ref[i]
            plan, c = plan_clipped(head, hv[i, 0], hv[i, 1], factor[i])
            assert c == clipped[k]
            if step in (2, 3) and i == 1:
                assert c
                nulls += plan.amplitude < 1e-6
            assert plans.onset_ms[k] == plan.onset_ms and plans.end_ms[k] == plan.end_ms
            for a, b in ((plans.end[k], plan.end_angles), (plans.intended_end[k], plan.intended_end_angles),
                         (plans.signal_start[k], plan.signal_start_angles), (plans.target[k], plan.target),
                         (plans.efference_copy[k], plan.efference_copy),
                         (plans.efference_copy_eye[k], plan.efference_copy_eye),
                         (plans.executed_rotation[k], plan.executed_rotation),
                         (plans.endpoint_error_deg[k], plan.endpoint_error_deg)):
                np.testing.assert_allclose(a, b, rtol=0, atol=1e-9)
            for a, b in ((plans.amplitude[k], plan.amplitude), (plans.settle_ms[k], plan.settle_ms),
                         (plans.duration_ms[k], plan.duration_ms), (plans.peak_velocity[k], plan.peak_velocity)):
                assert abs(a - b) <= 1e-9 * max(1.0, abs(b))
            span = plan.end_ms - plan.onset_ms
            assert rows[k] == span + 1
            q = plan.angles(plan.onset_ms + np.arange(span + 1.0)).reshape(-1, 6)
            np.testing.assert_allclose(table[k, :span + 1], q, rtol=0, atol=1e-9)
            np.testing.assert_allclose(table[k, span + 1:], np.broadcast_to(q[-1], table[k, span + 1:].shape), atol=0)
            t = plan.onset_ms + np.array([0.3, 7.0, 19.5, 60.0, 140.0])  # fractional times, mid-saccade
            np.testing.assert_allclose(plans.angles(np.broadcast_to(t, (len(worlds), len(t))))[k], plan.angles(t),
                                       atol=1e-9)
            head.start_saccade(plan)
            _step(head, int(advance[k]), poses[i])
        planner.start(worlds, plans, advance)
        now = planner.eye_position_signal()
        for i in range(n):
            assert planner.time_ms[i] == ref[i].time_ms
            np.testing.assert_allclose(now[i], ref[i].eye_position_signal(), atol=1e-9)
            np.testing.assert_allclose(planner.hold[i], ref[i]._hold, atol=1e-12)
            assert planner.rngs[i].bit_generator.state == ref[i]._rng.bit_generator.state
            plan = ref[i].last_plan
            if plan is None:
                continue
            times = plan.onset_ms + np.array([-60.0, 0.0, 25.5, 90.0, 400.0])
            batch, k = planner._last[i]
            got = batch.eye_position_signal(np.tile(times, (batch.n, 1)))[k]
            np.testing.assert_allclose(got, plan.eye_position_signal(times), atol=1e-9)
    if not ({"endpoint_noise", "motor_noise"} & set(kw)):  # (a noisy landing may leave room inside the edge)
        assert nulls >= 1  # the push from the edge found no reachable attempt at least once


def test_planner_refuses_heads_mid_saccade_and_short_advances():
    planner = _planner(2, 0)
    plans, _ = planner.plan(np.arange(2), np.full((2, 2), 0.1), np.ones(2))
    with pytest.raises(ValueError, match="past its saccade"):
        planner.start(np.arange(2), plans, np.zeros(2, np.int64))
    head = planner.head
    head.start_saccade(head.plan_saccade(0.1, 0.0))
    with pytest.raises(RuntimeError, match="freshly reset"):
        planner.take_reset(0)


def test_planner_input_edges():
    """No worlds to plan, NaN amplitudes and float32 increments."""
    planner = _planner(2, 0)
    plans, clipped = planner.plan(np.arange(0), np.zeros((0, 2)), np.ones(0))
    assert plans.n == 0 and clipped.shape == (0,) and planner.commands(plans)[0].shape[0] == 0
    with pytest.raises(models.OculomotorRangeError, match="amplitudes"):
        burst_profiles(models.BurstGenerator(), [np.nan])
    a, _ = planner.plan(np.arange(2), np.full((2, 2), 0.1, np.float32), np.ones(2, np.float32))
    b, _ = planner.plan(np.arange(2), np.full((2, 2), np.float32(0.1), np.float64), np.ones(2))
    np.testing.assert_array_equal(a.end, b.end)


@pytest.mark.parametrize("scene", models.SCENES)
def test_settled_reset_equals_head_reset(scene):
    """SettledReset (the batched env's resets) leaves a head as Head.reset does: joints, velocities,
    set-points, mocap layout, clock, held angles, fixation point and the generator's state."""
    from models import SettledReset

    a, b = models.Head(scene, 16, seed=0), models.Head(scene, 16, seed=0)
    fast = SettledReset(a)
    assert fast.usable
    task = {"dots": "fixate", "search": "search"}.get(scene, "free")
    task = envs.TASKS[task]()
    for seed in (3, 12345):
        a.start_saccade(a.plan_saccade(0.1, 0.05))  # some state to reset from
        a.step_ms(30)
        hidden = a.scene.objects[0]
        a.set_visible(hidden, False)
        if a.scene.flashes:
            a.flash(a.scene.flashes[0])
        fast.apply(a, seed)
        b.reset(seed=seed)
        np.testing.assert_array_equal(a.model.geom_rgba, b.model.geom_rgba)
        task.initialize_episode(a, np.random.default_rng(seed))
        task.initialize_episode(b, np.random.default_rng(seed))
        for k in ("qpos", "qvel", "ctrl", "act", "mocap_pos", "mocap_quat", "geom_xpos", "cam_xpos"):
            np.testing.assert_array_equal(getattr(a.data, k), getattr(b.data, k), err_msg=k)
        assert a.time_ms == b.time_ms and a._plan is None and a._signal_plan is None
        for k in ("_hold", "_signal_hold", "_fix_head"):
            np.testing.assert_array_equal(getattr(a, k), getattr(b, k))
        assert a._rng.bit_generator.state == b._rng.bit_generator.state


@pytest.mark.parametrize("scene", models.SCENES)
def test_take_settled_equals_one_by_one_resets(scene):
    """BatchedPlanner.take_settled (the batched env's resets, all at once) leaves each world as
    SettledReset.apply + the task's initialize_episode + take_reset leave it, world by world: clock,
    holds, fixation, signal, joints, set-points, every movable object, and the generator's state."""
    from models import SettledReset

    task = envs.TASKS[{"dots": "fixate", "search": "search"}.get(scene, "free")]()
    head = models.Head(scene, 16, seed=0)
    settled = SettledReset(head)
    n = 5
    one, many = BatchedPlanner(head, n), BatchedPlanner(head, n)
    worlds = np.array([3, 0, 4])
    seeds = [7, 123456, 2**31 - 2]
    env_rngs = [np.random.default_rng(100 + k) for k in range(3)]
    for k, i in enumerate(worlds):
        settled.apply(head, seeds[k])
        task.initialize_episode(head, np.random.default_rng(100 + k))
        one.take_reset(i)
    many.take_settled(worlds, settled, seeds, [task.placements(r) for r in env_rngs])
    for k in ("time_ms", "hold", "signal_hold", "signal_now", "fix_head", "qpos", "qvel", "ctrl", "mocap_pos",
              "mocap_quat"):
        np.testing.assert_array_equal(getattr(many, k)[worlds], getattr(one, k)[worlds], err_msg=k)
    for i in worlds:
        assert many.rngs[i].bit_generator.state == one.rngs[i].bit_generator.state
    assert many.rngs[1] is None and not many.qpos[1].any()  # worlds not reset are not touched
    if scene == "dots":  # the task's target moved: the placements arrived
        assert len({tuple(p) for p in many.mocap_pos[worlds, settled.mocap_index("target")]}) == 3
    with pytest.raises(KeyError, match="not a movable object"):
        many.take_settled([0], settled, [1], [{"no_such_body": np.zeros(3)}])
    for name in list(settled._mocap_rows)[:1]:  # (the bar scene has no movable object)
        with pytest.raises(ValueError, match="finite"):
            many.take_settled([0], settled, [1], [{name: np.full(3, np.nan)}])
    with pytest.raises(ValueError, match="one seed"):
        many.take_settled([0, 1], settled, [1])


def test_command_tables_in_the_reused_buffer_are_the_fresh_tables():
    """``BatchedPlanner.commands`` writes every call's tables into one buffer (grown, then reused by a
    shorter table): each is bit-identical to ``SaccadePlans.command_table()``'s new array."""
    n = 6
    planner = _planner(n, 3)
    rng = np.random.default_rng(8)
    worlds = np.arange(n)
    sizes = []
    for scale in (0.05, 0.6, 0.1, 0.6):  # small, larger (the buffer grows), small again (reused), larger
        plans, _ = planner.plan(worlds, rng.uniform(-scale, scale, (n, 2)), np.ones(n))
        table, rows = planner.commands(plans)
        fresh, fresh_rows = plans.command_table()
        assert table.dtype == fresh.dtype and table.shape == fresh.shape and table.flags.c_contiguous
        np.testing.assert_array_equal(table, fresh)
        np.testing.assert_array_equal(rows, fresh_rows)
        assert np.shares_memory(table, planner._table)
        sizes.append(table.shape[1])
    assert sizes[1] > sizes[0] and sizes[2] < sizes[1]  # the buffer was grown and then reused
    with pytest.raises(ValueError, match="contiguous flat float64"):
        plans.command_table(np.empty(3))


def _bits(a: np.ndarray) -> np.ndarray:
    """The float64 numbers' bit patterns (telling -0.0 from 0.0, unlike ==)."""
    return np.ascontiguousarray(a, np.float64).view(np.uint64)


def _varied_plans(case: str) -> models.SaccadePlans:
    """Plans of eight worlds of one case: random saccades and vergence, a zero saccade, and a world whose
    vertical angles are 0.0 until the settle time and -0.0 from it (Listing's torsion keeps its sign)."""
    from models.saccade_plans import _FIELDS

    n = 8
    planner = _planner(n, 21, **CASES[case])
    rng = np.random.default_rng(2)
    hv = rng.uniform(-0.35, 0.35, (n, 2))
    hv[1] = 0.0
    factor = 2.0 ** rng.uniform(-0.6, 0.6, n)
    factor[:2] = 1.0
    plans, _ = planner.plan(np.arange(n), hv, factor)
    cols = {k: getattr(plans, k).copy() for k in _FIELDS}
    for k in ("start", "signal_start"):
        cols[k][0, :, 1] = 0.0
    for k in ("end", "intended_end"):
        cols[k][0, :, 1] = -0.0
    return models.SaccadePlans(*cols.values(), generator=plans.generator, vergence=plans.vergence,
                               eye_position=plans.eye_position)


@pytest.mark.parametrize("case", sorted(CASES))
def test_command_tables_are_the_angles_at_every_ms_to_the_bit(case):
    """``SaccadePlans.command_table`` (``_plan_kernels.command_rows``: the rows in use computed once, the
    held rows copied, the tangent of each eye's vertical half-angle kept while it repeats) gives the
    same bits as ``SaccadePlans.angles`` at the whole ms ``min(k, rows - 1)`` after each onset."""
    plans = _varied_plans(case)
    table, rows = plans.command_table()
    T = table.shape[1]
    t = np.minimum(np.arange(T, dtype=float)[None, :], (rows - 1)[:, None].astype(float))
    ref = plans.angles(plans.onset_ms[:, None] + t).reshape(plans.n, T, 6)
    np.testing.assert_array_equal(_bits(table), _bits(ref))
    assert np.signbit(table[0, -1, [1, 4]]).all() and not np.signbit(table[0, 0, [1, 4]]).any()


@pytest.mark.parametrize("case", sorted(CASES))
def test_eye_position_signal_from_the_cdf_table_to_the_bit(case):
    """At times on the knots' half-ms grid (whole ms after onset, whole-ms delay: the batched env's) the
    eye-position signal reads the Gaussian's CDF from one table per call; it gives the same bits as the
    CDF computed at every knot, and times one ulp off the grid are computed."""
    from models import _plan_kernels as K
    from models.eye_kinematics import with_listing
    from models.saccade_plans import KNOT_MS, _cdf_grid

    plans = _varied_plans(case)
    eps = plans.eye_position
    grid = plans.onset_ms[:, None] + np.arange(-80.0, 600.0, 17.0)[None, :]  # before, during and after
    for times in (grid, np.nextafter(grid, np.inf), grid + 0.25):
        got = plans.eye_position_signal(times)
        t = plans._rel(times) - eps.delay_ms
        count = np.ceil((plans.settle_ms + KNOT_MS) / KNOT_MS).astype(np.int64)
        smooth = np.empty(t.shape + (4,))
        K.signals(*plans.profiles.args(), *plans._args("intended"), KNOT_MS, count, t, eps.sigma_ms,
                  np.zeros(0), 0.0, smooth)
        start = plans.signal_start[:, None, :, :2]
        hv = start + (plans.intended_end[:, None, :, :2] - start) * smooth.reshape(t.shape + (2, 2))
        np.testing.assert_array_equal(_bits(got), _bits(with_listing(hv)))
    assert _cdf_grid(plans._rel(grid) - eps.delay_ms, count, eps.sigma_ms)[0].size > 0  # the table was read
    assert _cdf_grid(plans._rel(grid + 0.1) - eps.delay_ms, count, eps.sigma_ms)[0].size == 0  # off the grid


def test_layouts_of_many_worlds_are_each_worlds_own_draws(monkeypatch):
    """The search display laid out for many worlds at once (``layout.many``, what ``take_settled`` uses) is,
    to the bit, each world's layout drawn alone from its own generator; a layout without ``many`` (drawn
    world by world and written at once) gives the same worlds."""
    from models import SettledReset

    layout = models.Head("search", 16, seed=0).scene.layout
    seeds = list(range(0, 4000, 97))
    names, pts = layout.many([np.random.default_rng(s) for s in seeds])
    for k, s in enumerate(seeds):
        alone = layout(np.random.default_rng(s))
        assert tuple(alone) == names
        np.testing.assert_array_equal(_bits(np.array(list(alone.values()))), _bits(pts[k]))
    head = models.Head("search", 16, seed=0)
    settled = SettledReset(head)
    worlds = np.arange(len(seeds))[::-1]
    fast, plain = BatchedPlanner(head, len(seeds)), BatchedPlanner(head, len(seeds))
    fast.take_settled(worlds, settled, seeds)
    monkeypatch.setattr(head.scene, "layout", lambda rng: layout(rng))  # no ``many``
    plain.take_settled(worlds, settled, seeds)
    np.testing.assert_array_equal(_bits(fast.mocap_pos), _bits(plain.mocap_pos))
    assert len({tuple(p) for p in fast.mocap_pos[:, settled.mocap_index("target")]}) == len(seeds)


def test_command_tables_of_every_world_built_in_place():
    """``BatchedPlanner.commands(plans, worlds)``: the table of all N worlds, each planned world's rows its
    plan's table and every other world holding its eyes -- to the bit what the batched env assembled
    before (a new (N, T, 6) array of the holds, the plans' tables copied into their worlds' rows)."""
    n = 7
    planner = _planner(n, 5)
    rng = np.random.default_rng(4)
    for worlds in (np.array([5, 0, 3]), np.arange(n), np.array([6])):
        plans, _ = planner.plan(worlds, rng.uniform(-0.3, 0.3, (len(worlds), 2)), np.ones(len(worlds)))
        own, rows = plans.command_table()
        before = np.empty((n, own.shape[1], 6))
        before[:] = planner.hold.reshape(n, 1, 6)
        before[worlds] = own
        table, lengths = planner.commands(plans, worlds)
        np.testing.assert_array_equal(_bits(table), _bits(before))
        expected = np.ones(n, np.int64)
        expected[worlds] = rows
        np.testing.assert_array_equal(lengths, expected)
        assert np.shares_memory(table, planner._table)
        planner.start(worlds, plans, plans.end_ms - planner.time_ms[worlds] + 30)
    plans, _ = planner.plan(np.array([1, 2]), rng.uniform(-0.3, 0.3, (2, 2)), np.ones(2))
    with pytest.raises(ValueError, match="distinct"):
        plans.command_table(rows=[1, 1], num_rows=n)
    with pytest.raises(ValueError, match="below num_rows"):
        plans.command_table(rows=[1, n], num_rows=n)
