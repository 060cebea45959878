"""RL agents: features, baselines, CEM training improves on random, save/reload/evaluate, CLI."""

from __future__ import annotations

import importlib.util
import json
import os
import subprocess
import sys

import numpy as np
import pytest

from experiments.agents import (BrightestCellPolicy, CEMConfig, LinearCellPolicy, RandomPolicy, cell_features,
                                episode_seeds, evaluate, load_policy, make_env, train_cem)


def _fake_obs(M=4, N=6, cell=(2, 3), colour=(1.0, 1.0, 0.0)):
    c = np.full((2, M, N, 3), 0.1, np.float32)
    c[:, cell[0], cell[1]] = colour
    return {"cortical": c}


def test_features_single_yellow_cell_ground_truth():
    M, N = 4, 6
    phi = cell_features(_fake_obs(M, N))
    assert phi.shape == (M * N, 4 + M)
    idx = 2 * N + 3
    # yellow opponency (R+G)/2 - B: 1.0 in the cell vs 0 elsewhere; minus the ring mean 1/6; x10
    assert phi[idx, 1] == pytest.approx(10 * (1 - 1 / 6), rel=1e-6)
    assert phi[0, 1] == pytest.approx(0.0, abs=1e-6)  # another ring: no contrast
    assert phi[2 * N, 1] == pytest.approx(-10 / 6, rel=1e-6)
    np.testing.assert_array_equal(phi[idx, 4:], np.eye(M)[2])
    w = np.zeros(4 + M)
    w[1] = 1.0
    assert LinearCellPolicy(w).act(_fake_obs(M, N), np.random.default_rng(0)) == idx
    assert BrightestCellPolicy().act(_fake_obs(M, N), np.random.default_rng(0)) == idx


def test_policies_reject_bad_input(tmp_path):
    with pytest.raises(ValueError):
        cell_features({"cortical": np.zeros((2, 4, 6, 1))})
    with pytest.raises(ValueError):
        LinearCellPolicy(np.array([np.nan] * 8))
    with pytest.raises(ValueError):  # 8 weights = 4 rings, observation has 5
        LinearCellPolicy(np.zeros(8)).act(_fake_obs(5, 6), np.random.default_rng(0))
    with pytest.raises(FileNotFoundError):
        load_policy(tmp_path)
    with pytest.raises(ValueError):
        CEMConfig(population=0).validate()


def test_softmax_sampling_follows_logits():
    w = np.zeros(8)
    w[1] = 1.0
    pol = LinearCellPolicy(w, temperature=0.5)
    obs = _fake_obs()
    rng = np.random.default_rng(1)
    acts = np.array([pol.act(obs, rng) for _ in range(4000)])
    z = cell_features(obs) @ w / 0.5
    p = np.exp(z - z.max())
    p /= p.sum()
    assert np.mean(acts == 15) == pytest.approx(p[15], abs=0.03)


def test_episode_seeds_are_deterministic_and_streams_disjoint():
    a, b = episode_seeds(3, 10), episode_seeds(3, 10)
    np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(episode_seeds(3, 5, start=5), a[5:])
    assert not set(a) & set(episode_seeds(3, 10, stream=1))


@pytest.fixture(scope="module")
def trained(tmp_path_factory):
    out = tmp_path_factory.mktemp("policy")
    policy, meta = train_cem(out, config=CEMConfig.quick(), seed=0, progress=False)
    return out, policy, meta


@pytest.mark.slow
def test_short_training_beats_random_by_a_clear_margin(trained):
    out, policy, meta = trained
    env = make_env("fixate")
    try:
        seeds = episode_seeds(11, 24)  # held out: not the training or validation episodes
        g = env.vision.grid
        rand = evaluate(env, RandomPolicy(g.M * g.N), seeds, rng_seed=11)
        agent = evaluate(env, policy, seeds, rng_seed=11)
    finally:
        env.close()
    assert agent.success_rate >= rand.success_rate + 0.4, (agent, rand)
    assert agent.mean_reward > rand.mean_reward + 0.4
    # the log was written incrementally, one row per iteration
    rows = (out / "training_log.csv").read_text().strip().splitlines()
    assert len(rows) == 1 + CEMConfig.quick().iterations
    assert len(meta["curve"]) == CEMConfig.quick().iterations


@pytest.mark.slow
def test_saved_policy_reloads_and_evaluates_identically(trained, capsys):
    out, policy, _ = trained
    loaded = load_policy(out)
    np.testing.assert_array_equal(loaded.weights, policy.weights)
    assert loaded.metadata["env_kwargs"]["image_size"] == 96
    results = []
    for _ in range(2):
        parser = __import__("experiments.__main__", fromlist=["build_parser"]).build_parser()
        args = parser.parse_args(["evaluate", "--task", "fixate", "--policy", str(out), "--episodes", "6", "--seed", "5"])
        assert args.func(args) == 0
        lines = capsys.readouterr().out.strip().splitlines()
        assert len(lines) == 1
        results.append(json.loads(lines[0]))
    assert results[0] == results[1]
    for key in ("success_rate", "mean_reward", "mean_saccades", "episodes", "seed", "policy"):
        assert key in results[0]
    env = make_env("fixate")
    try:
        direct = evaluate(env, policy, episode_seeds(5, 6), rng_seed=5)
    finally:
        env.close()
    assert direct.mean_reward == results[0]["mean_reward"]


