"""The docs' table of public real recordings (``experiments.oculomotor.recordings``): its tables are
their CSVs' rendering, the bundled files carry their licence, and the helpers read the files as the
tracker wrote them."""

from __future__ import annotations

import csv
import math
from pathlib import Path

import pytest

from experiments.oculomotor import recordings as R

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "experiments" / "data" / "recordings"


def test_docs_tables_are_the_csvs():
    """``docs/eyetracker.md``'s recordings tables are rendered from the CSVs (rerun the module with
    ``--docs`` after changing them)."""
    assert R.update_docs(ROOT / "docs" / "eyetracker.md", check=True) == []
    text = (ROOT / "docs" / "eyetracker.md").read_text()
    for name in ("recordings.csv", "bins.csv", "saturated.csv"):
        assert f"<!-- recordings table: {name} -->" in text


def test_every_row_is_a_documented_file():
    """Each recording in the CSVs is named in the README with its source and licence; each bundled
    file has its licence beside it."""
    readme = (DATA / "README.md").read_text()
    with open(DATA / "recordings.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert rows
    for r in rows:
        stem = r["recording"].rsplit(".", 1)[0]
        assert stem.split("_")[0] in readme or stem in readme, r["recording"]
        if r["saccades"] not in ("", "0") and r["exit"] == "0":
            assert not r["at_bounds"]  # a written generator.json has nothing on a bound
    with open(DATA / "saturated.csv", newline="") as f:
        saturated = list(csv.DictReader(f))
    assert {r["recording"] for r in saturated} <= {r["recording"] for r in rows}
    for r in saturated:  # an identified fit has nothing on a bound; one on a bound is not identified
        if r["at_bounds"]:
            assert r["result"].startswith("not identified"), r
        if r["result"] == "identified":
            assert not r["at_bounds"] and r["burst_max_deg_s"] and r["burst_lag_ms"], r
    for asc in DATA.rglob("*.asc"):
        assert (asc.parent / "LICENSE.txt").is_file(), asc
        assert asc.name in readme


def test_file_events_are_the_esacc_lines_of_one_eye():
    """The binocular excerpt's own events, counted independently of the parser's split."""
    path = DATA / "pymovements" / "eyelink_binocular_example.asc"
    lines = [ln.split() for ln in path.read_text(encoding="latin-1").splitlines() if ln.startswith("ESACC")]
    for eye, letter in (("left", "L"), ("right", "R")):
        want = [(float(p[9]), float(p[10])) for p in lines if p[1] == letter]
        assert R.file_events(path, eye) == want
        assert want  # the excerpt has events of both eyes


def test_screen_from_res_gives_the_files_pixels_per_degree():
    """At the screen's centre one degree spans ``RES`` pixels: the inferred width makes the angle of one
    pixel there 1/RES deg (geometry: atan(pixel width / distance))."""
    path = DATA / "pymovements" / "eyelink_monocular_example.asc"
    w_cm, h_cm, d_cm = R.screen_from_res(path)
    assert d_cm == R.ASSUMED_DISTANCE_CM
    px_deg_x = math.degrees(math.atan(w_cm / 1280 / d_cm))
    px_deg_y = math.degrees(math.atan(h_cm / 1024 / d_cm))
    assert px_deg_x == pytest.approx(1 / 37.17, rel=2e-3)
    assert px_deg_y == pytest.approx(1 / 37.75, rel=2e-3)


def test_saturated_fit_needs_a_run_of_the_command(tmp_path):
    """Without the folder ``saccades --recording`` writes there is nothing to fit: None, no error."""
    assert R.saturated_fit(DATA / "pymovements" / "eyelink_binocular_example.asc", tmp_path) is None


def test_a_file_without_a_res_line_is_named():
    with pytest.raises(ValueError, match="RES"):
        R.screen_from_res(DATA / "pymovements" / "eyelink_monocular_no_dummy_example.asc")
