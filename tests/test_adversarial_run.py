"""Hostile inputs to ``python -m experiments run`` and to the psychophysics library (issue 11, item 5).

Every numeric option of ``run`` is swept with NaN, infinities, zero, negative, huge and non-integer
values, wrong types and empty strings: each must end in a usage error (exit 2) whose message is one
line naming the option, before any folder is created or any trial simulated. The library's
``Design``, ``TrialConfig``, ``RemapTimeCourse`` and ``run_trials`` raise ``TypeError`` or
``ValueError`` naming the parameter. Each case is one test item marked ``adversarial``.
"""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from experiments.psychophysics.bounds import LIMITS

pytestmark = pytest.mark.adversarial

PROG_ERROR = "python -m experiments run: error: "

# option -> its parameter in bounds.LIMITS
NUMERIC = {
    "--peak-time-ms": "peak_time_ms", "--rise-ms": "rise_ms", "--decay-ms": "decay_ms", "--peak-gain": "peak_gain",
    "--fovy-deg": "fovy_deg", "--fovea-deg": "fovea_deg", "--threshold": "threshold",
    "--flash-radius-deg": "flash_radius_deg", "--endpoint-noise": "endpoint_noise",
    "--repetitions": "repetitions", "--seed": "seed", "--image-size": "image_size", "--oversample": "oversample",
    "--workers": "workers",
}
COMMON = ("nan", "NaN", "inf", "-inf", "Infinity", "1e9", "1e300", "-1e300", "1e400", "abc", "", " ", "1,2", "0x10")


def _num(v: float) -> str:
    return str(int(v)) if float(v).is_integer() else repr(float(v))


def _bad_values(opt: str) -> list[str]:
    lim = LIMITS[NUMERIC[opt]]
    vals = list(COMMON)
    vals.append(_num(lim.lo) if lim.lo_open else _num(lim.lo - 1))  # just below
    vals.append(_num(lim.hi) if lim.hi_open else _num(lim.hi + 1))  # just above
    vals += [v for v in ("0", "-1", "-0.5") if not lim.contains(float(v))]
    if lim.integer:
        vals += ["2.5", "1.0000001", "1e-3", str(2**70), "1e20"]  # ("3.0" and "1e3" are whole numbers)
    out = []
    for v in vals:
        try:
            f = float(v)
        except ValueError:
            f = math.nan
        valid = lim.contains(f) and (not lim.integer or f.is_integer())  # e.g. --seed=1e9 is a seed
        if v not in out and not valid:
            out.append(v)
    return out


CASES = [pytest.param(opt, [f"{opt}={v}"], id=f"{opt}={v!r}") for opt in NUMERIC for v in _bad_values(opt)]
CASES += [pytest.param(opt, [opt], id=f"{opt}-missing-value") for opt in NUMERIC]
CASES += [pytest.param("--amplitudes", [f"--amplitudes={v}"], id=f"--amplitudes={v!r}") for v in (
    "nan", "inf", "-inf", "0", "-5", "40.0001", "41", "1e9", "1e300", "1e400", "abc", "", ",", " , ", "12,nan",
    "12,abc", "12;16", "12,,inf", "0x10")]
CASES += [pytest.param("--flash-times", [f"--flash-times={v}"], id=f"--flash-times={v!r}") for v in (
    "nan", "inf", "-inf", "0.5", "1e9", "-1001", "1001", "abc", "", ",", "-100:100:0", "100:-100:10", "-100:100",
    "0:1e9:1", "-1000000000:1000000000:1", "1:2:3:4", "a:b:c", "0,0.5", "-100:100:-10", "-100:100:2.5",
    "0:1001:1", "-1001:0:1", str(10**30))]
CASES += [pytest.param("--formats", [f"--formats={v}"], id=f"--formats={v!r}") for v in (
    "", "gif", "png,gif", "nan", ",", "png;svg", "1e9")]
CASES += [pytest.param("--positions", [f"--positions={v}"], id=f"--positions={v!r}")
          for v in ("nope", "", "FIG11", "1e9")]
CASES += [pytest.param(opt, [opt], id=f"{opt}-missing-value")
          for opt in ("--amplitudes", "--flash-times", "--formats", "--positions", "--out")]