@pytest.mark.slow
def test_train_and_evaluate_commands_end_to_end(tmp_path, capsys):
    """``train --quick`` (shrunk further) through the command line writes the policy, the log,
    the baselines (random and brightest-cell heuristic) and the learning curve; ``evaluate``
    runs the heuristic and random policies, and the heuristic beats random."""
    from experiments.__main__ import main

    out = tmp_path / "cem"
    assert main(["train", "--task", "fixate", "--out", str(out), "--quick", "--iterations", "1", "--population", "4",
                 "--episodes", "1", "--eval-episodes", "4", "--no-progress"]) == 0
    line = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert line["iterations"] == 1 and {"random", "heuristic"} <= set(line["baselines"])
    for name in ("policy.npz", "policy.json", "training_log.csv", "baselines.json", "learning_curve.png"):
        assert (out / name).stat().st_size > 0, name
    assert (out / "learning_curve.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    res = {}
    for pol in ("heuristic", "random"):
        assert main(["evaluate", "--task", "fixate", "--policy", pol, "--episodes", "8", "--seed", "2"]) == 0
        res[pol] = json.loads(capsys.readouterr().out.strip())
        assert res[pol]["policy"] == pol and res[pol]["episodes"] == 8
    assert res["heuristic"]["success_rate"] > res["random"]["success_rate"] + 0.4


@pytest.mark.parametrize("command", ["run", "visualize", "train", "evaluate"])
def test_every_command_has_help(command, capsys):
    from experiments.__main__ import main

    with pytest.raises(SystemExit) as e:
        main([command, "--help"])
    assert e.value.code == 0
    text = capsys.readouterr().out
    assert text.startswith("usage:") and "--" in text
    for opt in {"run": ["--out", "--quick"], "visualize": ["--out", "--spawn"], "train": ["--task", "--out", "--quick"],
                "evaluate": ["--task", "--policy", "--episodes", "--seed"]}[command]:
        assert opt in text
    # every option of the command is documented: listed in --help with a help text of its own
    import argparse

    from experiments.__main__ import build_parser

    sub = next(a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction))
    for action in sub.choices[command]._actions:
        if action.option_strings and action.help != argparse.SUPPRESS:
            assert action.help and action.option_strings[-1] in text, action.option_strings


@pytest.mark.slow
def test_cli_bad_options_fail_clearly(tmp_path):
    cmd = [sys.executable, "-m", "experiments", "evaluate", "--policy", str(tmp_path), "--episodes", "1"]
    r = subprocess.run(cmd, capture_output=True, text=True)
    assert r.returncode == 2 and "not a saved policy" in r.stderr
    r = subprocess.run([sys.executable, "-m", "experiments", "evaluate", "--policy", "random", "--episodes", "0"],
                       capture_output=True, text=True)
    assert r.returncode == 2 and "--episodes: expected a whole number in [1," in r.stderr


# -- hostile command-line input: every numeric and path option of train / evaluate / the SB3 recipe --------
_BAD_INTS = ["nan", "inf", "-inf", "-1", "2.5", "1e12", "1e300", "abc", "", "0x10"]
_INT_OPTIONS = [("train", "--seed"), ("train", "--iterations"), ("train", "--population"), ("train", "--episodes"),
                ("train", "--eval-episodes"), ("train", "--image-size"), ("evaluate", "--episodes"),
                ("evaluate", "--seed"), ("evaluate", "--image-size")]


def _argv(command: str, option: str, value: str, out) -> list[str]:
    base = {"train": ["train", "--out", str(out), "--quick"], "evaluate": ["evaluate", "--policy", "random"]}[command]
    return base + [f"{option}={value}"]


def _usage_error(argv: list[str], capsys, main) -> str:
    with pytest.raises(SystemExit) as e:
        main(argv)
    assert e.value.code == 2, argv
    err = capsys.readouterr().err.strip().splitlines()
    assert err, argv
    return err[-1]


@pytest.mark.adversarial
@pytest.mark.parametrize("value", _BAD_INTS)
@pytest.mark.parametrize("command,option", _INT_OPTIONS)
def test_cli_rejects_bad_integers(command, option, value, tmp_path, capsys):
    from experiments.__main__ import main

    last = _usage_error(_argv(command, option, value, tmp_path / "o"), capsys, main)
    assert f"argument {option}" in last, last
    assert not (tmp_path / "o").exists()  # refused before anything was written


@pytest.mark.adversarial
@pytest.mark.parametrize("value,why", [("", "empty"), ("{file}", "not a folder"), ("{file}/sub", "is a file"),
                                       ("/proc/version/x", "is a file")])
