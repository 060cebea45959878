"""``--generator FILE`` on ``run``, ``phenomena`` and ``fit``: a person's fitted burst generator used
everywhere (``models.BurstGenerator.from_file``), and bad files refused as usage errors."""

from __future__ import annotations

import json

import pytest

import models
from experiments.__main__ import build_parser
from experiments.psychophysics import Design, TrialConfig
from experiments.psychophysics.runner import config_fingerprint
from experiments.modelfit.forward import config_from_fingerprint

GEN = models.BurstGenerator(burst_max_deg_s=610.0, burst_scale_deg=3.7, burst_lag_ms=9.1)


@pytest.fixture()
def gen_file(tmp_path):
    path = tmp_path / "generator.json"
    GEN.to_file(path, ci95={"burst_max_deg_s": [600.0, 620.0]})
    return path


@pytest.mark.parametrize("command", [["run"], ["phenomena"], ["fit", "--data", "data.csv", "--out", "o"]])
def test_each_command_reads_the_generator(command, gen_file):
    args = build_parser().parse_args(command + ["--generator", str(gen_file)])
    assert args.generator == GEN


@pytest.mark.parametrize("command", [["run"], ["phenomena"], ["fit", "--data", "data.csv", "--out", "o"]])
@pytest.mark.parametrize("content, message", [
    ("{not json", "cannot read a burst generator"),
    (json.dumps({"model": "MainSequence", "parameters": {}}), "is not a burst-generator file"),
    (json.dumps({"model": "BurstGenerator", "parameters": {"burst_speed": 3}}), "unknown burst-generator parameter"),
    (json.dumps({"model": "BurstGenerator", "parameters": {"burst_max_deg_s": -5}}), "burst_max_deg_s"),
    # within every parameter's range, but above the family's 1000 deg/s ceiling: refused when read, not mid-run
    (json.dumps({"model": "BurstGenerator", "parameters": {"burst_max_deg_s": 1800, "adaptation_gain": 0}}),
     "1000 deg/s"),
    ("[" * 100_000 + "]" * 100_000, "nested too deeply"),
])
def test_a_bad_generator_file_is_a_usage_error(command, content, message, tmp_path, capsys):
    bad = tmp_path / "bad.json"
    bad.write_text(content)
    with pytest.raises(SystemExit) as exc:
        build_parser().parse_args(command + ["--generator", str(bad)])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert "--generator" in err and message in err and "bad.json" in err


def test_missing_generator_file_is_a_usage_error(tmp_path, capsys):
    with pytest.raises(SystemExit) as exc:
        build_parser().parse_args(["run", "--generator", str(tmp_path / "nope.json")])
    assert exc.value.code == 2 and "nope.json" in capsys.readouterr().err


def test_the_generator_reaches_the_head_and_survives_the_run_record():
    """The trial runner's head uses it; the run's fingerprint (run.json) stores it and gives it back, and
    it changes the configuration hash (a resumed run cannot mix generators)."""
    from experiments.psychophysics import TrialRunner
    from experiments.psychophysics.runner import config_hash

    cfg = TrialConfig(image_size=64, generator=GEN)
    runner = TrialRunner(cfg)
    try:
        assert runner.head.generator == GEN
    finally:
        runner.close()
    design = Design(amplitudes_deg=(10.0,), flash_offsets_deg=((0.0, 0.0),), flash_times_ms=(0,), repetitions=1, seed=0)
    stored = json.loads(json.dumps(config_fingerprint(design, cfg)))["config"]
    assert config_from_fingerprint(stored) == cfg
    assert config_hash(design, cfg) != config_hash(design, TrialConfig(image_size=64))
    assert "generator" not in config_fingerprint(design, TrialConfig(image_size=64))["config"]  # old hashes stay
    with pytest.raises(ValueError, match="legacy"):
        TrialConfig(saccade_model="legacy", generator=GEN)
    with pytest.raises(TypeError, match="BurstGenerator"):
        TrialConfig(generator={"burst_max_deg_s": 600})


def test_the_eye_drive_is_part_of_the_configuration():
    """A run made with the servo and one with the orbital plant are different configurations: a folder
    of one cannot be resumed as the other."""
    from experiments.psychophysics import TrialRunner
    from experiments.psychophysics.runner import config_hash

    design = Design(amplitudes_deg=(10.0,), flash_offsets_deg=((0.0, 0.0),), flash_times_ms=(0,), repetitions=1, seed=0)
    plant, servo = TrialConfig(image_size=64), TrialConfig(image_size=64, eye_drive="servo")
    assert config_hash(design, plant) != config_hash(design, servo)
    stored = json.loads(json.dumps(config_fingerprint(design, servo)))["config"]
    assert config_from_fingerprint(stored) == servo
    runner = TrialRunner(servo)
    try:
        assert runner.head.eye_drive == "servo"
    finally:
        runner.close()
    with pytest.raises(ValueError, match="eye_drive"):
        TrialConfig(eye_drive="muscle")
    assert build_parser().parse_args(["run", "--eye-drive", "servo"]).eye_drive == "servo"
