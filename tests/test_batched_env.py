"""The batched env (``envs.BatchedBinocularSaccade``) on Warp's CPU backend: spaces, the vector entry
point, determinism, agreement with ``BinocularSaccadeEnv`` (the ground truth: the CPU physics, the
classic EGL renderer, float64 vision), autoreset and bad input.

The first construction compiles Warp's kernels (~30 s on a cold cache); the envs are shared per module.
"""

from __future__ import annotations

import math
import os

import gymnasium as gym
import numpy as np
import pytest

torch = pytest.importorskip("torch")
pytest.importorskip("mujoco_warp")

import functools  # noqa: E402

import envs  # noqa: E402
import models  # noqa: E402
from envs import BatchedBinocularSaccade as _Batched, BinocularSaccadeEnv as _Single  # noqa: E402

#: The engines' shared vision, remapping, tasks and options are compared with the eyes on the servo
#: (exact pointing: both engines land them within 1e-6 deg); the orbital plant, the physics' own
#: answer at each engine's timestep, has its own comparison (``test_agrees_with_the_single_env``).
BatchedBinocularSaccade = functools.partial(_Batched, eye_drive="servo")
BinocularSaccadeEnv = functools.partial(_Single, eye_drive="servo")

#: The device the batched envs run on: Warp's CPU backend unless CONFORMAL_TEST_DEVICE names another
#: (``CONFORMAL_TEST_DEVICE=cuda python -m pytest tests/test_batched_env.py`` on a machine with an NVIDIA GPU).
DEVICE = os.environ.get("CONFORMAL_TEST_DEVICE", "cpu")
N = 2
SIZE = 64
ACTIONS = [np.array([[0.5, 0.2], [-0.3, 0.4]], np.float32), np.array([[-0.4, -0.1], [0.2, -0.5]], np.float32)]


@pytest.fixture(scope="module")
def benv():
    env = BatchedBinocularSaccade(N, device=DEVICE, image_size=SIZE, task_kwargs={"max_saccades": 2},
                                  eye_drive="plant")
    yield env
    env.close()


def _cpu_run(seed: int, actions: list[np.ndarray], world: int, **kwargs):
    """The single env's observations, rewards and infos for world ``world`` of the batched run."""
    env = BinocularSaccadeEnv(image_size=SIZE, task_kwargs={"max_saccades": 2}, **kwargs)
    obs, info = env.reset(seed=seed + world)
    out = [(obs, 0.0, False, False, info)]
    for a in actions:
        out.append(env.step(a[world]))
    env.close()
    return out


def _np(obs):
    return {k: (v.cpu().numpy() if isinstance(v, torch.Tensor) else v) for k, v in obs.items()}


def test_spaces_and_vector_entry_point(benv):
    single = BinocularSaccadeEnv(image_size=SIZE)
    assert benv.single_observation_space == single.observation_space
    assert benv.single_action_space == single.action_space
    assert benv.action_space.shape == (N, 2)
    single.close()
    obs, info = benv.reset(seed=3)
    for k, space in benv.single_observation_space.spaces.items():
        assert isinstance(obs[k], torch.Tensor) and obs[k].device.type == torch.device(DEVICE).type
        assert tuple(obs[k].shape) == (N,) + space.shape and obs[k].dtype == torch.float32, k
        assert benv.single_observation_space[k].contains(obs[k][0].cpu().numpy()), k
    assert info["sim_time_ms"].shape == (N,) and info["_sim_time_ms"].all()
    spec = gym.spec("BinocularSaccade-v0")
    assert spec.vector_entry_point == "envs.batched_env:BatchedBinocularSaccade"


def test_make_vec_builds_the_batched_env():
    env = gym.make_vec("BinocularSaccade-v0", num_envs=1, vectorization_mode="vector_entry_point", device=DEVICE,
                       image_size=32, fovea_deg=5.0, output="numpy")
    try:
        assert isinstance(env, _Batched)
        obs, _ = env.reset(seed=0)
        assert isinstance(obs["cortical"], np.ndarray) and obs["cortical"].shape[0] == 1
        assert env._max_steps == gym.spec("BinocularSaccade-v0").max_episode_steps == 5  # make_vec passes it
    finally:
        env.close()