# combinations: each value is valid alone, together they are not
CASES += [
    pytest.param("--repetitions", ["--repetitions=1000"], id="design-too-large-1248000-trials"),
    pytest.param("--repetitions", ["--repetitions=100", "--amplitudes=1,2,3,4,5"], id="design-too-large-156000-trials"),
    pytest.param("--repetitions", ["--repetitions=1000", "--quick", "--flash-times=-1000:1000:1"],
                 id="design-too-large-quick-every-ms"),
    pytest.param("--fovea-deg", ["--fovea-deg=9", "--fovy-deg=20"], id="fovea-wider-than-a-quarter-of-fovy"),
    pytest.param("--fovea-deg", ["--fovea-deg=10", "--fovy-deg=40"], id="fovea-equal-to-a-quarter-of-fovy"),
]


def _usage_error(capsys, argv: list[str], opt: str) -> str:
    from experiments.__main__ import main

    with pytest.raises(SystemExit) as e:
        main(argv)
    assert e.value.code == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err
    errors = [ln for ln in err.splitlines() if "error:" in ln]
    assert len(errors) == 1 and err.rstrip("\n").splitlines()[-1] == errors[0], err
    assert errors[0].startswith(PROG_ERROR) and opt in errors[0], err
    return errors[0]


@pytest.mark.parametrize("opt, args", CASES)
def test_bad_option_is_a_one_line_usage_error(tmp_path, capsys, opt, args):
    out = tmp_path / "never"
    _usage_error(capsys, ["run", "--out", str(out), "--no-progress", *args], opt)
    assert not out.exists()  # refused before anything was created or simulated


def _file(tmp_path: Path) -> Path:
    f = tmp_path / "a_file"
    f.write_text("not a folder")
    return f


OUT_CASES = {
    "empty": lambda tmp: "",
    "blank": lambda tmp: "   ",
    "nul": lambda tmp: "res\x00ults",
    "a-file": lambda tmp: str(_file(tmp)),
    "under-a-file": lambda tmp: str(_file(tmp) / "sub"),
    "deep-under-a-file": lambda tmp: str(_file(tmp) / "a" / "b"),
    "proc-new": lambda tmp: "/proc/conformal_head_results",
    "proc": lambda tmp: "/proc",
    "proc-self-file": lambda tmp: "/proc/self/status",
}


@pytest.mark.parametrize("case", list(OUT_CASES))
def test_unusable_output_folder_is_a_usage_error(tmp_path, capsys, case):
    line = _usage_error(capsys, ["run", "--quick", "--no-progress", f"--out={OUT_CASES[case](tmp_path)}"], "--out")
    assert line.startswith(PROG_ERROR + "argument --out: ")


# ---------------------------------------------------------------------------------------------- library
NAN, INF = math.nan, math.inf


def _lib_cases():
    from experiments.psychophysics import Design, RemapTimeCourse, TrialConfig

    V, T = ValueError, TypeError
    cases = []
    for name, bad in {
        "image_size": [(7.5, V), ("256", T), (True, T), (None, T), (1e9, V), (NAN, V), (31, V), (2**70, V), (1025, V)],
        "fovy_deg": [(NAN, V), (INF, V), ("90", T), (0, V), (1e300, V), (1 + 0j, T), (-90, V)],
        "fovea_deg": [(0, V), (-1, V), (NAN, V), (INF, V), ([2.0], T)],
        "threshold": [(1, V), (-0.1, V), (NAN, V), ("0.2", T)],
        "oversample": [(2.5, V), (0, V), (9, V), ("3", T), (NAN, V)],
        "flash_radius_deg": [(0, V), (100, V), (NAN, V), (-1, V)],
        "endpoint_noise": [(-0.1, V), (NAN, V), (1, V), (INF, V), (False, T)],
        "timecourse": [("x", T), (None, T), (0.5, T)],
    }.items():
        for v, exc in bad:
            cases.append(pytest.param(lambda n=name, v=v: TrialConfig(**{n: v}), exc, name,
                                      id=f"TrialConfig-{name}={v!r}"))
    cases.append(pytest.param(lambda: TrialConfig(fovy_deg=20, fovea_deg=6), ValueError, "fovea_deg",
                              id="TrialConfig-fovea-vs-fovy"))
    for name, bad in {
        "peak_gain": [(1e9, V), (NAN, V), (-1, V), ("0.5", T), (INF, V), (5.0001, V)],
        "rise_ms": [(0, V), (INF, V), (-1, V), (NAN, V), (1e9, V)],
        "decay_ms": [(NAN, V), (0, V), (None, T)],
        "peak_time_ms": [(1e9, V), (NAN, V), (-INF, V), ("0", T)],
    }.items():
        for v, exc in bad:
            cases.append(pytest.param(lambda n=name, v=v: RemapTimeCourse(**{n: v}), exc, name,
                                      id=f"RemapTimeCourse-{name}={v!r}"))
    for name, bad in {
        "amplitudes_deg": [((), V), ((NAN,), V), ((0,), V), ((-5,), V), ((1e9,), V), (("12",), T), (12, T),
                           ("12", T), ((INF,), V), ((None,), T)],
        "flash_times_ms": [((0.5,), V), ((NAN,), V), ((1e9,), V), (("0",), T), ((), V), (0, T), ((INF,), V)],
        "repetitions": [(0, V), (2.5, V), (1e9, V), ("1", T), (True, T), (NAN, V), (-1, V)],
        "seed": [(-1, V), (2**40, V), (1.5, V), ("0", T), (NAN, V)],
        "flash_offsets_deg": [(((NAN, 0.0),), V), (((1.0,),), V), (((1.0, 2.0, 3.0),), V), ("ab", T), ((), V),
                              (((1e9, 0.0),), V), (((100.0, 0.0),), V), ((("a", 0.0),), T)],
        "name": [(3, T), (None, T)],
    }.items():
        for v, exc in bad:
            cases.append(pytest.param(lambda n=name, v=v: Design(**{n: v}), exc, name, id=f"Design-{name}={v!r}"))
    cases.append(pytest.param(lambda: Design(repetitions=1000), ValueError, "trials", id="Design-too-many-trials"))
    tc = RemapTimeCourse()
    cases += [pytest.param(lambda: tc.gain(NAN), ValueError, "t_ms", id="gain(nan)"),
              pytest.param(lambda: tc.gain([0, INF]), ValueError, "t_ms", id="gain([0, inf])"),
              pytest.param(lambda: tc.gain("abc"), TypeError, "t_ms", id="gain('abc')"),
              pytest.param(lambda: tc.compression(NAN), ValueError, "t_ms", id="compression(nan)")]
    return cases


