"""BinocularSaccade-v0: API conformance, determinism, errors, and honest remapping errors."""

import copy
import gc
import math
import pickle
import subprocess
import sys
import textwrap
import tracemalloc
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import conformal as C
import envs
import models
from memory import rss_kb  # tests/memory.py


@pytest.fixture(scope="module")
def env():
    e = envs.BinocularSaccadeEnv(image_size=64, render_mode="rgb_array")
    yield e
    e.close()


@pytest.mark.parametrize(
    "env_id, kwargs",
    [
        ("BinocularSaccade-v0", {}),
        ("BinocularSaccade-v0", {"action_mode": "cell"}),
        ("BinocularSaccade-v0", {"cortex": "hemispheres", "grayscale": True, "include_coeffs": True}),
        ("BinocularSaccade-v0", {"vergence": True, "remap_model": "mobius"}),
        ("BinocularSaccadeSearch-v0", {}),
        ("BinocularSaccadeSearch-v0", {"action_mode": "cell", "cortex": "hemispheres"}),
        ("BinocularSaccade-v0", {"render_mode": "rgb_array", "remap_model": "shift", "shift_rings": 1.5}),
        ("BinocularSaccadeSearch-v0", {"render_mode": "rgb_array", "action_mode": "cell", "grayscale": True}),
        ("BinocularSaccade-v0", {"task": "free", "scene": "natural", "render_mode": "rgb_array"}),
    ],
)
@pytest.mark.slow
def test_check_env_passes(env_id, kwargs):
    e = gym.make(env_id, image_size=64, fixation_ms=50, **kwargs)
    check_env(e.unwrapped, skip_render_check="render_mode" not in kwargs)
    e.close()