def test_train_rejects_bad_out(value, why, tmp_path, capsys):
    from experiments.__main__ import main

    f = tmp_path / "afile"
    f.write_text("x")
    last = _usage_error(["train", "--out", value.format(file=f), "--quick"], capsys, main)
    assert "argument --out" in last and why in last, last


def _corrupt_policies(tmp_path):
    good = {"kind": "linear-cell", "feature_set": "contrast-v1", "task": "fixate", "env_kwargs": {"image_size": 96}}
    cases = {
        "empty folder": ({}, "not a saved policy"),
        "torn json": ({"policy.json": "{", "policy.npz": b""}, "not valid JSON"),
        "json list": ({"policy.json": "[1]", "policy.npz": b""}, "JSON object"),
        "wrong kind": ({"policy.json": json.dumps({**good, "kind": "x"}), "policy.npz": b""}, "unsupported"),
        "empty npz": ({"policy.json": json.dumps(good), "policy.npz": b""}, "could not be read"),
        "not a zip": ({"policy.json": json.dumps(good), "policy.npz": b"PK\x03\x04garbage"}, "could not be read"),
        "torn ppo.json": ({"ppo.json": "{"}, "not a valid PPO metadata"),
        "ppo without weights": ({"ppo.json": json.dumps({"format": "sb3-npz-1", "task": "fixate", "env_kwargs": {}})},
                                "missing ppo.npz"),
        "old sb3 zip": ({"ppo.json": json.dumps({"task": "fixate", "env_kwargs": {}}), "ppo_fixate.zip": b"PK"},
                        "never loaded"),
        "two kinds": ({"policy.json": json.dumps(good), "sac.json": "{}"}, "not one training run"),
    }
    out = []
    for name, (files, msg) in cases.items():
        d = tmp_path / name.replace(" ", "_")
        d.mkdir()
        for fn, content in files.items():
            (d / fn).write_bytes(content if isinstance(content, bytes) else content.encode())
        out.append((d, msg))
    return out


