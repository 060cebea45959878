"""``--backend local|ray`` and ``--workers`` of the heavy commands (issue 37): one option declaration
(``experiments.cli.options``), one Ray path (``psychophysics.backends.ray_map``), the same table."""

from __future__ import annotations

import pytest

from experiments.__main__ import build_parser, main
from experiments.psychophysics import FIG11_OFFSETS_DEG, Design, TrialConfig, run_trials
from experiments.psychophysics.backends import check_backend

HEAVY = ("run", "phenomena", "fit", "compare", "recovery", "baselines")


@pytest.mark.parametrize("command", HEAVY)
def test_every_heavy_command_offers_the_same_backend_and_workers(command):
    """Each heavy command's --workers accepts 1-64 and nothing else, and --backend local|ray."""
    sub = build_parser(command)._subparsers._group_actions[0].choices[command]  # type: ignore[union-attr]
    opts = {o: a for a in sub._actions for o in a.option_strings}
    assert opts["--backend"].choices == ("local", "ray") and opts["--backend"].default == "local"
    workers = opts["--workers"].type
    assert workers("1") == 1 and workers("64") == 64
    for bad in ("0", "65", "2.5", "nan"):
        with pytest.raises(Exception, match="1, 64"):
            workers(bad)


@pytest.mark.parametrize("command", ["run", "phenomena", "recovery", "baselines"])
def test_a_ray_address_without_the_ray_backend_is_a_usage_error(command, tmp_path, capsys):
    with pytest.raises(SystemExit) as e:
        main([command, "--out", str(tmp_path / "x"), "--ray-address", "auto"])
    assert e.value.code == 2
    assert "--ray-address: only with --backend ray" in capsys.readouterr().err
    assert not (tmp_path / "x").exists()


def test_check_backend_refuses_what_it_cannot_run():
    check_backend("local")
    check_backend("ray", "auto")
    with pytest.raises(ValueError, match="backend must be one of local, ray"):
        check_backend("dask")
    with pytest.raises(ValueError, match="only for the ray backend"):
        check_backend("local", "auto")
    with pytest.raises(ValueError, match="backend must be one of"):
        run_trials(Design(amplitudes_deg=(20.0,), flash_offsets_deg=FIG11_OFFSETS_DEG[:1], flash_times_ms=(0,)),
                   TrialConfig(image_size=64), "unused", backend="dask")


@pytest.mark.slow
def test_ray_backend_writes_the_local_table_and_observations(tmp_path):
    """The same design run in this process and on a local Ray instance (2 actors): byte-identical
    trials.csv (rows sorted, each with its configuration hash and checksum); and the same trials
    observed for a fit (``modelfit.observe_trials``) on it: identical read-outs. One instance serves
    both (``ray_map`` uses a running one); ``ray_map`` starting and stopping its own is exercised by
    ``tests/test_adversarial_fit.py``'s kill -9 of a Ray fit, through the command line."""
    ray = pytest.importorskip("ray")
    from experiments.modelfit import observe_trials
    from experiments.psychophysics import Trial, TrialRunner

    design = Design(amplitudes_deg=(20.0,), flash_offsets_deg=FIG11_OFFSETS_DEG[:2], flash_times_ms=(-50, 25),
                    name="backends")
    cfg = TrialConfig(image_size=64)
    trials = [Trial(trial_id=i, amplitude_deg=20.0, flash_dx_deg=dx, flash_dy_deg=dy, flash_time_ms=t,
                    repetition=0, seed=0)
              for i, ((dx, dy), t) in enumerate(zip(FIG11_OFFSETS_DEG[:4], (-50, 0, 25, 100)))]
    local = run_trials(design, cfg, tmp_path / "local", workers=1, progress=False, batch_size=1)
    observed = observe_trials(trials, cfg, backend="local", workers=1)
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
    try:
        remote = run_trials(design, cfg, tmp_path / "ray", workers=2, progress=False, batch_size=1, backend="ray")
        assert ray.is_initialized()  # ray_map used the running instance and left it running
        observed_remote = observe_trials(trials, cfg, backend="ray", workers=2)
    finally:
        ray.shutdown()
    assert local.read_bytes() == remote.read_bytes()
    assert len(local.read_text().splitlines()) == 1 + design.n_trials
    runner = TrialRunner(cfg)
    try:
        for a, b in zip(observed, observed_remote, strict=True):
            ra, rb = runner.readout(a), runner.readout(b)
            assert ra["perceived_x_deg"] == rb["perceived_x_deg"] and ra["perceived_y_deg"] == rb["perceived_y_deg"]
    finally:
        runner.close()


