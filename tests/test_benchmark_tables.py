"""The docs' batched-env speed tables (docs/batched.md) are their CSVs' rendering (``benchmarks/tables.py``), and the
renderer reads a CSV as written (numbers, the device, the code measured) or says what is wrong."""

from __future__ import annotations

import importlib.util
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