@pytest.mark.adversarial
@pytest.mark.parametrize("case", range(10))
def test_evaluate_rejects_corrupt_policy_folders(case, tmp_path, capsys):
    from experiments.__main__ import main

    d, msg = _corrupt_policies(tmp_path)[case]
    if "ppo" in d.name or "sb3" in d.name:  # an SB3 folder is read only with the rl extra (else: one line saying so)
        pytest.importorskip("stable_baselines3", reason="the SB3 folder cases need the rl extra")
    assert main(["evaluate", "--policy", str(d), "--episodes", "1"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("evaluate: error:") and msg in err and len(err.splitlines()) == 1, err


@pytest.mark.adversarial
@pytest.mark.parametrize("value", ["nan", "0", "-3", "2.5", "1e12", "abc"])
@pytest.mark.parametrize("option", ["--timesteps", "--n-envs", "--n-steps", "--eval-episodes", "--seed"])
def test_sb3_recipe_rejects_bad_options(option, value, tmp_path, capsys):
    from experiments.agents import sb3_recipe

    if option == "--seed" and value == "0":
        pytest.skip("0 is a valid seed")
    with pytest.raises(SystemExit) as e:
        sb3_recipe.main(["--out", str(tmp_path / "o"), f"{option}={value}"])
    assert e.value.code == 2
    assert f"argument {option}" in capsys.readouterr().err.strip().splitlines()[-1]


@pytest.mark.slow
@pytest.mark.skipif(importlib.util.find_spec("stable_baselines3") is None,
                    reason="needs the optional 'rl' extra (stable-baselines3 + CPU torch)")
def test_sb3_recipe_runs(tmp_path, monkeypatch):
    import tempfile

    from experiments.agents import sb3_recipe

    scratch = tmp_path / "tmpdir"
    scratch.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(scratch))
    path = sb3_recipe.train_ppo(tmp_path, total_timesteps=64, n_envs=2, n_steps=32, vec="dummy", seed=0)
    assert not list(scratch.glob("SB3-*"))  # no SB3 logger folder left behind
    assert path.exists() and (tmp_path / "ppo.json").exists()
    res = sb3_recipe.evaluate_ppo(path, episodes=2, seed=0)
    assert 0.0 <= res["success_rate"] <= 1.0 and res["episodes"] == 2


@pytest.mark.slow
@pytest.mark.skipif(importlib.util.find_spec("stable_baselines3") is None,
                    reason="needs the optional 'rl' extra (stable-baselines3 + CPU torch)")
def test_sb3_recipe_prints_progress_and_evaluate_loads_it(tmp_path):
    """The recipe's command prints a line per rollout and its result; ``python -m experiments
    evaluate --policy DIR`` loads what it saved and, on the same episodes, reports the same numbers."""
    out = tmp_path / "ppo"
    r = subprocess.run([sys.executable, "-m", "experiments.agents.sb3_recipe", "--out", str(out), "--timesteps", "64",
                        "--n-envs", "1", "--n-steps", "32", "--vec", "dummy", "--eval-episodes", "3", "--seed", "4"],
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr[-2000:]
    progress = [ln for ln in r.stderr.splitlines() if ln.startswith("ppo: ")]
    assert [ln.split()[1] for ln in progress] == ["32/64", "64/64"], r.stderr
    recipe = json.loads(r.stdout.strip().splitlines()[-1])
    e = subprocess.run([sys.executable, "-m", "experiments", "evaluate", "--task", "fixate", "--policy", str(out),
                        "--episodes", "3", "--seed", "4"], capture_output=True, text=True, timeout=300)
    assert e.returncode == 0, e.stderr[-2000:]
    ev = json.loads(e.stdout.strip())
    for k in ("success_rate", "mean_reward", "mean_saccades", "episodes"):
        assert ev[k] == recipe[k], k
    # a folder from the recipe evaluated on the wrong task is refused
    e = subprocess.run([sys.executable, "-m", "experiments", "evaluate", "--task", "search", "--policy", str(out),
                        "--episodes", "1"], capture_output=True, text=True, timeout=300)
    assert e.returncode == 2 and "trained on task 'fixate'" in e.stderr


# -- issue 26: shaping, wrappers, the wrap-around cortical convolution, IQM/bootstrap, PPO/SAC recipes -------
def _small_env(**kw):
    import envs

    return envs.BinocularSaccadeEnv(image_size=32, fixation_ms=10, remap_models=("homography",), **kw)


@pytest.mark.slow
@pytest.mark.parametrize("tolerance", [2.0, 45.0])
def test_potential_shaping_telescopes(tolerance):
    """Sum_t gamma^t r'_t = sum_t gamma^t r_t + gamma^T Phi(s_T) - Phi(s_0), with Phi(s_T) = 0 on a
    termination (Ng et al. 1999); the task's reward and success are unchanged. tolerance 2 deg:
    random saccades truncate after 5; 45 deg: the first saccade terminates."""
    import envs

    gamma = 0.9
    env = envs.PotentialShaping(_small_env(task_kwargs={"tolerance_deg": tolerance}), gamma=gamma, scale_deg=10.0)
    try:
        env.reset(seed=3)
        phi0 = env.potential()
        assert phi0 < 0
        rng = np.random.default_rng(0)
        shaped = unshaped = 0.0
        t, done = 0, False
        while not done:
            _, r, term, trunc, info = env.step(rng.uniform(-1, 1, 2).astype(np.float32))
            assert r == pytest.approx(info["reward_task"] + info["reward_shaping"])
            assert info["reward_task"] == pytest.approx(info["reward_target"] + info["reward_saccade"])
            shaped += gamma ** t * r
            unshaped += gamma ** t * info["reward_task"]
            t += 1
            done = term or trunc
        phi_T = 0.0 if term else -info["target_error_deg"] / 10.0
        assert term == (tolerance == 45.0) and t == (1 if term else 5)
        assert shaped == pytest.approx(unshaped + gamma ** t * phi_T - phi0, abs=1e-9)
    finally:
        env.close()


def test_potential_shaping_rejects_bad_arguments():
    import envs

    env = _small_env()
    try:
        for kw, msg in (({"gamma": 0.0}, "gamma"), ({"gamma": float("nan")}, "gamma"), ({"scale_deg": -1.0}, "scale_deg")):
            with pytest.raises(ValueError, match=msg):
                envs.PotentialShaping(env, **kw)
        with pytest.raises(RuntimeError, match="reset"):
            envs.PotentialShaping(env).step(np.zeros(2, np.float32))
    finally:
        env.close()
    with pytest.raises(TypeError, match="env"):
        envs.PotentialShaping(object())
    free = _small_env(task="free", scene="dots")
    try:
        with pytest.raises(ValueError, match="free"):
            envs.PotentialShaping(free)
    finally:
        free.close()


@pytest.mark.slow
def test_gymnasium_wrappers_compose_with_shaping():
    """gymnasium.make (TimeLimit) + PotentialShaping + FilterObservation + FlattenObservation +
    NormalizeObservation + FrameStackObservation: one truncation at the budget, shapes as stacked."""
    import gymnasium as gym
    from gymnasium.wrappers import (FilterObservation, FlattenObservation, FrameStackObservation,
                                    NormalizeObservation)

    import envs

    env = gym.make("BinocularSaccade-v0", image_size=32, fixation_ms=10, remap_models=("homography",))
    env = FrameStackObservation(NormalizeObservation(FlattenObservation(FilterObservation(
        envs.PotentialShaping(env, gamma=0.95), ["cortical", "eyes"]))), 2)
    try:
        obs, _ = env.reset(seed=1)
        d = env.observation_space.shape
        assert obs.shape == d and d[0] == 2 and np.all(np.isfinite(obs))
        steps, trunc, term = 0, False, False
        while not (trunc or term):
            obs, r, term, trunc, info = env.step(np.array([0.01, 0.0], np.float32))
            steps += 1
            assert "reward_shaping" in info and obs.shape == d
        assert trunc and steps == 5
    finally:
        env.close()


@pytest.mark.slow
def test_wrap_conv_is_equivariant_to_sector_rolls_and_wraps():
    import torch

    from experiments.agents.extractors import CorticalEncoder, WrapConv2d

    torch.manual_seed(0)
    conv = WrapConv2d(3, 4, 3)
    x = torch.rand(2, 3, 5, 9)
    for s in (1, 4, -2):
        torch.testing.assert_close(conv(torch.roll(x, s, dims=3)), torch.roll(conv(x), s, dims=3))
    # it wraps: an impulse in sector 0 reaches sector N-1 (a zero-padded conv would not see it there)
    imp = torch.zeros(1, 3, 5, 9)
    imp[0, :, 2, 0] = 1.0
    bias = conv.conv.bias.view(1, -1, 1, 1)
    resp = (conv(imp) - bias).abs().sum(dim=(0, 1))
    assert resp[2, 8] > 0 and resp[2, 1] > 0 and resp[2, 4] == 0
    assert resp[0, 0] == 0  # rings do not wrap
    with pytest.raises(ValueError, match="kernel_size"):
        WrapConv2d(3, 4, 2)
    # the whole encoder (raw + ring-contrast input, convolutions, logit map) is equivariant too
    enc = CorticalEncoder((2, 5, 9, 3), (2, 7, 3), 6, (8, 8))
    obs = {"cortical": torch.rand(3, 2, 5, 9, 3), "fovea": torch.rand(3, 2, 7, 3), "eyes": torch.rand(3, 2, 3)}
    logits, glob = enc(obs)
    rolled = {**obs, "cortical": torch.roll(obs["cortical"], 3, dims=3)}
    l2, g2 = enc(rolled)
    torch.testing.assert_close(l2.view(3, 5, 9), torch.roll(logits.view(3, 5, 9), 3, dims=2))
    torch.testing.assert_close(g2, glob)  # pooled features: invariant


def test_soft_argmax_saccade_reaches_the_cell():
    torch = pytest.importorskip("torch", reason="needs the rl extra")

    from experiments.agents.extractors import SoftArgmaxSaccade, cell_saccade_vectors

    pts = np.array([[0.3 + 0j, 0.5j], [-0.2 + 0.1j, 3.0 + 0j]])
    v = cell_saccade_vectors(pts, np.radians(30))
    assert v.shape == (4, 2) and np.abs(v).max() <= 1.0
    np.testing.assert_allclose(v[0], [np.arctan(0.3) / np.radians(30), 0.0], rtol=1e-6)
    assert v[3, 0] == 1.0  # arctan(3) = 71.6 deg: clipped to the action range
    logits = torch.full((1, 4), -50.0)
    logits[0, 2] = 50.0
    torch.testing.assert_close(SoftArgmaxSaccade(v)(logits)[0], torch.as_tensor(v[2]))
    torch.testing.assert_close(SoftArgmaxSaccade(v, atanh=True)(logits)[0], torch.atanh(torch.as_tensor(v[2])))
    torch.testing.assert_close(SoftArgmaxSaccade(v)(torch.zeros(1, 4))[0], torch.as_tensor(v.mean(axis=0)))


@pytest.mark.slow
def test_iqm_and_bootstrap_match_a_direct_computation():
    from experiments.agents.stats import bootstrap_ci, iqm, summarize_runs

    x = np.array([0.9, 0.1, 0.5, 0.7, 0.3, 0.8, 0.2, 0.6])
    assert iqm(x) == pytest.approx(np.mean(np.sort(x)[2:6]))  # the middle 50 %
    assert iqm([0.2, 0.4, 0.9]) == pytest.approx(0.5)  # 3 runs: nothing trimmed
    lo, hi = bootstrap_ci(x, iqm, reps=500, seed=7)
    rng = np.random.default_rng(7)
    idx = rng.integers(0, x.size, size=(500, x.size))
    direct = np.quantile([np.mean(np.sort(x[i])[2:6]) for i in idx], [0.025, 0.975])
    assert (lo, hi) == pytest.approx(tuple(direct))
    assert lo <= iqm(x) <= hi
    assert bootstrap_ci([0.7, 0.7, 0.7]) == pytest.approx((0.7, 0.7))
    s = summarize_runs([0.8, 0.9, 1.0], reps=200)
    assert s["runs"] == 3 and s["iqm"] == pytest.approx(0.9) and s["ci_low"] <= 0.9 <= s["ci_high"]
    for bad in ([], [np.nan, 1.0]):
        with pytest.raises(ValueError, match="scores"):
            iqm(bad)
    with pytest.raises(ValueError, match="confidence"):
        bootstrap_ci(x, confidence=1.5)
    # iqm's all-resamples-at-once path gives the bits of the resample-by-resample one (any other statistic's)
    rng = np.random.default_rng(3)
    for n in (1, 2, 3, 5, 8, 13, 40):
        for v in (rng.random(n), rng.integers(0, 4, n) / 3.0):
            assert bootstrap_ci(v, iqm, reps=300, seed=n) == bootstrap_ci(v, lambda r: iqm(r), reps=300, seed=n)


def test_hyperparameter_files_hold_every_task():
    from experiments.agents.hyperparams import load_hyperparams

    for algo in ("ppo", "sac"):
        for task in ("fixate", "search"):
            hp = load_hyperparams(algo, task)
            assert hp["n_timesteps"] > 0 and hp["policy"].startswith("cortical")
            # the Box saccade, but PPO's search reads its cell off the map (README ablation)
            want = "cell" if (algo, task) == ("ppo", "search") else "vector"
            assert hp["env_kwargs"]["action_mode"] == want
            assert hp["shaping"]["enabled"] is True
    with pytest.raises(ValueError, match="no entry for task"):
        load_hyperparams("ppo", "dance")
    with pytest.raises(FileNotFoundError, match="algo"):
        load_hyperparams("dqn", "fixate")


_needs_sb3 = pytest.mark.skipif(importlib.util.find_spec("stable_baselines3") is None,
                                reason="needs the optional 'rl' extra (stable-baselines3 + CPU torch)")


@pytest.mark.slow
@_needs_sb3
def test_cell_head_policy_is_the_cell_map():
    """PPO's cell head: the action distribution's logits are the encoder's logit map, so rolling the
    cortical input along the sectors rolls the action probabilities over the cells."""
    import torch
    from gymnasium import spaces

    from experiments.agents.sb3 import CorticalActorCritic

    M, N = 4, 8
    obs_space = spaces.Dict({"cortical": spaces.Box(0, 1, (2, M, N, 3), np.float32),
                             "eyes": spaces.Box(-np.pi, np.pi, (2, 3), np.float32)})
    pol = CorticalActorCritic(obs_space, spaces.Discrete(M * N), lambda _: 1e-3, channels=(8,))
    with torch.no_grad():
        pol.features_extractor.encoder.logit.weight.mul_(300.0)  # undo the near-uniform initialisation
        obs = {"cortical": torch.rand(1, 2, M, N, 3), "eyes": torch.zeros(1, 2, 3)}
        p = pol.get_distribution(obs).distribution.probs.view(M, N)
        p2 = pol.get_distribution({**obs, "cortical": torch.roll(obs["cortical"], 2, dims=3)}).distribution.probs.view(M, N)
    torch.testing.assert_close(p2, torch.roll(p, 2, dims=1))
    assert p.max() > 2.0 / (M * N)  # not uniform
    with pytest.raises(ValueError, match="head"):
        CorticalActorCritic(obs_space, spaces.Discrete(M * N), lambda _: 1e-3, head="wide")
    with pytest.raises(ValueError, match="saccade_vectors"):
        CorticalActorCritic(obs_space, spaces.Box(-1, 1, (2,)), lambda _: 1e-3)


@pytest.mark.slow
@_needs_sb3
@pytest.mark.parametrize("algo", ["ppo", "sac"])
def test_train_recipe_runs_a_few_hundred_steps_and_evaluates(algo, tmp_path, capsys, monkeypatch):
    """``train --algo ppo|sac --quick`` (256 env steps at 48 px) writes the model, the metadata and a log
    row per evaluation (appended as it goes); ``evaluate`` reloads it and gives the same numbers twice,
    deterministic and (seeded) stochastic. SB3 leaves no ``SB3-<date>`` logger folder in the temporary
    directory (its default at ``verbose=0``, one per ``learn()``)."""
    import tempfile

    from experiments.__main__ import main

    scratch = tmp_path / "tmpdir"
    scratch.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(scratch))

    out = tmp_path / algo
    assert main(["train", "--algo", algo, "--task", "fixate", "--out", str(out), "--quick", "--image-size", "48",
                 "--seed", "3", "--no-progress"]) == 0
    line = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert line["algo"] == algo and line["env_steps"] >= 256
    rows = (out / "training_log.csv").read_text().strip().splitlines()
    steps = [int(r.split(",")[0]) for r in rows[1:]]
    assert steps[0] == 0 and steps == sorted(steps) and steps[-1] >= 256 and len(steps) >= 3
    meta = json.loads((out / f"{algo}.json").read_text())
    assert meta["env_kwargs"]["action_mode"] == "vector" and meta["shaping"]["enabled"] is True
    res = []
    for flags in ([], [], ["--stochastic"], ["--stochastic"]):
        assert main(["evaluate", "--task", "fixate", "--policy", str(out), "--episodes", "3", "--seed", "2",
                     "--no-progress", *flags]) == 0
        res.append(json.loads(capsys.readouterr().out.strip()))
    assert res[0] == res[1] and res[2] == res[3]
    assert res[0]["deterministic"] is True and res[2]["deterministic"] is False
    assert 0.0 <= res[0]["success_rate"] <= 1.0 and res[0]["episodes"] == 3
    assert not list(scratch.glob("SB3-*"))


@pytest.mark.slow
@_needs_sb3
def test_train_sb3_cli_refuses_bad_combinations(tmp_path, capsys):
    from experiments.__main__ import main

    assert main(["train", "--algo", "ppo", "--out", str(tmp_path / "a"), "--iterations", "3"]) == 2
    assert "--iterations apply to --algo cem only" in capsys.readouterr().err
    bad = tmp_path / "hp.yml"
    bad.write_text("fixate: [1, 2\n")
    assert main(["train", "--algo", "ppo", "--out", str(tmp_path / "b"), "--hyperparams", str(bad)]) == 2
    assert "not valid YAML" in capsys.readouterr().err
    bad.write_text("fixate: {policy: transformer}\n")
    assert main(["train", "--algo", "ppo", "--out", str(tmp_path / "c"), "--hyperparams", str(bad), "--quick"]) == 2
    assert "policy must be one of" in capsys.readouterr().err
    assert main(["evaluate", "--policy", "heuristic", "--episodes", "1", "--stochastic"]) == 2
    assert "--stochastic applies to a Stable-Baselines3" in capsys.readouterr().err


@pytest.mark.slow
@pytest.mark.skipif(any(importlib.util.find_spec(m) is None for m in ("skrl", "mujoco_warp", "warp")),
                    reason="needs the gpu extra (skrl, mujoco-warp) for the batched engine's learner")
def test_skrl_recipe_trains_the_cortical_cell_policy_on_cpu(tmp_path):
    """The batched engine's learner with the wrap-around cortical encoder and cell actions: two PPO
    updates on 2 worlds (CPU backend), its summary names the policy, and the curve CSV is written
    (a header at the start, rows appended per rollout)."""
    from experiments.agents import skrl_recipe

    out = tmp_path / "skrl"
    assert skrl_recipe.main(["--out", str(out), "--device", "cpu", "--num-envs", "2", "--timesteps", "4",
                             "--rollouts", "2", "--image-size", "32", "--policy", "cortical",
                             "--action-mode", "cell"]) == 0
    summary = json.loads((out / "ppo.json").read_text())
    assert summary["policy"] == "cortical" and summary["action_mode"] == "cell" and summary["env_steps"] == 8
    # the weights as data (no torch.save pickle), the summary inside the same file
    from experiments.agents.saved import read_unit

    arrays, meta = read_unit(out / "agent.npz")
    assert meta["summary"] == summary and any(k.startswith("agent/policy/") for k in arrays)
    assert not list(out.glob("*.pt"))
    assert (out / "learning_curve.csv").read_text().splitlines()[0] == "env_steps,episodes,mean_return,success_rate"
    with pytest.raises(SystemExit):  # cell actions need the cortical policy
        skrl_recipe.main(["--out", str(tmp_path / "x"), "--action-mode", "cell", "--timesteps", "8"])


@pytest.mark.slow
@_needs_sb3
def test_baselines_command_trains_evaluates_aggregates_and_resumes(tmp_path, capsys):
    """``baselines --quick`` (PPO and CEM x 2 seeds, 48 px, 3 held-out episodes): every run's held-out
    numbers equal ``evaluate`` on the same episodes; the table's IQM and CI are those of
    :func:`summarize_runs` on them; a second call trains nothing; a corrupt ``heldout.json`` re-runs
    that run alone to the same numbers; another study in the folder is refused."""
    import csv

    from experiments.__main__ import main
    from experiments.agents.stats import summarize_runs

    out = tmp_path / "b"
    tiny = tmp_path / "cem.yml"  # a small CEM: its part here is the table's other agent
    tiny.write_text("fixate: {iterations: 2, population: 4, episodes: 1, eval_episodes: 2}\n")
    args = ["baselines", "--task", "fixate", "--agents", "ppo", "cem", "--seeds", "0", "1", "--out", str(out),
            "--quick", "--image-size", "48", "--episodes", "3", "--eval-seed", "2", "--cem-hyperparams", str(tiny)]
    assert main(args) == 0
    first = capsys.readouterr()
    table = first.out
    assert table.startswith("| agent |") and "PPO" in table and "CEM" in table and "heuristic" in table
    # no silent training: each CEM iteration and each PPO evaluation says where the run is (stderr)
    assert "cem fixate: iteration 1/" in first.err and "ppo fixate: " in first.err
    held = {(a, s): json.loads((out / f"{a}_s{s}" / "heldout.json").read_text()) for a in ("ppo", "cem") for s in (0, 1)}
    assert all(h["env_steps"] > 0 for h in held.values()) and "stochastic" in held[("ppo", 0)]
    assert "stochastic" not in held[("cem", 0)]
    # the same episodes as `evaluate --episodes 3 --seed 2`
    assert main(["evaluate", "--task", "fixate", "--policy", str(out / "ppo_s1"), "--episodes", "3", "--seed", "2",
                 "--no-progress"]) == 0
    ev = json.loads(capsys.readouterr().out)
    assert ev["success_rate"] == held[("ppo", 1)]["deterministic"]["success_rate"]
    assert ev["mean_reward"] == pytest.approx(held[("ppo", 1)]["deterministic"]["mean_reward"], abs=1e-12)
    with open(out / "table.csv", newline="") as f:
        rows = {(r["agent"], r["actions"]): r for r in csv.DictReader(f)}
    ppo = rows[("PPO (cortical conv, Box saccade)", "deterministic")]
    s = summarize_runs([held[("ppo", k)]["deterministic"]["success_rate"] for k in (0, 1)])
    assert float(ppo["iqm"]) == pytest.approx(s["iqm"], abs=1e-4)
    assert float(ppo["ci_low"]) == pytest.approx(s["ci_low"], abs=1e-4)
    assert (out / "curves.png").stat().st_size > 1000 and not (out / ".lock").exists()
    # the one RL results table reads the folder as written (benchmarks/rl_results.py)
    spec = importlib.util.spec_from_file_location(
        "rl_results", os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "benchmarks", "rl_results.py"))
    rl_results = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(rl_results)
    res = rl_results.merge(tmp_path / "rl.csv", rl_results.rows_from_baselines(out, "single", "cpu", "test"))
    assert {(r["agent"], r["actions"]): r["heldout_success_iqm"] for r in res}[
        ("PPO (cortical conv, Box saccade)", "deterministic")] == ppo["iqm"]
    # resume: nothing is trained again
    stamps = {p: p.stat().st_mtime_ns for p in out.glob("*_s*/*")}
    assert main(args) == 0
    assert capsys.readouterr().out == table
    assert {p: p.stat().st_mtime_ns for p in out.glob("*_s*/*")} == stamps
    # a torn result: that run alone is trained and evaluated again, to the same numbers
    (out / "cem_s1" / "heldout.json").write_text('{"deterministic": {"success_rate": 0.')
    assert main(args) == 0
    capsys.readouterr()
    again = json.loads((out / "cem_s1" / "heldout.json").read_text())
    assert again["deterministic"] == held[("cem", 1)]["deterministic"]
    assert (out / "ppo_s0" / "heldout.json").stat().st_mtime_ns == stamps[out / "ppo_s0" / "heldout.json"]
    # another study in the same folder is refused, and so is a run made with other hyper-parameters
    assert main([*args, "--eval-seed", "5"]) == 2  # (the last --eval-seed counts)
    assert "another baselines study" in capsys.readouterr().err
    hp = tmp_path / "ppo.yml"
    hp.write_text("fixate: {policy: cortical-cell, env_kwargs: {action_mode: vector}, gamma: 0.8}\n")
    assert main([*args, "--ppo-hyperparams", str(hp)]) == 2
    assert "other ppo hyper-parameters" in capsys.readouterr().err