def test_observation_shapes_and_info(env):
    obs, info = env.reset(seed=1)
    g = env.vision.grid
    assert obs["cortical"].shape == (2, g.M, g.N, 3) and obs["cortical"].dtype == np.float32
    assert obs["fovea"].shape == (2, g.n_fovea, 3)
    assert np.array_equal(obs["remapped"], obs["cortical"])  # nothing to predict at reset
    assert obs["eyes"].shape == (2, 3)
    t0 = info["sim_time_ms"]
    obs, r, term, trunc, info = env.step(np.array([0.2, -0.1], np.float32))
    assert set(info["remap_error"]) == set(envs.REMAP_MODELS)
    assert info["sim_time_ms"] - t0 >= 250 + info["saccade_duration_ms"]
    amp = math.degrees(math.acos(math.cos(0.2 * math.radians(30)) * math.cos(0.1 * math.radians(30))))
    assert info["saccade_amplitude_deg"] == pytest.approx(amp, rel=0.05)
    # the burst generator's main sequence: Van Wetter & Van Opstal (2008), 525 (1 - e^{-A/7}) deg/s, within 15 %
    vw = 525.0 * (1 - math.exp(-info["saccade_amplitude_deg"] / 7.0))
    assert info["peak_velocity_deg_s"] == pytest.approx(vw, rel=0.15)
    assert info["landing_error_deg"] < 0.1
    # ground truth and the command are reported; without motor noise they agree
    assert info["eye_angles"].shape == (2, 3) and info["efference_copy"].shape == (2, 3, 3)
    assert np.allclose(info["efference_copy"], info["executed_rotation"]) and np.all(info["endpoint_error_deg"] < 1e-4)
    # the observed eye position is the eye-position signal, settled 250 ms after this ~8 deg saccade
    assert np.allclose(obs["eyes"], env.head.eye_position_signal(), atol=1e-6)
    assert np.degrees(np.abs(obs["eyes"] - info["eye_angles"])).max() < 0.5
    frame = env.render()
    assert frame.dtype == np.uint8 and frame.ndim == 3 and frame.shape[2] == 3
    # top: the left and right eye images with the retina grid drawn on them in cyan
    h, w = env.head.image_shape
    assert frame.shape == (h + 4 + h // 2, 2 * w, 3)
    for i, eye in enumerate((env._frame.left, env._frame.right)):
        top = frame[:h, i * w:(i + 1) * w]
        grid = envs.grid_overlay(g, (h, w), eye.pixels_per_unit)
        assert np.all(top[grid] == (0, 200, 200)) and np.array_equal(top[~grid], eye.image[~grid])
    # bottom: each eye's cut-and-paste cortical map (N/2 x 2M cells stretched to h/2 x w)
    for i, v in enumerate(env._views):
        cm = np.clip(C.cortical_map(v.periphery, g), 0, 1)
        bottom = frame[h + 4:, i * w:(i + 1) * w].astype(float) / 255
        assert bottom[0, 0] == pytest.approx(cm[0, 0], abs=1 / 255)
        assert bottom[-1, -1] == pytest.approx(cm[-1, -1], abs=1 / 255)


def test_motor_noise_separates_the_command_from_the_movement():
    """With endpoint noise the efference copy stays the intended rotation and the observed eye
    position (the eye-position signal, from the command) differs from the true eye by the error."""
    e = envs.BinocularSaccadeEnv(image_size=32, endpoint_noise=0.1, fixation_ms=400)
    try:
        e.reset(seed=4)
        obs, _, _, _, info = e.step(np.array([0.5, 0.2], np.float32))
        assert np.all(info["endpoint_error_deg"] > 0.05)
        assert not np.allclose(info["efference_copy"], info["executed_rotation"], atol=1e-4)
        plan = e.head.last_plan
        assert np.allclose(info["efference_copy"], plan.efference_copy)
        assert np.allclose(obs["eyes"], plan.intended_end_angles, atol=1e-3)  # the signal has settled on the command
        assert np.allclose(info["eye_angles"], plan.end_angles, atol=1e-3)  # the eye on the executed endpoint
    finally:
        e.close()


def test_same_seed_same_observations():
    def run():
        e = envs.BinocularSaccadeEnv(task="search", image_size=64, endpoint_noise=0.05)
        obs, _ = e.reset(seed=7)
        out = [obs]
        rng = np.random.default_rng(0)
        for _ in range(3):
            obs, r, term, trunc, info = e.step(rng.uniform(-0.5, 0.5, 2).astype(np.float32))
            out.append(obs)
        e.close()
        return out, info

    a, ia = run()
    b, ib = run()
    for oa, ob in zip(a, b):
        for k in oa:
            assert np.array_equal(oa[k], ob[k]), k
    assert ia.keys() == ib.keys()
    for k in ia:  # arrays (efference copy, eye angles) compare element-wise
        assert (np.array_equal(ia[k], ib[k]) if isinstance(ia[k], np.ndarray) else ia[k] == ib[k]), k


def test_different_seeds_place_targets_differently(env):
    env.reset(seed=1)
    p1 = env.head.object_position("target")
    env.reset(seed=2)
    assert not np.allclose(p1, env.head.object_position("target"))


@pytest.mark.parametrize("mode", ["sync", "async"])
@pytest.mark.slow
def test_vector_envs_run(mode):
    # EGL contexts do not survive fork: this process has rendered already, so workers are spawned
    kw = {"vector_kwargs": {"context": "spawn"}} if mode == "async" else {}
    vec = gym.make_vec("BinocularSaccade-v0", num_envs=2, vectorization_mode=mode, image_size=48, fixation_ms=20, **kw)
    obs, info = vec.reset(seed=0)
    assert obs["cortical"].shape[0] == 2
    for _ in range(3):
        obs, r, term, trunc, info = vec.step(vec.action_space.sample())
    assert r.shape == (2,)
    vec.close()


def test_step_before_reset_and_bad_actions_raise():
    e = envs.BinocularSaccadeEnv(image_size=48)
    with pytest.raises(RuntimeError, match="reset"):
        e.step(np.zeros(2, np.float32))
    e.reset(seed=0)
    for bad, says in ((np.array([np.nan, 0.0]), "NaN"), (np.array([1.5, 0.0]), r"\[-1, 1\]"),
                      (np.zeros(3), "shape"), ("left", "numbers in")):
        with pytest.raises(ValueError, match=says):
            e.step(bad)
    e.close()
    c = envs.BinocularSaccadeEnv(image_size=48, action_mode="cell", render_mode="rgb_array")
    with pytest.raises(RuntimeError, match="reset"):
        c.render()
    c.reset(seed=0)
    for bad in (-1, c.action_space.n, 2.5, np.nan):
        with pytest.raises(ValueError, match="cell index"):
            c.step(bad)
    c.close()


@pytest.mark.parametrize(
    "kwargs",
    [dict(action_mode="joystick"), dict(scene="moon"), dict(task="dance"), dict(scene="bar"),
     dict(remap_model="affine"), dict(image_size=8), dict(fixation_ms=-5), dict(cortex="v4")],
)
def test_bad_arguments_raise(kwargs):
    with pytest.raises(ValueError):
        envs.BinocularSaccadeEnv(**kwargs)


def test_cell_action_saccades_to_the_cell(env):
    # the motor map: picking the retina cell that holds the target lands the gaze on it
    env.reset(seed=3)
    target = env.head.object_position("target")
    z = env.head.project(target[None])[:, 0].mean()  # cyclopean-ish image position
    k, l = env.vision.grid.locate(np.array([z]))
    cell_env = envs.BinocularSaccadeEnv(image_size=64, action_mode="cell")
    cell_env.reset(seed=3)
    _, _, _, _, info = cell_env.step(int(k[0] * env.vision.grid.N + l[0]))
    cell_size_deg = math.degrees(abs(z) * env.vision.grid.delta) + math.degrees(2 * math.pi / env.vision.grid.N * abs(z))
    assert info["target_error_deg"] < cell_size_deg + 0.5
    cell_env.close()


def test_fixating_the_target_succeeds_and_ends_the_episode(env):
    env.reset(seed=4)
    target = env.head.object_position("target")
    d = target - env.head.cyclopean_position
    h = math.atan2(-d[1], d[0])
    v = math.atan2(d[2], math.hypot(d[0], d[1]))
    a = np.array([h, v]) / math.radians(30)
    obs, r, term, trunc, info = env.step(a.astype(np.float32))
    assert info["success"] and term and not trunc
    assert info["target_error_deg"] < 1.0 and r > 0.8


def test_fixate_targets_lie_5_to_20_deg_out_and_the_budget_truncates():
    e = envs.BinocularSaccadeEnv(image_size=32, fixation_ms=0)
    for seed in range(12):
        e.reset(seed=seed)
        ecc = envs.gaze_errors_deg(e.head, e.head.object_position("target"))  # gaze starts at the centre
        assert np.all((ecc > 5.0 - 0.5) & (ecc < 20.0 + 0.5)), ecc  # +- parallax of the 1 m screen
    e.reset(seed=0)
    away = np.array([0.0, 0.0], np.float32)  # null saccades: the target is never foveated
    for i in range(e.task.max_saccades):
        _, r, term, trunc, info = e.step(away)
        assert not term and trunc == (i == e.task.max_saccades - 1)
        err = info["target_error_deg"]
        assert r == pytest.approx(math.exp(-0.5 * (err / e.task.tolerance_deg) ** 2) - e.task.saccade_cost)
    e.close()


def test_search_rewards_foveating_the_target_and_charges_each_saccade():
    e = envs.BinocularSaccadeEnv(task="search", image_size=32, fixation_ms=0)
    e.reset(seed=5)
    _, r, term, trunc, info = e.step(np.zeros(2, np.float32))  # stay: the target is elsewhere
    assert r == pytest.approx(-e.task.saccade_cost) and not term and not info["success"]
    d = e.head.object_position("target") - e.head.cyclopean_position
    a = np.array([math.atan2(-d[1], d[0]), math.atan2(d[2], math.hypot(d[0], d[1]))]) / math.radians(30)
    _, r, term, trunc, info = e.step(a.astype(np.float32))
    assert info["success"] and term and r == pytest.approx(1.0 - e.task.saccade_cost)
    e.close()


def _aim(e) -> np.ndarray:
    """The vector action that saccades straight to the target."""
    d = e.head.object_position("target") - e.head.cyclopean_position
    return (np.array([math.atan2(-d[1], d[0]), math.atan2(d[2], math.hypot(d[0], d[1]))]) / math.radians(30)).astype(np.float32)


@pytest.mark.parametrize("env_id, task", [("BinocularSaccade-v0", "fixate"), ("BinocularSaccadeSearch-v0", "search")])
def test_registered_step_limit_is_the_task_budget_and_truncates_once(env_id, task):
    """Each id is registered with max_episode_steps = its task's default saccade budget, so TimeLimit and
    the env truncate at the same step: truncated once, at that step, with the env's own flag agreeing."""
    budget = envs.TASKS[task].max_saccades
    assert gym.spec(env_id).max_episode_steps == budget == {"fixate": 5, "search": 10}[task]
    e = gym.make(env_id, image_size=32, fixation_ms=0)
    assert e.spec.max_episode_steps == budget and isinstance(e, gym.wrappers.TimeLimit)
    assert e.unwrapped.task.max_saccades == budget
    for episode in range(2):  # the second episode: TimeLimit's count restarts with reset
        e.reset(seed=5)
        flags = []
        for _ in range(budget):
            _, _, term, trunc, info = e.step(np.zeros(2, np.float32))  # null saccades: never foveated
            assert not term and not info["success"]
            flags.append(trunc)
        assert flags == [False] * (budget - 1) + [True]
        assert e.unwrapped._saccades >= e.unwrapped.task.max_saccades  # the env's own budget ran out too
    e.close()


def test_make_with_max_episode_steps():
    """gym.make(id, max_episode_steps=K): TimeLimit truncates after K steps when K is within the budget;
    longer episodes raise the budget with it; -1 leaves truncation to the env's budget alone."""

    def length(**kwargs):
        e = gym.make("BinocularSaccade-v0", image_size=32, fixation_ms=0, **kwargs)
        e.reset(seed=5)
        n, done = 0, False
        while not done:
            _, _, term, trunc, _ = e.step(np.zeros(2, np.float32))
            assert not term
            n, done = n + 1, trunc
        spec_k = e.spec.max_episode_steps
        e.close()
        return n, spec_k

    assert length(max_episode_steps=3) == (3, 3)
    assert length(max_episode_steps=8, task_kwargs={"max_saccades": 8}) == (8, 8)
    assert length(max_episode_steps=-1) == (5, None)  # no TimeLimit: the env's budget of 5
    assert length(max_episode_steps=-1, task_kwargs={"max_saccades": 7}) == (7, None)


@pytest.mark.parametrize("task", ["fixate", "search", "free"])
def test_reward_components_sum_to_the_reward(task):
    """info reports the reward's additive components as reward_* keys (task.reward_keys), as Gymnasium's
    MuJoCo envs do; they sum to the reward, on misses and on success alike; free viewing has none."""
    e = envs.BinocularSaccadeEnv(task=task, image_size=32, fixation_ms=0)
    expected = {"fixate": ("reward_target", "reward_saccade"), "search": ("reward_target", "reward_saccade"),
                "free": ()}[task]
    assert e.task.reward_keys == expected
    _, info = e.reset(seed=3)
    assert not [k for k in info if k.startswith("reward_")]  # a reset has no reward
    rng = np.random.default_rng(0)
    for i in range(3):
        if i == 2:  # the last saccade, from the start of a new episode, lands on the target
            e.reset(seed=3)
        a = _aim(e) if i == 2 and task != "free" else rng.uniform(-0.3, 0.3, 2).astype(np.float32)
        _, r, term, _, info = e.step(a)
        parts = {k: v for k, v in info.items() if k.startswith("reward_")}
        assert tuple(parts) == expected and all(isinstance(v, float) for v in parts.values())
        assert sum(parts.values()) == pytest.approx(r, abs=1e-12)
        if task != "free":
            assert parts["reward_saccade"] == -e.task.saccade_cost
            assert term == info["success"] == (i == 2)
        if i == 2 and task != "free":
            assert parts["reward_target"] == (1.0 if task == "search" else pytest.approx(1.0, abs=0.2))
    e.close()


_COPY_SCRIPT = textwrap.dedent("""
    import copy, gc, pickle
    import gymnasium as gym
    import models
    import envs

    made = gym.make("BinocularSaccade-v0", image_size=16, fixation_ms=0)
    direct = envs.BinocularSaccadeEnv(image_size=16, fixation_ms=0)
    head = models.Head("dots", image_size=16)
    for name, obj, rendered in (("made", made, False), ("direct", direct, False), ("head", head, False),
                                ("made", made, True), ("direct", direct, True), ("head", head, True)):
        if rendered:  # a GL context now exists: the case that printed Renderer.__del__'s traceback
            head.render() if name == "head" else obj.reset(seed=0)
        for how, f in (("pickle", pickle.dumps), ("deepcopy", copy.deepcopy), ("copy", copy.copy)):
            if name == "made" and how == "copy":
                continue  # a shallow copy of the wrappers shares the env: gymnasium's, harmless
            try:
                f(obj)
            except TypeError as err:
                print(name, rendered, how, "TypeError", err, flush=True)
            else:
                print(name, rendered, how, "copied", flush=True)
            gc.collect()
    made.close(); direct.close(); head.close()
    gc.collect()
    print("done", flush=True)
""")


@pytest.mark.slow
def test_pickle_and_copy_refuse_clearly_without_a_stray_traceback():
    """pickle.dumps / copy.deepcopy / copy.copy of the env (direct or from gym.make) and of models.Head raise
    a TypeError saying what to do instead, before or after the GL context exists, and nothing is printed
    on stderr (no PicklingError, no Renderer.__del__ traceback from a half-built copy)."""
    root = Path(__file__).resolve().parents[1]
    out = subprocess.run([sys.executable, "-c", _COPY_SCRIPT], cwd=root, capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    assert out.stderr.strip() == "", out.stderr
    lines = out.stdout.strip().splitlines()
    assert lines[-1] == "done" and len(lines) == 1 + 2 * (3 + 3 + 2)
    for line in lines[:-1]:
        name, _, how, outcome, message = line.split(" ", 4)
        assert outcome == "TypeError", line
        assert "cannot be pickled or copied" in message, line
        if name == "head":
            assert "models.Head" in message and "new Head with the same arguments" in message
        else:
            assert "BinocularSaccadeEnv" in message and "gymnasium.make(env.spec.id, **env.spec.kwargs)" in message
            assert "same seed" in message


def test_the_copy_recipe_rebuilds_the_same_env():
    """What the TypeError recommends: gym.make(env.spec.id, **env.spec.kwargs), reset with the same seed,
    the same actions: the same observations and rewards."""
    e = gym.make("BinocularSaccadeSearch-v0", image_size=32, fixation_ms=0, action_mode="cell")
    with pytest.raises(TypeError, match="gymnasium.make"):
        copy.deepcopy(e.unwrapped)
    with pytest.raises(TypeError, match="cannot be pickled"):
        pickle.dumps(e)
    twin = gym.make(e.spec.id, **e.spec.kwargs)
    assert twin.spec.max_episode_steps == e.spec.max_episode_steps == 10
    runs = []
    for env in (e, twin):
        obs, _ = env.reset(seed=9)
        run = [obs]
        for a in (3, 40, 55):
            o, r, *_ = env.step(a)
            run += [o, r]
        runs.append(run)
        env.close()
    for a, b in zip(*runs):
        if isinstance(a, dict):
            for k in a:
                assert np.array_equal(a[k], b[k]), k
        else:
            assert a == b


def test_vergence_action_changes_the_fixation_distance():
    e = envs.BinocularSaccadeEnv(image_size=32, fixation_ms=50, vergence=True)
    e.reset(seed=0)

    def vergence_deg():  # angle between the two optical axes
        a, b = (s.eye_axes[:, 1] for s in e.head.eye_states())
        return math.degrees(math.acos(np.clip(a @ b, -1, 1)))

    v0 = vergence_deg()
    e.step(np.array([0.0, 0.0, -1.0], np.float32))  # fixation distance x 1/2: converge
    v1 = vergence_deg()
    e.step(np.array([0.0, 0.0, 1.0], np.float32))  # x 2: back
    v2 = vergence_deg()
    # the geometric vergence of a point at distance D straight ahead: 2 atan(IPD / 2 / D)
    assert v1 == pytest.approx(2 * v0, rel=0.05) and v2 == pytest.approx(v0, abs=0.05)
    e.close()


def test_same_seed_same_observations_in_cell_mode_through_gym_make():
    def run():
        e = gym.make("BinocularSaccade-v0", action_mode="cell", image_size=48, fixation_ms=20)
        obs, _ = e.reset(seed=11)
        acts = np.random.default_rng(1).integers(0, e.action_space.n, 3)
        out = [obs] + [e.step(int(a))[0] for a in acts]
        e.close()
        return out

    for oa, ob in zip(run(), run()):
        for k in oa:
            assert np.array_equal(oa[k], ob[k]), k


def test_remapping_errors_are_honest_for_horizontal_saccades():
    """Pure horizontal saccades in the bar scene: the exact rotation warp (homography) predicts
    the rendered post-saccadic samples better than the translation-plus-shift model."""
    e = envs.BinocularSaccadeEnv(scene="bar", task="free", image_size=128)
    e.reset(seed=0)
    errs = []
    for a in (20.0, -20.0):
        e.reset(seed=0)
        _, _, _, _, info = e.step(np.array([a / 30.0, 0.0], np.float32))
        errs.append(info["remap_error"])
    for err in errs:
        assert err["homography"] < err["shift"]
        assert 0 < err["homography"] < 0.5  # reported, not zero: resolution is lost in the periphery
    e.close()
    # ... and with the shift model's compression gain on (§6.5's log-radius shift) too
    g = envs.BinocularSaccadeEnv(scene="bar", task="free", image_size=128, shift_rings=1.0)
    g.reset(seed=0)
    _, _, _, _, info = g.step(np.array([20.0 / 30.0, 0.0], np.float32))
    assert info["remap_error"]["homography"] < info["remap_error"]["shift"]
    g.close()


def test_reported_remap_errors_are_the_double_precision_reference():
    """``info["remap_error"]`` (compiled, single precision) equals the errors recomputed with the
    numpy path: ``predict_many`` in double precision and the error formula written out."""
    e = envs.BinocularSaccadeEnv(scene="natural", task="free", image_size=64)
    e.reset(seed=3)
    action = np.array([0.25, -0.1], np.float32)
    pre = e._views
    plan, _ = e._plan(*e._decode(action))
    _, _, _, _, info = e.step(action)
    post = e._views
    ref = {}
    for k, model in enumerate(e.remap_models):
        per_eye = []
        for eye in range(2):
            pm = e.vision.point_map(model, plan.efference_copy_eye[eye])
            p = C.predict_many(pre[eye].coeffs, pre[eye].fovea, e.vision.grid, [pm])[0]
            m = p.mask & post[eye].mask
            fm = p.fovea_mask & post[eye].fovea_mask
            a = np.concatenate([post[eye].periphery[m].ravel(), post[eye].fovea[fm].ravel()])
            q = np.concatenate([p.periphery[m].ravel(), p.fovea[fm].ravel()])
            per_eye.append(np.sqrt(np.mean((q - a) ** 2)) / np.sqrt(np.mean((a - a.mean()) ** 2)))
        ref[model] = np.mean(per_eye)
    for model in e.remap_models:
        assert abs(info["remap_error"][model] - ref[model]) < 1e-5 * max(1.0, ref[model]), model
    e.close()


def test_remapped_observation_predicts_the_next_cortical_one():
    e = envs.BinocularSaccadeEnv(scene="natural", task="free", image_size=64)
    e.reset(seed=0)
    obs, *_ , info = e.step(np.array([0.3, 0.0], np.float32))
    diff = np.abs(obs["remapped"] - obs["cortical"]).mean()
    # versus the prediction of "no eye movement": the previous cortical image
    e.reset(seed=0)
    before = e._observation()["cortical"]
    assert diff < np.abs(before - obs["cortical"]).mean()
    e.close()


@pytest.mark.slow
def test_memory_does_not_grow_over_1750_steps():
    """Resident memory (C allocations included) and Python objects stay flat over 1,750 steps: a
    step's buffers are reused. A leak of a step's smallest buffer (one eye's 32 px image, 3 kB)
    would add 5 MB here (1.2 MB in each window of 400 steps)."""
    e = envs.BinocularSaccadeEnv(image_size=32, fixation_ms=0)
    e.reset(seed=0)
    rng = np.random.default_rng(0)

    def run(n):
        for _ in range(n):
            _, _, term, trunc, _ = e.step(rng.uniform(-0.1, 0.1, 2).astype(np.float32))
            if term or trunc:
                e.reset()

    run(200)  # warm up caches and allocator
    growth = []  # kB per window of 400 steps (1,750 steps in all with the ones below)
    for _ in range(3):
        gc.collect()
        before = rss_kb()
        run(400)
        gc.collect()
        growth.append(rss_kb() - before)
    # a leak grows every window (a 3 kB-a-step leak: 1.2 MB each); the allocator's one-off growth
    # (an arena extended once) shows in one window only: two of the three must stay under 1 MB
    assert sorted(growth)[1] < 1024, growth
    tracemalloc.start()
    run(50)
    first, _ = tracemalloc.get_traced_memory()
    run(300)
    gc.collect()
    second, _ = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    assert second - first < 200_000  # bytes: no per-step accumulation of Python objects
    e.close()