def test_max_episode_steps_caps_the_budget_as_a_time_limit():
    """make_vec(..., max_episode_steps=K) reaches the vector entry point: worlds are truncated after
    min(K, max_saccades) steps, as TimeLimit(K) around the single env truncates them (here free viewing,
    budget 20, K = 1); -1 or None leave the budget alone; a bad K is refused."""
    env = gym.make_vec("BinocularSaccade-v0", num_envs=1, vectorization_mode="vector_entry_point", device=DEVICE,
                       image_size=32, fovea_deg=5.0, output="numpy", task="free", scene="bar", max_episode_steps=1)
    try:
        env.reset(seed=0)
        _, _, te, tr, _ = env.step(ACTIONS[0][:1])
        assert tr.all() and not te.any()
    finally:
        env.close()
    for bad in (0, -2, 2.5, "5"):
        with pytest.raises(ValueError, match="max_episode_steps"):  # (checks' TypeError is a ValueError too)
            BatchedBinocularSaccade(1, device=DEVICE, image_size=32, max_episode_steps=bad)


def test_max_episode_steps_default_is_the_budget(benv):
    assert benv._max_steps == benv.task.max_saccades == 2  # built directly: no TimeLimit, the budget decides


def test_pickle_and_copy_refuse_clearly(benv):
    """pickle and copy raise a TypeError saying what to do, before any half-built copy exists: nothing
    reaches sys.unraisablehook (where a Renderer.__del__ traceback would go)."""
    import copy
    import gc
    import pickle
    import sys

    unraisable = []
    old, sys.unraisablehook = sys.unraisablehook, unraisable.append
    try:
        benv.reset(seed=0)
        for f in (pickle.dumps, copy.deepcopy, copy.copy):
            with pytest.raises(TypeError, match="BatchedBinocularSaccade cannot be pickled or copied.*make_vec"):
                f(benv)
        gc.collect()
    finally:
        sys.unraisablehook = old
    assert not unraisable, [u.exc_value for u in unraisable]


@pytest.mark.parametrize("eye_drive", ["plant", "servo"])
def test_agrees_with_the_single_env(benv, eye_drive):
    """Same seeds and actions: the batched worlds' rewards, terminations and info agree with
    ``BinocularSaccadeEnv``; observations within the tolerances measured here (2 worlds, 2 saccades,
    64 px dots scene). Why not zero: MJWarp's renderer vs the classic EGL one (on this dark screen
    the two differ by one grey level, 1/255, over much of the picture), float32 pooling/DPFT/remapping
    vs float64, and the physics at 1 ms in float32. The servo lands both engines' eyes within 1e-6 deg
    (measured <= 4e-7); the orbital plant is the physics' own answer at each engine's timestep (the
    batched physics steps 1 ms, the CPU head 0.25 ms during saccades), measured within 0.006 deg of
    each other (eye angles; target and landing errors within 0.0051 deg): tolerance 0.01 deg.

    Measured: cortical, remapped and fovea differ by 0.0014-0.0034 on average, 0.0039-0.0047 at most.
    ``remap_error`` is normalised by the RMS contrast of the actual samples, which on this nearly
    uniform screen at 64 px is ~0.01: that one grey level moves it by up to 0.13 (1.10 vs 1.21); the
    bar scene below, with real contrast, pins the remapping errors to 0.005."""
    seed = 11
    if eye_drive != "plant":  # the fixture is the default (the plant)
        benv = BatchedBinocularSaccade(N, device=DEVICE, image_size=SIZE, task_kwargs={"max_saccades": 2},
                                       eye_drive=eye_drive)
    tol_deg = 0.01 if eye_drive == "plant" else 1e-3
    obs, info = benv.reset(seed=seed)
    batched = [(_np(obs), np.zeros(N), np.zeros(N, bool), np.zeros(N, bool), info)]
    for a in ACTIONS:
        o, r, te, tr, inf = benv.step(a)
        batched.append((_np(o), r, te, tr, inf))
    for w in range(N):
        cpu = _cpu_run(seed, ACTIONS, w, eye_drive=eye_drive)
        for t, ((co, cr, cte, ctr, ci), (bo, br, bte, btr, bi)) in enumerate(zip(cpu, batched)):
            assert set(co) == set(bo)
            for k in co:
                diff = np.abs(co[k] - bo[k][w])
                assert diff.mean() < 0.005, (t, k, diff.mean())
                assert diff.max() < 0.01, (t, k, diff.max())
            np.testing.assert_array_equal(co["eyes"], bo["eyes"][w])  # host: the same efference copy
            if t == 0:
                continue
            assert math.isclose(cr, br[w], abs_tol=1e-4), (t, cr, br[w])
            assert (cte, ctr) == (bte[w], btr[w])
            for key in ("saccade_amplitude_deg", "saccade_duration_ms", "peak_velocity_deg_s", "target_error_deg",
                        "landing_error_deg"):
                assert math.isclose(ci[key], bi[key][w], abs_tol=tol_deg), (t, key, ci[key], bi[key][w])
            np.testing.assert_allclose(ci["efference_copy"], bi["efference_copy"][w], atol=1e-12)
            np.testing.assert_allclose(ci["eye_angles"], bi["eye_angles"][w], atol=1e-6 if eye_drive == "servo"
                                       else math.radians(tol_deg))
            assert ci["sim_time_ms"] == bi["sim_time_ms"][w]
            assert ci["clipped"] == bi["clipped"][w] and ci["success"] == bi["success"][w]
            for m, e in ci["remap_error"].items():
                assert abs(e - bi["remap_error"][m][w]) < 0.2, (t, m, e, bi["remap_error"][m][w])
            # the reward's components: the same reward_* keys, values and sum
            parts = [k for k in ci if k.startswith("reward_")]
            assert parts == [k for k in bi if k.startswith("reward_")] == ["reward_target", "reward_saccade"]
            for key in parts:
                assert bi["_" + key][w] and math.isclose(ci[key], bi[key][w], abs_tol=1e-4), (t, key)
            assert math.isclose(sum(bi[k][w] for k in parts), br[w], abs_tol=1e-12)
    if eye_drive != "plant":
        benv.close()


