"""``train --algo ppo --engine batched``: hostile options give one line; the batched shaping is the single
env's ``PotentialShaping``; a tiny CPU run (Warp's CPU backend) trains, is killed and resumes to the same
weights, and ``evaluate`` runs the saved agent on the single env."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

ENV = {**os.environ, "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl")}


def _main(argv, capsys) -> tuple[int, str]:
    from experiments.__main__ import main

    try:
        rc = main(argv)
    except SystemExit as e:
        rc = e.code
    return rc, capsys.readouterr().err


def _one_line(rc: int, err: str, expect: str) -> None:
    assert rc == 2, err
    assert "Traceback" not in err and expect in err.strip().splitlines()[-1], err


@pytest.mark.parametrize("extra, expect", [
    (["--engine", "batched", "--algo", "sac"], "--engine batched trains PPO only"),
    (["--engine", "batched", "--algo", "cem"], "--engine batched trains PPO only"),
    (["--engine", "batched", "--algo", "ppo", "--num-envs", "0"], "--num-envs: expected a whole number in [1, 65536]"),
    (["--algo", "ppo", "--num-envs", "4"], "apply to --engine batched only"),
    (["--algo", "ppo", "--device", "cpu"], "apply to --engine batched only"),
    (["--engine", "batched", "--algo", "ppo", "--iterations", "3"], "apply to --algo cem only"),
])
def test_hostile_options_are_one_line(extra, expect, tmp_path, capsys):
    out = tmp_path / "run"
    rc, err = _main(["train", "--task", "search", "--out", str(out), *extra], capsys)
    _one_line(rc, err, expect)
    assert not out.exists()


def test_cuda_without_cuda_is_one_line(tmp_path, capsys):
    torch = pytest.importorskip("torch")
    pytest.importorskip("warp")
    pytest.importorskip("mujoco_warp")
    if torch.cuda.is_available():
        pytest.skip("this machine has CUDA")
    out = tmp_path / "run"
    for device, expect in (("cuda", "finds no CUDA device here; use --device cpu"), ("tpu", "--device must be cpu")):
        rc, err = _main(["train", "--algo", "ppo", "--engine", "batched", "--device", device, "--task", "search",
                         "--out", str(out)], capsys)
        _one_line(rc, err, expect)
        assert not out.exists()


def test_bad_hyperparameters_are_refused():
    pytest.importorskip("torch")
    from experiments.agents.batched_ppo import plan_batched
    from experiments.agents.hyperparams import load_hyperparams

    hp = load_hyperparams("ppo_batched", "search")
    plan = plan_batched("search", hp, num_envs=8, timesteps=100)
    assert plan["updates"] == 1 and plan["env_steps"] == 8 * hp["n_steps"]  # rounded up to whole updates
    assert plan["algo_kwargs"]["gamma"] == 0.9 and plan["shaping"]["enabled"]  # as the CPU recipe (ppo.yml)
    assert plan["heldout"] == {"seed": 0, "episodes": 100, "stream": 0}  # evaluate's episodes
    for bad, msg in (({"n_stepz": 3}, "unknown"), ({"n_steps": 0}, "n_steps"), ({"gamma": 1.5}, "gamma"),
                     ({"learning_rate": float("nan")}, "learning_rate"), ({"env_kwargs": {"action_mode": "vector"}},
                                                                          "image_size and task_kwargs only"),
                     ({"env_kwargs": {"task_kwargs": [3]}}, "task_kwargs must be a mapping"),
                     ({"env_kwargs": {"task_kwargs": {"max_saccades": 0}}}, "task_kwargs: .*max_saccades"),
                     ({"env_kwargs": {"task_kwargs": {"max_sacades": 3}}}, "task_kwargs: ")):
        with pytest.raises(ValueError, match=msg):
            plan_batched("search", {**hp, **bad}, num_envs=8)


def test_batched_shaping_refuses_what_is_not_a_batched_env():
    import envs
    from conformal import checks

    with pytest.raises(checks.InputTypeError, match="BatchedBinocularSaccade"):
        envs.BatchedPotentialShaping(object())


@pytest.mark.slow
def test_batched_shaping_is_the_single_envs():
    """``envs.BatchedPotentialShaping``: Phi at reset and F after a step, per world, equal ``envs.PotentialShaping``'s on the single env
    started from the same seed and given the same cell (the batched physics runs in float32: 1e-4)."""
    pytest.importorskip("torch")
    pytest.importorskip("warp")
    pytest.importorskip("mujoco_warp")
    import envs
    from experiments.agents.batched_ppo import make_batched_env
    from experiments.agents.rollout import make_env

    seeds, cells = [11, 12, 13], np.array([3, 30, 47])
    env = make_batched_env("search", 3, "cpu", 32)
    try:
        env.reset(seed=seeds)
        with pytest.raises(ValueError, match="gamma"):
            envs.BatchedPotentialShaping(env, gamma=0.0)
        sh = envs.BatchedPotentialShaping(env, 0.9, 10.0)
        sh.start()
        phi0 = sh.phi.copy()
        _, r, te, tr, info = env.step(cells)
        f = sh.step(info, te, te | tr)
    finally:
        env.close()
    for i, s in enumerate(seeds):
        single = envs.PotentialShaping(make_env("search", image_size=32), gamma=0.9, scale_deg=10.0)
        try:
            single.reset(seed=s)
            assert phi0[i] == pytest.approx(single.potential(), abs=1e-4)
            _, _, _, _, sinfo = single.step(int(cells[i]))
        finally:
            single.close()
        assert f[i] == pytest.approx(sinfo["reward_shaping"], abs=1e-4)
        assert r[i] == pytest.approx(sinfo["reward_task"])


def _kill_after_checkpoint(argv: list[str], out: Path) -> None:
    p = subprocess.Popen(argv + ["--out", str(out)], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=ENV)
    ck = out / "checkpoint.npz"
    try:
        while not ck.exists() and p.poll() is None:
            time.sleep(0.01)
        assert p.poll() is None, "the run ended before its first checkpoint"
    finally:
        p.kill()
        p.wait()


@pytest.mark.slow
def test_tiny_cpu_run_resumes_to_the_same_weights_and_evaluates(tmp_path, capsys):
    """``train --engine batched --device cpu --quick`` (2 worlds, 2 PPO updates, 1 validation episode): killed (SIGKILL) after its
    first checkpoint, the same command finishes with the weights and log of a run never stopped; the folder
    holds no pickle, and ``evaluate --policy DIR`` runs the agent on the single env's held-out episodes."""
    pytest.importorskip("torch")
    pytest.importorskip("warp")
    pytest.importorskip("mujoco_warp")
    argv = [sys.executable, "-m", "experiments", "train", "--algo", "ppo", "--engine", "batched", "--device", "cpu",
            "--num-envs", "2", "--task", "search", "--quick", "--eval-episodes", "1", "--seed", "3", "--no-progress"]
    whole, cut = tmp_path / "whole", tmp_path / "cut"
    r = subprocess.run(argv + ["--out", str(whole)], capture_output=True, text=True, env=ENV)
    assert r.returncode == 0, r.stderr[-2000:]
    line = json.loads(r.stdout.strip().splitlines()[-1])
    assert line["engine"] == "batched" and line["env_steps"] == 8 and line["heldout_episodes"] == 4
    _kill_after_checkpoint(argv, cut)
    assert not (cut / "ppo.json").exists() and (cut / "train.json").exists()
    r = subprocess.run(argv + ["--out", str(cut)], capture_output=True, text=True, env=ENV)
    assert r.returncode == 0, r.stderr[-2000:]
    a, b = np.load(whole / "ppo.npz", allow_pickle=False), np.load(cut / "ppo.npz", allow_pickle=False)
    keys = sorted(k for k in a.files if k != "__meta__")
    assert keys == sorted(k for k in b.files if k != "__meta__") and keys
    for k in keys:
        np.testing.assert_array_equal(a[k], b[k], err_msg=k)
    drop = lambda t: [ln.split(",")[:2] + ln.split(",")[3:-1] for ln in t.splitlines()]  # noqa: E731 (no timings)
    assert drop((whole / "training_log.csv").read_text()) == drop((cut / "training_log.csv").read_text())
    assert len((whole / "training_log.csv").read_text().splitlines()) == 4  # header, start, after each update
    assert not (cut / "checkpoint.npz").exists() and not (cut / ".lock").exists()
    assert not any(p.suffix in (".zip", ".pt", ".pkl", ".pth") for p in whole.iterdir())
    meta = json.loads((whole / "ppo.json").read_text())
    assert meta["architecture"]["class"] == "CellActorCritic" and meta["shaping"]["enabled"]
    # another run's settings are refused, naming what differs (in this process: the same code as the command's)
    capsys.readouterr()
    rc, err = _main([*argv[3:-3], "--seed", "4", "--no-progress", "--out", str(whole)], capsys)
    _one_line(rc, err, "differs in: seed")
    from experiments.__main__ import main

    rc = main(["evaluate", "--task", "search", "--policy", str(whole), "--episodes", "3", "--no-progress"])
    res = capsys.readouterr()
    assert rc == 0, res.err
    ev = json.loads(res.out.strip().splitlines()[-1])
    assert ev["source"] == "folder (ppo)" and ev["episodes"] == 3 and 1 <= ev["mean_saccades"] <= 10