def test_train_refuses_a_folder_another_run_holds(tmp_path, capsys):
    """Two ``train`` runs into one folder would interleave their logs: the second stops at once."""
    from experiments.__main__ import main
    from experiments.folders import path_lock

    out = tmp_path / "run"
    out.mkdir()
    with path_lock(out / ".lock"):
        assert main(["train", "--task", "fixate", "--out", str(out), "--quick", "--no-progress"]) == 2
    assert "in use by another run" in capsys.readouterr().err
    assert not (out / "training_log.csv").exists()


@pytest.mark.slow
@_needs_sb3
def test_training_keeps_one_torch_thread_whatever_ran_before(tmp_path):
    """numba's OpenMP layer, started by the env's first step, used to reset torch to 2 threads: a fresh
    process and one that had run the env before trained different weights. Both now train on one torch
    thread, to the same weights."""
    code = ("import sys, hashlib, torch\n"
            "from experiments.agents.hyperparams import load_hyperparams\n"
            "from experiments.agents.baselines import quick_hyperparams\n"
            "from experiments.agents.sb3 import train_sb3\n"
            "if sys.argv[1] == 'env-first':\n"
            "    from experiments.agents.rollout import make_env\n"
            "    e = make_env('search', image_size=48); e.reset(seed=1); e.step(3); e.close()\n"
            "hp = load_hyperparams('ppo', 'search'); hp['env_kwargs']['image_size'] = 48\n"
            "train_sb3(sys.argv[2], 'ppo', 'search', quick_hyperparams('ppo', hp), seed=0, timesteps=64, log=lambda m: None)\n"
            "import numpy as np\n"
            "z = np.load(sys.argv[2] + '/ppo.npz', allow_pickle=False)\n"
            "w = b''.join(z[k].tobytes() for k in sorted(z.files) if k != '__meta__')\n"
            "print(torch.get_num_threads(), hashlib.md5(w).hexdigest())\n")
    env = {**os.environ, "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl")}
    runs = [subprocess.run([sys.executable, "-c", code, mode, str(tmp_path / mode)], capture_output=True, text=True,
                           env=env) for mode in ("fresh", "env-first")]
    assert all(r.returncode == 0 for r in runs), [r.stderr[-2000:] for r in runs]
    outs = [r.stdout.split() for r in runs]
    assert outs[0][0] == outs[1][0] == "1", outs
    assert outs[0][1] == outs[1][1], outs