def test_remapping_errors_agree_on_a_contrasted_scene():
    """The bar scene (untextured, high contrast; task free): observations within 0.0039 (one grey
    level) everywhere and the remapping errors of all three models within 0.005 of the single env's
    (measured: 0.0002-0.0023 mean, <= 0.0053 max for the observations; errors within 0.002)."""
    env = BatchedBinocularSaccade(N, device=DEVICE, image_size=SIZE, task="free", scene="bar", output="numpy")
    try:
        env.reset(seed=11)
        steps = [env.step(a) for a in ACTIONS]
    finally:
        env.close()
    for w in range(N):
        single = BinocularSaccadeEnv(image_size=SIZE, task="free", scene="bar")
        single.reset(seed=11 + w)
        for a, (bo, _, _, _, bi) in zip(ACTIONS, steps):
            so, _, _, _, si = single.step(a[w])
            for k in ("cortical", "remapped", "fovea"):
                diff = np.abs(so[k] - bo[k][w])
                assert diff.mean() < 0.004 and diff.max() < 0.008, (k, diff.mean(), diff.max())
            for m, e in si["remap_error"].items():
                assert abs(e - bi["remap_error"][m][w]) < 0.005, (m, e, bi["remap_error"][m][w])
        single.close()


def test_textures_are_sampled_alike_by_both_renderers():
    """The natural scene's 1/f textures seen from afar: MuJoCo's GL renderer samples them as MJWarp's
    ray tracer does (full resolution, bilinear: ``models.render._sample_textures_bilinear``), so the two
    pictures at the scene's default fixation differ by about one grey level on average (measured
    0.0028 at 64 px; 0.0149 with GL's trilinear mipmaps, which blur the far backdrop)."""
    import models
    from envs.batched_physics import WarpHeads

    head = models.Head("natural", SIZE, seed=0)
    head.reset(seed=11)
    ref = head.render()
    gl = np.stack([ref.left.image, ref.right.image]).astype(float) / 255
    warp = WarpHeads(head, 1, DEVICE)
    d = head.data
    warp.load(np.arange(1), d.qpos[None], d.qvel[None], d.ctrl[None], d.mocap_pos[None], d.mocap_quat[None])
    diff = np.abs(warp.render()[0].cpu().numpy() - gl)
    head.close()
    assert diff.mean() < 0.006, diff.mean()


@pytest.mark.parametrize("scene, task, typical, worst", [("search", "search", 0.004, 0.006),
                                                         ("natural", "free", 0.004, 0.06)])
