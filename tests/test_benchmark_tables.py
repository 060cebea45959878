"""The docs' batched-env speed tables (docs/batched.md) are their CSVs' rendering (``benchmarks/tables.py``), and the
renderer reads a CSV as written (numbers, the device, the code measured) or says what is wrong."""

from __future__ import annotations

import importlib.util
import json
import math
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent


def _tables():
    spec = importlib.util.spec_from_file_location("benchmark_tables", ROOT / "benchmarks" / "tables.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


tables = _tables()
HEAD = ("device,eyes,worlds,env_steps_per_s,single_env_steps_per_s,ms_per_step,host_ms,remap_ms,physics_ms,"
        "render_ms,retina_ms,dpft_ms,task_ms,host_sync_ms,memory\n")


def test_the_docs_tables_are_their_csvs():
    found = 0
    for page in [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]:
        text, where = page.read_text(), page.relative_to(ROOT)
        for name, start, end in tables.marked_tables(text):
            found += 1
            assert text[start:end] == tables.render(ROOT / name), \
                f"{where}'s table of {name} differs: python benchmarks/tables.py {where}"
    assert found, "no docs page marks a benchmark table"


def test_a_row_is_rendered_from_its_cells(tmp_path):
    p = tmp_path / "b.csv"
    p.write_text(HEAD + "NVIDIA H100 80GB HBM3,128 px per eye,4096,12971.8,54.5,315.761,118.743,30.941,152.264,"
                        "22.174,5.822,0.539,1.619,0.813,9923 MiB\n")
    lines = tables.render(p).splitlines()
    assert lines[0].startswith("| device | eyes | worlds | env-steps/s | ms/step | host |")
    assert lines[2] == "| NVIDIA H100 80GB HBM3 | 128 px per eye | 4,096 | 12,972 | 315.8 | 118.7 | 30.9 | 152.3 | 22.2 | 5.8 | 0.5 | 1.6 | 0.8 |"


def test_update_rewrites_a_stale_table_and_check_reports_it(tmp_path):
    (tmp_path / "b.csv").write_text(HEAD + "CPU backend,16 px per eye,2,1.5,3,900,1,2,3,4,5,6,7,8,1 MiB\n")
    readme = tmp_path / "README.md"
    readme.write_text("intro\n<!-- table: b.csv -->\n| old |\n<!-- end of table -->\nafter\n")
    assert tables.update(readme, check=True) == ["b.csv"]
    assert "| old |" in readme.read_text()  # --check writes nothing
    assert tables.update(readme) == ["b.csv"]
    text = readme.read_text()
    assert "| old |" not in text and "| CPU backend | 16 px per eye | 2 | 2 | 900.0 |" in text
    assert text.startswith("intro\n") and text.endswith("<!-- end of table -->\nafter\n")
    assert tables.update(readme, check=True) == []


@pytest.mark.parametrize("content, message", [
    ("device,eyes\nx,y\n", "no column worlds"),
    (HEAD, "has no rows"),
    (HEAD + "d,e,4,fast,1,1,1,1,1,1,1,1,1,1,m\n", "'fast' is not a number"),
    (HEAD + "d,e,4,nan,1,1,1,1,1,1,1,1,1,1,m\n", "not a finite number"),
])
def test_bad_csvs_are_named(tmp_path, content, message):
    p = tmp_path / "b.csv"
    p.write_text(content)
    with pytest.raises(ValueError, match=message):
        tables.render(p)


def test_missing_csv_and_unclosed_mark(tmp_path):
    with pytest.raises(ValueError, match="cannot read the benchmark CSV"):
        tables.render(tmp_path / "none.csv")
    with pytest.raises(ValueError, match="no closing"):
        tables.marked_tables("<!-- table: b.csv -->\n| x |\n")


def _rl_results():
    spec = importlib.util.spec_from_file_location("rl_results", ROOT / "benchmarks" / "rl_results.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


BASELINES_TABLE = ("agent,actions,seeds,iqm,ci_low,ci_high,mean,per_seed,mean_return,env_steps,wall_s\n"
                   "\"PPO (cortical conv, Box saccade)\",deterministic,0 1 2,0.5,0.25,0.75,0.5,0.25 0.50 0.75,0.1234,"
                   "4096 4096 4096,300 310 320\n"
                   "random (uniform cell),-,-,0.02,,,0.02,,-0.473,,\n")


def _baselines(folder, task="search"):
    folder.mkdir()
    (folder / "study.json").write_text(f'{{"version": 1, "task": "{task}", "episodes": 100, "eval_seed": 1}}')
    (folder / "table.csv").write_text(BASELINES_TABLE)
    return folder


def test_the_rl_results_table_is_written_from_baselines_folders_and_rendered(tmp_path):
    """A ``baselines`` table.csv becomes rows of the RL results CSV (the same numbers), a second folder of the
    same agents, task, engine and device replaces them, another engine adds rows; the rendering shows each."""
    rl = _rl_results()
    out = tmp_path / "rl.csv"
    table = rl.merge(out, rl.rows_from_baselines(_baselines(tmp_path / "a"), "single", "cpu", "abc123"))
    assert [(r["agent"], r["heldout_success_iqm"], r["ci_low"], r["seeds"]) for r in table] == [
        ("PPO (cortical conv, Box saccade)", "0.5", "0.25", "0 1 2"), ("random (uniform cell)", "0.02", "", "")]
    table = rl.merge(out, rl.rows_from_baselines(_baselines(tmp_path / "b"), "single", "cpu", "def456"))
    assert [r["code"] for r in table] == ["def456", "def456"]  # replaced, not appended
    table = rl.merge(out, rl.rows_from_baselines(_baselines(tmp_path / "c"), "batched", "H100", "def456"))
    assert len(table) == 4
    lines = tables.render(out).splitlines()
    assert lines[0].startswith("| task | agent | engine | device | actions | seeds |")
    assert lines[2] == ("| `search` | PPO (cortical conv, Box saccade) | single | cpu | deterministic | 0, 1, 2 | "
                        "4096, 4096, 4096 | 300, 310, 320 | 0.50 [0.25, 0.75] | 0.25, 0.50, 0.75 | +0.123 | def456 |")
    assert lines[3] == "| `search` | random (uniform cell) | single | cpu | - | - | - | - | 0.02 | - | -0.473 | def456 |"
    assert len(lines) == 6


@pytest.mark.parametrize("make, message", [
    (lambda d: d.mkdir(), "not a finished `python -m experiments baselines` folder"),
    (lambda d: (_baselines(d), (d / "table.csv").write_text("agent,iqm\nx,1\n")), "no column actions"),
    (lambda d: (_baselines(d), (d / "study.json").write_text("{")), "not a finished"),
])
def test_rl_results_refuses_what_is_not_a_baselines_folder(tmp_path, make, message):
    rl = _rl_results()
    make(tmp_path / "f")
    with pytest.raises(ValueError, match=message):
        rl.rows_from_baselines(tmp_path / "f", "single", "cpu", "abc")


def test_rl_results_refuses_a_csv_of_other_columns_and_bad_words(tmp_path):
    rl = _rl_results()
    (tmp_path / "rl.csv").write_text("device,eyes\nx,y\n")
    rows = rl.rows_from_baselines(_baselines(tmp_path / "a"), "single", "cpu", "abc")
    with pytest.raises(ValueError, match="does not have the RL results columns"):
        rl.merge(tmp_path / "rl.csv", rows)
    with pytest.raises(ValueError, match="--device must be a non-empty word"):
        rl.rows_from_baselines(tmp_path / "a", "single", "cpu, 2 cores", "abc")
    bad = tmp_path / "bad.csv"
    rl.merge(bad, rows)
    bad.write_text(bad.read_text().replace("0.5,0.25", "nan,0.25"))
    with pytest.raises(ValueError, match="not a finite number"):
        tables.render(bad)


def _train_folder(folder, success=0.14, episodes=100, engine="batched"):
    """The keys of a ``train --engine batched`` folder's ppo.json that the results row reads."""
    folder.mkdir()
    meta = {"task": "search", "engine": engine, "device": "cuda", "device_name": "NVIDIA H200", "seed": 0,
            "env_steps": 786432, "wall_s": 125.3, "final": {"success_rate": 0.19},
            "heldout_batched": {"success_rate": success, "mean_reward": -0.3095, "episodes": episodes,
                                "seed": 0, "deterministic": True}}
    (folder / "ppo.json").write_text(json.dumps(meta))
    return folder


def test_a_batched_train_folder_is_one_seeds_row_with_a_wilson_interval(tmp_path):
    """One seed: the interval is the Wilson score interval over its held-out episodes, computed here from
    Wilson's (1927) closed form: (p + z^2/2n -/+ z sqrt(p(1-p)/n + z^2/4n^2)) / (1 + z^2/n)."""
    rl = _rl_results()
    (row,) = rl.rows_from_train(_train_folder(tmp_path / "t"), "abc123", "an H200")
    p, n, z = 0.14, 100, 1.959963984540054
    centre, half = p + z * z / (2 * n), z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n))
    lo, hi = (centre - half) / (1 + z * z / n), (centre + half) / (1 + z * z / n)
    assert (row["ci_low"], row["ci_high"]) == (f"{lo:.2f}", f"{hi:.2f}") == ("0.09", "0.22")
    assert (row["seeds"], row["heldout_success_iqm"], row["engine"], row["device"]) == ("0", "0.14", "batched",
                                                                                      "NVIDIA H200")
    assert row["note"].startswith("one seed: 95 % Wilson interval over its 100 held-out episodes; an H200")
    table = rl.merge(tmp_path / "rl.csv", [row])
    assert "| `search` | PPO batched (cortical conv, cell action) | batched | NVIDIA H200 |" in tables.render(
        tmp_path / "rl.csv")
    assert len(table) == 1


@pytest.mark.parametrize("make, message", [
    (lambda d: d.mkdir(), "not a finished `python -m experiments train --engine batched` run"),
    (lambda d: (_train_folder(d), (d / "ppo.json").write_text('{"task": "search"}')), "KeyError"),
    (lambda d: _train_folder(d, success=1.5), "successes <= n"),
    (lambda d: _train_folder(d, engine="single"), "reads batched train folders"),
])
def test_rl_results_refuses_what_is_not_a_batched_train_folder(tmp_path, make, message):
    rl = _rl_results()
    make(tmp_path / "t")
    with pytest.raises(ValueError, match=message):
        rl.rows_from_train(tmp_path / "t", "abc")