@pytest.mark.slow
def test_baselines_on_two_processes_writes_the_in_process_table(tmp_path, capsys):
    """CEM x 2 seeds trained one after the other and on 2 spawned processes: the same held-out numbers
    and the same table rows (wall times aside). CEM alone (no PPO or SAC) still writes the
    ``curves.png`` that ``--help`` promises: its validation curve, IQM over the seeds (issue 37)."""
    import json

    tiny = tmp_path / "cem.yml"  # a tiny CEM (--cem-hyperparams): what is compared is where the runs train
    tiny.write_text("fixate: {iterations: 2, population: 4, episodes: 1, eval_episodes: 2}\n")
    common = ["baselines", "--task", "fixate", "--agents", "cem", "--seeds", "0", "1", "--quick", "--image-size",
              "32", "--episodes", "2", "--cem-hyperparams", str(tiny)]
    assert main([*common, "--out", str(tmp_path / "one")]) == 0
    assert main([*common, "--out", str(tmp_path / "two"), "--workers", "2"]) == 0
    capsys.readouterr()
    for s in (0, 1):
        a, b = (json.loads((tmp_path / d / f"cem_s{s}" / "heldout.json").read_text()) for d in ("one", "two"))
        assert a["deterministic"] == b["deterministic"] and a["env_steps"] == b["env_steps"]
    one, two = ([line.rsplit("|", 2)[0] for line in (tmp_path / d / "table.md").read_text().splitlines()]
                for d in ("one", "two"))  # the last column, the wall time, left out
    assert one == two
    assert all((tmp_path / d / "curves.png").stat().st_size > 1000 for d in ("one", "two"))
    import yaml

    from experiments.agents.cem import CEMConfig

    for s in (0, 1):  # the file's config is the one trained, and it is part of the runs' settings
        a = json.loads((tmp_path / "one" / f"cem_s{s}" / "heldout.json").read_text())
        assert CEMConfig(**a["hyperparams"]) == CEMConfig.from_mapping(yaml.safe_load(tiny.read_text())["fixate"])
        assert len((tmp_path / "one" / f"cem_s{s}" / "training_log.csv").read_text().splitlines()) == 1 + 2
    tiny.write_text("fixate: {iterations: 3, population: 4, episodes: 1, eval_episodes: 2}\n")
    assert main([*common, "--out", str(tmp_path / "one")]) == 2  # other hyper-parameters: refused, not mixed
    assert "other cem hyper-parameters" in capsys.readouterr().err


@pytest.mark.adversarial
@pytest.mark.parametrize("text, says", [
    ("fixate: {iters: 2}\n", "unknown CEM hyper-parameter(s) iters"),
    ("fixate: {iterations: 2.5}\n", "iterations must be a whole number"),
    ("fixate: {init_std: .inf}\n", "init_std must be a finite number"),
    ("fixate: {population: 0}\n", "population must be >= 1"),
    ("search: {iterations: 2}\n", "no entry for task 'fixate'"),
])
def test_bad_cem_hyperparams_are_refused_before_training(tmp_path, capsys, text, says):
    bad = tmp_path / "cem.yml"
    bad.write_text(text)
    out = tmp_path / "b"
    rc = main(["baselines", "--task", "fixate", "--agents", "cem", "--quick", "--cem-hyperparams", str(bad),
               "--out", str(out)])
    err = capsys.readouterr().err
    assert rc != 0 and says in err and "Traceback" not in err, err
    assert not any(out.glob("cem_s*"))