def test_every_scene_looks_alike_on_both_engines(scene, task, typical, worst):
    """The other scenes (dots and bar: the tests above), three saccades of two worlds: the fovea's mean
    difference per step between the engines. search (untextured spheres and cubes): at most one grey
    level (measured <= 0.0025). natural: typically one grey level (measured median 0.0021), but up to
    0.04 where the fovea lands on a box's face -- MJWarp maps a texture onto each face of a box while
    MuJoCo's GL renderer projects it (a difference of texture *mapping* between the renderers, left as it
    is); cortical maps within 0.01 on average everywhere."""
    actions = ACTIONS + [np.array([[0.1, -0.3], [0.3, 0.1]], np.float32)]
    kw = dict(image_size=SIZE, task=task, scene=scene)
    env = BatchedBinocularSaccade(N, device=DEVICE, output="numpy", **kw)
    try:
        obs, _ = env.reset(seed=11)
        steps = [obs] + [env.step(a)[0] for a in actions]
    finally:
        env.close()
    fovea = []
    for w in range(N):
        single = BinocularSaccadeEnv(**kw)
        so, _ = single.reset(seed=11 + w)
        for t, bo in enumerate(steps):
            if t:
                so = single.step(actions[t - 1][w])[0]
            fovea.append(np.abs(so["fovea"] - bo["fovea"][w]).mean())
            assert np.abs(so["cortical"] - bo["cortical"][w]).mean() < 0.01, (w, t)
        single.close()
    assert np.median(fovea) < typical and max(fovea) < worst, fovea


def test_deterministic_under_a_seed(benv):
    runs = []
    for _ in range(2):
        obs, _ = benv.reset(seed=5)
        o, r, *_ = benv.step(ACTIONS[0])
        runs.append((_np(obs), _np(o), r))
    for a, b in zip(runs[0][:2], runs[1][:2]):
        for k in a:
            np.testing.assert_array_equal(a[k], b[k])
    np.testing.assert_array_equal(runs[0][2], runs[1][2])


def test_autoreset_next_step(benv):
    """max_saccades=2: both worlds are truncated (or terminated) by the second step; the third step
    resets them (gymnasium's NEXT_STEP): reward 0, no termination, and the observation of the single
    env's next ``reset()`` (its rng continues)."""
    seed = 21
    benv.reset(seed=seed)
    for a in ACTIONS:
        _, _, te, tr, _ = benv.step(a)
    assert np.all(te | tr)
    obs, r, te, tr, info = benv.step(ACTIONS[0])
    np.testing.assert_array_equal(r, 0.0)
    assert not te.any() and not tr.any()
    assert not info["_saccade_amplitude_deg"].any() and info["_sim_time_ms"].all()
    obs = _np(obs)
    for w in range(N):
        env = BinocularSaccadeEnv(image_size=SIZE, task_kwargs={"max_saccades": 2})
        env.reset(seed=seed + w)
        for a in ACTIONS:
            env.step(a[w])
        o, _ = env.reset()
        env.close()
        assert np.abs(o["cortical"] - obs["cortical"][w]).mean() < 0.005
        np.testing.assert_array_equal(obs["cortical"][w], obs["remapped"][w])  # at reset: remapped = cortical
    o2, r2, *_ = benv.step(ACTIONS[1])  # and the worlds go on stepping
    assert np.all(r2 != 0)


@pytest.mark.parametrize("actions, error", [
    (np.array([[np.nan, 0.0], [0.0, 0.0]]), "NaN"),
    (np.array([[1.5, 0.0], [0.0, 0.0]]), r"\[-1, 1\]"),
    (np.zeros((3, 2)), "shape"),
    (np.zeros(2), "shape"),
    (np.array([["a", "b"], ["c", "d"]]), "real numbers"),
])
def test_bad_actions(benv, actions, error):
    benv.reset(seed=0)
    with pytest.raises((ValueError, TypeError), match=error):
        benv.step(actions)