def _run_cases():
    from experiments.psychophysics import Design, TrialConfig, run_trials

    d = Design(amplitudes_deg=(16.0,), flash_offsets_deg=((8.0, 3.0),), flash_times_ms=(0,))
    c = TrialConfig(image_size=32)
    V, T = ValueError, TypeError
    cases = []
    for kw, exc, word in [(dict(workers=0), V, "workers"), (dict(workers=2.5), V, "workers"),
                          (dict(workers="2"), T, "workers"), (dict(workers=True), T, "workers"),
                          (dict(workers=NAN), V, "workers"), (dict(workers=10**6), V, "workers"),
                          (dict(batch_size=0), V, "batch_size"), (dict(batch_size=1.5), V, "batch_size"),
                          (dict(limit=-1), V, "limit"), (dict(limit="3"), T, "limit")]:
        cases.append(pytest.param(lambda tmp, kw=kw: run_trials(d, c, tmp / "never", progress=False, **kw), exc, word,
                                  id=f"run_trials-{kw}"))
    cases += [
        pytest.param(lambda tmp: run_trials("design", c, tmp / "never"), T, "design", id="run_trials-design-str"),
        pytest.param(lambda tmp: run_trials(d, {"image_size": 64}, tmp / "never"), T, "config",
                     id="run_trials-config-dict"),
        pytest.param(lambda tmp: run_trials(d, c, ""), V, "empty", id="run_trials-out-empty"),
        pytest.param(lambda tmp: run_trials(d, c, _file(tmp)), V, "not a folder", id="run_trials-out-file"),
        pytest.param(lambda tmp: run_trials(d, c, _file(tmp) / "x"), V, "cannot create",
                     id="run_trials-out-under-file"),
        pytest.param(lambda tmp: run_trials(d, c, 3), T, "path", id="run_trials-out-int"),
    ]
    return cases


@pytest.mark.parametrize("make, exc, word", _lib_cases())
def test_library_refuses_bad_parameters(make, exc, word):
    with pytest.raises(exc) as e:
        make()
    assert word in str(e.value)


@pytest.mark.parametrize("call, exc, word", _run_cases())
def test_run_trials_refuses_bad_arguments(tmp_path, call, exc, word):
    with pytest.raises(exc) as e:
        call(tmp_path)
    assert word in str(e.value)
    assert not (tmp_path / "never").exists()


@pytest.mark.parametrize("name", ["amplitudes_deg", "image_size", "peak_gain", "repetitions", "workers"])
def test_bounds_accept_their_ends(name):
    """The bounds themselves are valid values (closed ends) so the refusals above are not vacuous."""
    lim = LIMITS[name]
    for v in (lim.lo, lim.hi):
        closed = not ((v == lim.lo and lim.lo_open) or (v == lim.hi and lim.hi_open))
        assert lim.contains(v) == closed
