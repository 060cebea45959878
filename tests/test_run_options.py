"""``run``: an option that does nothing in the chosen condition, model or paradigm is a usage error
(it would change the configuration's hash and nothing else); where it acts, it is accepted."""

from __future__ import annotations

import pytest

# (option and value, where it does nothing, where it acts)
PAIRS = [
    (["--markers", "1,1"], ["--condition", "dark"], ["--condition", "references"]),
    (["--no-ruler"], ["--condition", "dark"], ["--condition", "references"]),
    (["--reference-contrast", "0.5"], ["--condition", "dark"], []),
    (["--reference-ms", "200"], ["--condition", "dark"], []),
    (["--target-off-ms", "300"], ["--condition", "dark"], []),
    (["--feedback-gain", "3"], ["--model", "paper"], ["--model", "mechanistic"]),
    (["--feedback-gain", "3"], ["--model", "observer"], []),
    (["--reference-weight", "0.5"], ["--model", "population"], []),
    (["--disable", "smear"], ["--model", "paper"], []),
    (["--peak-gain", "0.3"], ["--model", "mechanistic"], ["--model", "paper"]),
    (["--peak-time-ms=-20"], ["--model", "observer"], ["--model", "paper"]),
    (["--rise-ms", "20"], [], ["--model", "paper"]),
    (["--decay-ms", "20"], ["--model", "population"], ["--model", "paper"]),
    (["--stability-tolerance", "0.2"], [], ["--paradigm", "displacement"]),
    (["--report-noise-deg", "1"], ["--paradigm", "separation"], ["--paradigm", "displacement"]),
]


def _build(argv):
    from experiments.__main__ import build_parser
    from experiments.cli.run import _build

    args = build_parser().parse_args(["run", "--quick", "--out", "unused", *argv])
    return _build(args)


@pytest.mark.parametrize("option,idle,active", PAIRS, ids=[" ".join(p[0] + p[1]) or p[0][0] for p in PAIRS])
def test_an_option_that_does_nothing_is_a_usage_error(option, idle, active, capsys):
    with pytest.raises(SystemExit) as e:
        _build([*idle, *option])
    assert e.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) >= 1 and err[-1].startswith("python -m experiments run: error: argument "
                                                f"{option[0].split('=')[0]}: does nothing here"), err
    _, config, _ = _build([*active, *option])  # where it acts it is accepted
    assert config is not None


def test_defaults_and_acting_values_pass():
    """The defaults of every option pass in every condition and model; a negative --target-off-ms (the
    target off before onset, a memory-guided saccade) acts in the dark too."""
    for cond in ("references", "dark"):
        for model in ("mechanistic", "paper", "population", "observer"):
            _build(["--condition", cond, "--model", model])
    _, config, _ = _build(["--condition", "dark", "--target-off-ms=-50"])
    assert config.target_off_ms == -50