def test_step_before_reset_and_bad_arguments():
    with pytest.raises(ValueError, match="num_envs"):
        BatchedBinocularSaccade(0, device="cpu")
    with pytest.raises(ValueError, match="device"):
        BatchedBinocularSaccade(1, device="tpu")
    if not torch.cuda.is_available():
        with pytest.raises(RuntimeError, match="no CUDA"):
            BatchedBinocularSaccade(1, device="cuda")
    with pytest.raises(ValueError, match="pooled_remap"):
        BatchedBinocularSaccade(1, device="cpu", pooled_remap=True)
    with pytest.raises(ValueError, match="render_mode"):
        BatchedBinocularSaccade(1, device="cpu", render_mode="rgb_array")
    with pytest.raises(ValueError, match="image_size"):
        BatchedBinocularSaccade(1, device="cpu", image_size=8)
    with pytest.raises(ValueError, match="output"):
        BatchedBinocularSaccade(1, device="cpu", output="jax")
    for name in ("linear_tail", "fused_physics"):
        with pytest.raises((TypeError, ValueError), match=name):
            BatchedBinocularSaccade(1, device="cpu", **{name: "yes"})
    env = BatchedBinocularSaccade(1, device="cpu", image_size=32, fovea_deg=5.0)
    with pytest.raises(RuntimeError, match="reset"):
        env.step(np.zeros((1, 2)))
    with pytest.raises(ValueError, match="seed"):
        env.reset(seed=[1, 2])
    env.close()


def test_search_and_cell_actions():
    """The search task (its layout drawn per world) and the cell action mode against the single env."""
    env = BatchedBinocularSaccade(N, device=DEVICE, task="search", action_mode="cell", image_size=SIZE, output="numpy")
    try:
        obs, _ = env.reset(seed=2)
        cells = np.array([5, 40])
        o, r, te, tr, info = env.step(cells)
        for w in range(N):
            single = BinocularSaccadeEnv(task="search", action_mode="cell", image_size=SIZE)
            so, _ = single.reset(seed=2 + w)
            so2, sr, ste, _, si = single.step(int(cells[w]))
            single.close()
            assert np.abs(so["cortical"] - obs["cortical"][w]).mean() < 0.005
            assert np.abs(so2["cortical"] - o["cortical"][w]).mean() < 0.005
            assert math.isclose(sr, r[w], abs_tol=1e-6) and ste == te[w]
            assert math.isclose(si["target_error_deg"], info["target_error_deg"][w], abs_tol=1e-3)
            for key in ("reward_target", "reward_saccade"):  # the search task's reward components
                assert si[key] == info[key][w] and info["_" + key][w], key
        with pytest.raises(TypeError, match="integer"):
            env.step(np.array([0.5, 1.0]))
        with pytest.raises(ValueError, match="world 1"):
            env.step(np.array([0, 10**6]))
    finally:
        env.close()


def test_same_step_autoreset():
    """autoreset_mode="same_step": the step that ends an episode returns the next episode's first
    observation (the single env's next reset()) and the ended one's in info["final_obs"]."""
    env = BatchedBinocularSaccade(N, device=DEVICE, image_size=SIZE, task_kwargs={"max_saccades": 1},
                                  autoreset_mode="same_step", output="numpy")
    try:
        assert env.metadata["autoreset_mode"] is gym.vector.AutoresetMode.SAME_STEP
        env.reset(seed=4)
        obs, r, te, tr, info = env.step(ACTIONS[0])
    finally:
        env.close()
    assert np.all(te | tr) and info["_final_obs"].all()
    for w in range(N):
        single = BinocularSaccadeEnv(image_size=SIZE, task_kwargs={"max_saccades": 1})
        single.reset(seed=4 + w)
        last, sr, *_ = single.step(ACTIONS[0][w])
        first, _ = single.reset()
        single.close()
        assert math.isclose(sr, r[w], abs_tol=1e-4)
        assert np.abs(last["cortical"] - info["final_obs"]["cortical"][w]).max() < 0.01
        assert np.abs(first["cortical"] - obs["cortical"][w]).max() < 0.01
        np.testing.assert_array_equal(obs["cortical"][w], obs["remapped"][w])  # a first observation
        assert info["final_info"]["success"][w] == (te[w])
        fi = info["final_info"]  # the ended step's reward components, in final_info as the rest of its info
        assert fi["_reward_target"][w] and math.isclose(fi["reward_target"][w] + fi["reward_saccade"][w], r[w])


