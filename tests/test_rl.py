"""RL agents: features, baselines, CEM training improves on random, save/reload/evaluate, CLI."""

from __future__ import annotations

import importlib.util
import json
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
        "ppo without zip": ({"ppo.json": json.dumps({"task": "fixate", "env_kwargs": {}})}, "missing ppo_fixate.zip"),
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
@pytest.mark.parametrize("case", range(8))
def test_evaluate_rejects_corrupt_policy_folders(case, tmp_path, capsys):
    from experiments.__main__ import main

    d, msg = _corrupt_policies(tmp_path)[case]
    assert main(["evaluate", "--policy", str(d), "--episodes", "1"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("evaluate: error:") and msg in err and len(err.splitlines()) == 1, err


@pytest.mark.adversarial
@pytest.mark.parametrize("value", ["nan", "0", "-3", "2.5", "1e12", "abc"])
@pytest.mark.parametrize("option", ["--timesteps", "--n-envs", "--n-steps", "--eval-episodes", "--seed"])
def test_sb3_recipe_rejects_bad_options(option, value, tmp_path, capsys):
    from experiments import sb3_recipe

    if option == "--seed" and value == "0":
        pytest.skip("0 is a valid seed")
    with pytest.raises(SystemExit) as e:
        sb3_recipe.main(["--out", str(tmp_path / "o"), f"{option}={value}"])
    assert e.value.code == 2
    assert f"argument {option}" in capsys.readouterr().err.strip().splitlines()[-1]


@pytest.mark.skipif(importlib.util.find_spec("stable_baselines3") is None,
                    reason="needs the optional 'rl' extra (stable-baselines3 + CPU torch)")
def test_sb3_recipe_runs(tmp_path):
    from experiments import sb3_recipe

    path = sb3_recipe.train_ppo(tmp_path, total_timesteps=64, n_envs=2, n_steps=32, vec="dummy", seed=0)
    assert path.exists() and (tmp_path / "ppo.json").exists()
    res = sb3_recipe.evaluate_ppo(path, episodes=2, seed=0)
    assert 0.0 <= res["success_rate"] <= 1.0 and res["episodes"] == 2


@pytest.mark.skipif(importlib.util.find_spec("stable_baselines3") is None,
                    reason="needs the optional 'rl' extra (stable-baselines3 + CPU torch)")
def test_sb3_recipe_prints_progress_and_evaluate_loads_it(tmp_path):
    """The recipe's command prints a line per rollout and its result; ``python -m experiments
    evaluate --policy DIR`` loads what it saved and, on the same episodes, reports the same numbers."""
    out = tmp_path / "ppo"
    r = subprocess.run([sys.executable, "-m", "experiments.sb3_recipe", "--out", str(out), "--timesteps", "64",
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