def test_retina_rays_observations():
    """retina_rays=s: the retina rendered along its fields' rays; the observations keep their spaces and
    stay close to the pooled pinhole picture's (bar scene; measured mean |difference| ~0.01)."""
    kw = dict(image_size=SIZE, task="free", scene="bar")
    native = BatchedBinocularSaccade(1, device=DEVICE, retina_rays=3, output="numpy", **kw)
    pinhole = BatchedBinocularSaccade(1, device=DEVICE, output="numpy", **kw)
    try:
        a, _ = native.reset(seed=0)
        b, _ = pinhole.reset(seed=0)
        for k, space in native.single_observation_space.spaces.items():
            assert space.contains(a[k][0]), k
        assert np.abs(a["cortical"] - b["cortical"]).mean() < 0.03
        a2, *_ = native.step(ACTIONS[0][:1])
        b2, *_ = pinhole.step(ACTIONS[0][:1])
        assert np.abs(a2["remapped"] - b2["remapped"]).mean() < 0.03
    finally:
        native.close()
        pinhole.close()
    with pytest.raises(ValueError, match="retina_rays"):
        BatchedBinocularSaccade(1, device=DEVICE, retina_rays=9)


def test_skrl_recipe(tmp_path):
    """The PPO recipe (experiments/agents/skrl_recipe.py) trains two updates on 2 worlds and writes its curve,
    checkpoint and summary; its CLI refuses a run shorter than one rollout."""
    pytest.importorskip("skrl")
    import csv
    import json

    from experiments.agents import skrl_recipe

    out = tmp_path / "ppo"
    assert skrl_recipe.main(["--out", str(out), "--device", DEVICE, "--num-envs", "2", "--timesteps", "4",
                             "--rollouts", "2", "--image-size", "32", "--hidden", "32"]) == 0
    summary = json.loads((out / "ppo.json").read_text())
    assert summary["env_steps"] == 8 and torch.device(summary["device"]).type == torch.device(DEVICE).type
    with open(out / "learning_curve.csv") as f:
        assert next(csv.reader(f)) == ["env_steps", "episodes", "mean_return", "success_rate"]
    assert (out / "agent.npz").stat().st_size > 0 and (out / "learning_curve.png").stat().st_size > 0
    with pytest.raises(SystemExit):
        skrl_recipe.main(["--out", str(tmp_path / "x"), "--timesteps", "2", "--rollouts", "4"])


@pytest.mark.parametrize("kwargs", [
    {"grayscale": True, "cortex": "hemispheres", "include_coeffs": True},
    {"vergence": True, "remap_model": "shift", "shift_rings": 1.5, "remap_models": ("shift",)},
    {"endpoint_noise": 0.1, "remap_model": "mobius", "fixation_ms": 0},
    {"motor_noise": models.HUMAN_MOTOR_NOISE, "vergence": True, "fixation_ms": 0},  # anisotropic, undershoot
])
def test_options_agree_with_the_single_env(kwargs):
    """Observation layouts (grayscale, hemispheres, coefficients), vergence actions, the shift model,
    endpoint noise (drawn on the host from each world's own generator) and no fixation, against
    ``BinocularSaccadeEnv`` after one saccade of each of 2 worlds (bar scene, task free)."""
    dims = 3 if kwargs.get("vergence") else 2
    action = np.array([[0.4, 0.1, 0.5], [-0.3, 0.2, -0.4]], np.float32)[:, :dims]
    env = BatchedBinocularSaccade(N, device=DEVICE, image_size=SIZE, task="free", scene="bar", output="numpy", **kwargs)
    try:
        b0, _ = env.reset(seed=7)
        b1, _, _, _, bi = env.step(action)
        assert env.single_observation_space == BinocularSaccadeEnv(image_size=SIZE, task="free", scene="bar",
                                                                   **kwargs).observation_space
    finally:
        env.close()
    for w in range(N):
        single = BinocularSaccadeEnv(image_size=SIZE, task="free", scene="bar", **kwargs)
        s0, _ = single.reset(seed=7 + w)
        s1, _, _, _, si = single.step(action[w])
        single.close()
        for k in s1:
            # the renderers may disagree on a pixel that an edge crosses within rounding of its centre,
            # and the smallest fields are a pixel or two: one sample can then differ by the edge's
            # contrast (measured here once: a right-eye foveal cell off by 0.34, one pixel of the
            # image). So: small on average, and at most 2 cells (or 2 %) off by more than 1/100.
            scale = max(1.0, float(np.abs(s1[k]).max())) if k == "coeffs" else 1.0
            for a, b in ((s0[k], b0[k][w]), (s1[k], b1[k][w])):
                d = np.abs(a - b) / scale
                off = int((d > 0.01).sum())
                assert d.mean() < 0.01 and off <= max(2, 0.02 * d.size), (k, d.mean(), off)
        np.testing.assert_allclose(si["endpoint_error_deg"], bi["endpoint_error_deg"][w], atol=1e-12)
        if {"endpoint_noise", "motor_noise"} & set(kwargs):  # the noise was drawn, not left out by both
            assert np.all(np.asarray(bi["endpoint_error_deg"][w]) > 1e-6)
        np.testing.assert_allclose(si["eye_angles"], bi["eye_angles"][w], atol=1e-6)  # measured <= 8.4e-8 rad
        assert si["sim_time_ms"] == bi["sim_time_ms"][w]
        for m, e in si["remap_error"].items():  # that one flipped pixel moves an error by 0.009
            assert abs(e - bi["remap_error"][m][w]) < 0.02, (m, e, bi["remap_error"][m][w])


def test_device_needs_a_cuda_build_of_torch(monkeypatch):
    """Warp may see a GPU while torch is a CPU-only build: device=None then falls back to the CPU and
    device="cuda" says what to install (not a crash later in a torch call)."""
    import warp as wp

    from envs.batched_env import _resolve_device

    monkeypatch.setattr(wp, "is_cuda_available", lambda: True)
    monkeypatch.setattr(torch.cuda, "is_available", lambda: False)
    assert _resolve_device(None, wp, torch) == "cpu"
    with pytest.raises(RuntimeError, match="CPU-only build"):
        _resolve_device("cuda", wp, torch)
    monkeypatch.setattr(torch.cuda, "is_available", lambda: True)
    assert _resolve_device(None, wp, torch) == "cuda"
    assert _resolve_device("cpu", wp, torch) == "cpu"


def test_same_step_infos_are_masked_and_a_closed_env_refuses():
    """SAME_STEP with a one-saccade budget: every world ends in its first step, so final_info carries the ended episodes' step info under masks and-ed with the ended worlds; the new
    episodes' remap_error is a reset's (zeros). A closed env refuses step and reset."""
    env = BatchedBinocularSaccade(N, device=DEVICE, image_size=32, task="free", scene="bar",
                                  task_kwargs={"max_saccades": 1}, autoreset_mode="same_step", output="numpy")
    env.reset(seed=1)
    obs, r, te, tr, info = env.step(ACTIONS[0])
    done = te | tr
    assert done.all()
    fi = info["final_info"]
    for k in ("saccade_amplitude_deg", "eye_angles", "success"):
        np.testing.assert_array_equal(fi["_" + k], done)
        assert not info.get("_" + k, np.zeros(N, bool)).any()  # no running world had a step info
    assert fi["saccade_amplitude_deg"].min() > 0
    assert "target_error_deg" not in fi  # the free task reports none, as BinocularSaccadeEnv
    assert not [k for k in (*fi, *info) if k.startswith("reward_")]  # nor reward components (reward 0)
    for m in env.remap_models:
        np.testing.assert_array_equal(info["remap_error"][m], 0.0)
    np.testing.assert_array_equal(fi["_remap_error"], done)
    fi["saccade_amplitude_deg"][0] = -1.0  # a copy: the env's own arrays are not shared
    env.close()
    env.close()  # twice is harmless
    assert env.closed
    with pytest.raises(RuntimeError, match="closed"):
        env.step(ACTIONS[0])
    with pytest.raises(RuntimeError, match="closed"):
        env.reset(seed=0)


def test_recipe_reports_truncation_as_termination():
    """The saccade budget is not observed, so the skrl wrapper reports a truncated episode as terminated
    (no bootstrap from the next episode's first observation) and keeps returns on the host."""
    pytest.importorskip("skrl")
    from experiments.agents.skrl_recipe import DeviceVectorWrapper

    env = BatchedBinocularSaccade(N, device=DEVICE, image_size=32, task="fixate", task_kwargs={"max_saccades": 1},
                                  autoreset_mode="same_step")
    try:
        w = DeviceVectorWrapper(env)
        env.reset(seed=3)
        _, r, te, tr, _ = w.step(torch.zeros(N, 2, device=env.device))
        assert te.shape == (N, 1) and te.all() and not tr.any()  # each world's one-saccade budget ran out
        assert len(w.episodes) == N and isinstance(w._returns, np.ndarray)
        np.testing.assert_allclose([e[1] for e in w.episodes], r.view(-1).cpu().numpy(), atol=1e-6)
    finally:
        env.close()


pytestmark = pytest.mark.warp  # needs the gpu extra (Warp, MuJoCo Warp, torch): see the README's "Tests"
