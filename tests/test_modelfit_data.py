"""experiments.modelfit.data: what labs really send (issue 21, item 5).

Each hostile file is one test: a ``DataFormatError`` whose message names the file, the row (the
header is row 1) and the column; each convention that cannot be decided from the file is a
``DataConventionWarning``. Positive cases: a BOM file reads like a plain one, the bundled example and
a ``python -m experiments run`` trials table read. ``read_data`` only: no rendering.
"""

from __future__ import annotations

import csv
import math
import os
import re
import warnings
from pathlib import Path

import numpy as np
import pytest

from experiments.modelfit import DataConventionWarning, DataFormatError, read_data
from experiments.psychophysics.runner import TABLE_COLUMNS

pytestmark = pytest.mark.adversarial

REQ = ["saccade_amplitude_deg", "flash_time_ms", "true_x_deg", "true_y_deg", "perceived_x_deg", "perceived_y_deg"]
ROWS = [[20, -50, 12, 3, 11.5, 2.5], [16, 0, 4, -3, 5, -2], [20, 50, 8, 1, 9, 1.5], [24, 100, 14, -4, 13, -3.5]]
EXAMPLE = Path(__file__).resolve().parents[1] / "experiments" / "data" / "example_localization.csv"


def _csv(path, header, rows, *, bom=False, newline="\r\n"):
    """Rows written as given (strings verbatim), like a spreadsheet export."""
    text = newline.join(",".join(str(v) for v in r) for r in [header, *rows]) + newline
    path.write_bytes((b"\xef\xbb\xbf" if bom else b"") + text.encode())
    return path


def _parquet(path, cols, schema=None):
    import pyarrow as pa
    import pyarrow.parquet as pq

    pq.write_table(pa.table(cols, schema=schema), path)
    return path


def _cols(header=REQ, rows=ROWS):
    return {h: [r[j] for r in rows] for j, h in enumerate(header)}


def _read_quietly(path):
    with warnings.catch_warnings():
        warnings.simplefilter("error", DataConventionWarning)
        return read_data(path)


def _fails(path, row=None, column=None, *also):
    """read_data(path) raises DataFormatError naming the file, the row and the column (and ``also``)."""
    with pytest.raises(DataFormatError) as ei:
        _read_quietly(path)
    msg = str(ei.value)
    assert str(path) in msg, msg
    if row is not None:
        assert re.search(rf"\b(rows?|line)\b[^;]*?\b{row}\b", msg), (row, msg)
    if column is not None:
        assert re.search(rf"\b{re.escape(column)}\b", msg), (column, msg)
    for s in also:
        assert s.lower() in msg.lower(), (s, msg)
    return msg


def _same(a, b):
    for f in ("amplitude_deg", "flash_time_ms", "true_deg", "perceived_deg", "condition", "n"):
        assert np.array_equal(getattr(a, f), getattr(b, f)), f
    assert np.array_equal(a.sd_deg, b.sd_deg, equal_nan=True)


# ---------------------------------------------------------------------------------------------- encoding, header
def test_bom_file_reads_like_a_plain_one(tmp_path):
    plain = _read_quietly(_csv(tmp_path / "plain.csv", REQ, ROWS))
    _same(plain, _read_quietly(_csv(tmp_path / "bom.csv", REQ, ROWS, bom=True)))
    _same(plain, _read_quietly(_csv(tmp_path / "lf.csv", REQ, ROWS, bom=True, newline="\n")))


def test_header_names_with_surrounding_spaces_are_read(tmp_path):
    plain = _read_quietly(_csv(tmp_path / "plain.csv", REQ, ROWS))
    spaced = [f" {h}\t" if j % 2 else f"{h} " for j, h in enumerate(REQ)]
    _same(plain, _read_quietly(_csv(tmp_path / "spaced.csv", spaced, ROWS, bom=True)))
    _same(plain, _read_quietly(_parquet(tmp_path / "spaced.parquet", _cols(spaced))))


def test_missing_column_names_the_header_row_and_a_case_hint(tmp_path):
    header = [h.title() if h == "flash_time_ms" else h for h in REQ]
    _fails(_csv(tmp_path / "d.csv", header, ROWS), 1, "flash_time_ms", "missing column", "case-sensitive")


def test_semicolon_separated_header(tmp_path):
    p = tmp_path / "d.csv"
    p.write_text(";".join(REQ) + "\n" + "\n".join(";".join(str(v).replace(".", ",") for v in r) for r in ROWS) + "\n")
    _fails(p, 1, None, "';'", "comma")


def test_first_row_of_numbers_is_not_a_header(tmp_path):
    p = tmp_path / "d.csv"
    p.write_text("\n".join(",".join(map(str, r)) for r in ROWS) + "\n")
    _fails(p, 1, "saccade_amplitude_deg", "header")


def test_a_column_named_twice(tmp_path):
    _fails(_csv(tmp_path / "d.csv", REQ + ["true_x_deg"], [r + [1] for r in ROWS]), None, "true_x_deg", "twice")


def test_repeated_header_line_inside_the_data(tmp_path):
    _fails(_csv(tmp_path / "d.csv", REQ, ROWS[:2] + [REQ] + ROWS[2:]), 4, "saccade_amplitude_deg", "header")


# ---------------------------------------------------------------------------------------------- row structure
def test_rows_with_extra_fields(tmp_path):
    rows = [list(r) for r in ROWS]
    rows[1] = [16, 0, 4, -3, 5, -2, 7]
    rows[3] = rows[3] + ["x"]
    _fails(_csv(tmp_path / "d.csv", REQ, rows), 3, "perceived_y_deg", "more fields", "rows 3, 5")


def test_empty_trailing_fields_and_blank_rows_are_tolerated(tmp_path):
    """A trailing comma, a row of empty fields and a blank line (spreadsheet exports) are not data;
    row numbers still count them, as a spreadsheet does."""
    p = tmp_path / "d.csv"
    lines = [",".join(REQ), ",".join(map(str, ROWS[0])) + ",", ",,,,,", "", ",".join(map(str, ROWS[1])),
             "20,0,2,3,x,1"]
    p.write_text("\n".join(lines) + "\n")
    _fails(p, 6, "perceived_x_deg", "not numbers")
    p.write_text("\n".join(lines[:-1]) + "\n")
    assert len(_read_quietly(p)) == 2


def test_rows_with_missing_fields(tmp_path):
    rows = [list(r) for r in ROWS]
    rows[2] = rows[2][:4]
    _fails(_csv(tmp_path / "d.csv", REQ, rows), 4, "perceived_x_deg", "fewer fields")


def test_field_over_the_csv_size_limit_names_the_row(tmp_path):
    """An unclosed quote swallows the rest of the file into one field: the row and column where it
    opened, not a csv.Error traceback."""
    p = tmp_path / "d.csv"
    filler = "\n".join(",".join(map(str, ROWS[k % 4])) for k in range(30_000))
    p.write_text(",".join(REQ) + "\n" + ",".join(map(str, ROWS[0])) + "\n" + '20,0,2,3,"4,1\n' + filler + "\n")
    assert len(p.read_text()) > csv.field_size_limit()
    _fails(p, 3, "perceived_x_deg", "quote")


def test_one_huge_field_names_the_row(tmp_path):
    rows = [list(r) for r in ROWS]
    rows[1][1] = "1" * (csv.field_size_limit() + 10)
    _fails(_csv(tmp_path / "d.csv", REQ, rows), 3, "flash_time_ms")


def test_header_only(tmp_path):
    _fails(_csv(tmp_path / "d.csv", REQ, []), None, None, "no data rows")


# ---------------------------------------------------------------------------------------------- values
@pytest.mark.parametrize("value", ["inf", "nan", "-inf", "NaN", "1e400", "-0.5", "200", "NA"])
def test_sd_must_be_finite_and_non_negative(tmp_path, value):
    header = REQ + ["n", "sd_x_deg", "sd_y_deg"]
    rows = [r + [5, 0.7, 0.6] for r in ROWS]
    rows[2][-2] = value
    _fails(_csv(tmp_path / "d.csv", header, rows), 4, "sd_x_deg")


def test_blank_sd_means_not_given(tmp_path):
    header = REQ + ["n", "sd_x_deg", "sd_y_deg"]
    rows = [r + [5, 0.7, 0.6] for r in ROWS]
    rows[1][-2:] = ["", " "]
    d = _read_quietly(_csv(tmp_path / "d.csv", header, rows))
    assert np.isnan(d.sd_deg[1]).all() and d.sd_deg[0] == pytest.approx([0.7, 0.6])


def test_nan_sd_in_parquet_is_an_error_null_is_not_given(tmp_path):
    cols = _cols() | {"n": [5] * 4, "sd_x_deg": [0.7, None, 0.5, 0.5], "sd_y_deg": [0.6, None, 0.5, 0.5]}
    assert np.isnan(_read_quietly(_parquet(tmp_path / "ok.parquet", cols)).sd_deg[1]).all()
    cols["sd_y_deg"] = [0.6, None, 0.5, float("nan")]
    _fails(_parquet(tmp_path / "nan.parquet", cols), 5, "sd_y_deg", "empty")


def test_sd_needs_n_of_two(tmp_path):
    _fails(_csv(tmp_path / "d.csv", REQ + ["sd_x_deg"], [r + [0.5] for r in ROWS]), 2, "sd_x_deg", "n >= 2")


@pytest.mark.parametrize("value", ["1e400", str(10**30), str(10**9 + 1), "2.5", "0", "-3", "inf", ""])
def test_n_overflow_and_bounds(tmp_path, value):
    rows = [r + [2] for r in ROWS]
    rows[3][-1] = value
    msg = _fails(_csv(tmp_path / "d.csv", REQ + ["n"], rows), 5, "n")
    assert "10**9" in msg or value == ""


def test_n_overflow_in_parquet(tmp_path):
    _fails(_parquet(tmp_path / "d.parquet", _cols() | {"n": [1.0, 1e30, 1.0, 1.0]}), 3, "n", "10**9")


def test_n_at_the_bound_reads(tmp_path):
    d = _read_quietly(_csv(tmp_path / "d.csv", REQ + ["n"], [r + [10**9] for r in ROWS]))
    assert d.n.dtype == np.int64 and d.n_observations == 4 * 10**9


def test_not_numbers_and_a_decimal_comma(tmp_path):
    rows = [list(r) for r in ROWS]
    rows[0][4] = '"11,5"'
    _fails(_csv(tmp_path / "d.csv", REQ, rows), 2, "perceived_x_deg", "not numbers", "decimal comma")
    rows[0][4] = "11.5 deg"
    _fails(_csv(tmp_path / "u.csv", REQ, rows), 2, "perceived_x_deg", "no units")


def test_empty_required_cell(tmp_path):
    rows = [list(r) for r in ROWS]
    rows[1][2] = ""
    _fails(_csv(tmp_path / "d.csv", REQ, rows), 3, "true_x_deg", "empty")


def test_nan_report_says_to_drop_the_row(tmp_path):
    rows = [list(r) for r in ROWS]
    rows[2][5] = "nan"
    _fails(_csv(tmp_path / "d.csv", REQ, rows), 4, "perceived_y_deg", "delete its row")


@pytest.mark.parametrize("col,value", [("saccade_amplitude_deg", 0), ("saccade_amplitude_deg", 60),
                                        ("flash_time_ms", 0.5), ("flash_time_ms", 5000), ("true_y_deg", -200),
                                        ("perceived_x_deg", 1e6), ("condition", "dusk"), ("condition", "")])
def test_existing_range_checks_are_kept(tmp_path, col, value):
    header = REQ + ["condition"]
    rows = [r + ["dark"] for r in ROWS]
    rows[1][header.index(col)] = value
    _fails(_csv(tmp_path / "d.csv", header, rows), 3, col)


def test_condition_ignores_case_and_spaces(tmp_path):
    d = _read_quietly(_csv(tmp_path / "d.csv", REQ + ["condition"], [r + [c] for r, c in
                                                                      zip(ROWS, ["Dark", " references ", "DARK", "dark"])]))
    assert list(d.condition) == ["dark", "references", "dark", "dark"]


def test_duplicated_rows_name_both_rows(tmp_path):
    rows = [ROWS[0], ROWS[1], ROWS[2], ROWS[1]]
    msg = _fails(_csv(tmp_path / "d.csv", REQ, rows), 3, "perceived_y_deg",
                 "aggregate them into one row with n")
    assert "rows 3 and 5" in msg


def test_rows_differing_only_in_another_column_are_not_duplicates(tmp_path):
    rows = [ROWS[0] + [0], ROWS[0] + [1], ROWS[1] + [2]]  # two trials with identical values, distinct ids
    assert len(_read_quietly(_csv(tmp_path / "d.csv", REQ + ["trial_id"], rows))) == 3


# ---------------------------------------------------------------------------------------------- the file itself
def test_a_directory(tmp_path):
    _fails(tmp_path, None, None, "directory")


def test_an_unreadable_file(tmp_path, monkeypatch):
    p = _csv(tmp_path / "d.csv", REQ, ROWS)
    p.chmod(0)
    try:
        if os.access(p, os.R_OK):  # root reads anything: make the read fail as it would for a user
            def deny(self):
                raise PermissionError(13, "Permission denied", str(self))
            monkeypatch.setattr(Path, "read_bytes", deny)
        _fails(p, None, None, "permission denied")
    finally:
        p.chmod(0o644)


def test_binary_garbage(tmp_path):
    p = tmp_path / "d.csv"
    p.write_bytes(bytes(range(256)) * 4)
    _fails(p, None, None, "binary")
    p.write_bytes(b"\xff\xfe\x00garbage")  # UTF-16 (Excel's "Unicode Text")
    _fails(p, None, None, "UTF-16")


def test_not_utf8_names_the_line_and_column(tmp_path):
    p = tmp_path / "d.csv"
    p.write_bytes((",".join(REQ + ["note"]) + "\n" + "\n".join(",".join(map(str, r + ["ok"])) for r in ROWS)
                   + "\n").encode() + b"20,0,2,3,4,1,caf\xe9\n")
    _fails(p, 6, "note", "UTF-8")


def test_an_excel_workbook_or_a_parquet_file_named_csv(tmp_path):
    p = tmp_path / "d.csv"
    p.write_bytes(b"PK\x03\x04" + b"\x14" * 40)
    _fails(p, None, None, "Excel")
    _parquet(tmp_path / "q.parquet", _cols())
    p.write_bytes((tmp_path / "q.parquet").read_bytes())
    _fails(p, None, None, "rename it to d.parquet")


def test_an_empty_file(tmp_path):
    for name in ("d.csv", "d.parquet"):
        (tmp_path / name).touch()
        _fails(tmp_path / name, None, None, "0 bytes")


def test_whitespace_only_file_has_no_header(tmp_path):
    p = tmp_path / "d.csv"
    p.write_text("\n\n")
    _fails(p, None, None, "no header")


# ---------------------------------------------------------------------------------------------- parquet
def test_parquet_with_zero_rows(tmp_path):
    import pyarrow as pa

    schema = pa.schema([(c, pa.float64()) for c in REQ])
    _fails(_parquet(tmp_path / "d.parquet", {c: [] for c in REQ}, schema), None, None, "no data rows")


def test_parquet_with_no_columns(tmp_path):
    _fails(_parquet(tmp_path / "d.parquet", {}), None, None, "no columns")


def test_unreadable_parquet(tmp_path):
    p = tmp_path / "d.parquet"
    p.write_text(",".join(REQ) + "\n1,2,3,4,5,6\n")
    _fails(p, None, None, "Parquet")
    good = _parquet(tmp_path / "g.parquet", _cols()).read_bytes()
    p.write_bytes(good[: len(good) // 2])  # truncated
    _fails(p, None, None, "Parquet")


def test_parquet_strings_where_numbers_are_expected(tmp_path):
    cols = _cols()
    cols["true_y_deg"] = [str(v) for v in cols["true_y_deg"]]  # numbers as strings: read like CSV cells
    _same(_read_quietly(_csv(tmp_path / "d.csv", REQ, ROWS)), _read_quietly(_parquet(tmp_path / "s.parquet", cols)))
    cols["true_y_deg"][1] = "three"
    _fails(_parquet(tmp_path / "d.parquet", cols), 3, "true_y_deg", "not numbers")


def test_parquet_booleans_and_timestamps_are_not_numbers(tmp_path):
    import datetime

    cols = _cols()
    cols["flash_time_ms"] = [True, False, True, False]
    _fails(_parquet(tmp_path / "b.parquet", cols), 2, "flash_time_ms", "bool")
    cols["flash_time_ms"] = [datetime.datetime(2024, 1, 1)] * 4
    _fails(_parquet(tmp_path / "t.parquet", cols), 2, "flash_time_ms", "datetime")


def test_parquet_null_in_a_required_column(tmp_path):
    cols = _cols()
    cols["perceived_x_deg"][3] = None
    _fails(_parquet(tmp_path / "d.parquet", cols), 5, "perceived_x_deg", "empty")


# ---------------------------------------------------------------------------------------------- conventions
def _warns(path, *also):
    with pytest.warns(DataConventionWarning) as rec:
        d = read_data(path)
    msgs = " | ".join(str(w.message) for w in rec if issubclass(w.category, DataConventionWarning))
    for s in also:
        assert s in msgs, (s, msgs)
    assert issubclass(DataConventionWarning, UserWarning)
    return d


def test_amplitudes_that_look_like_radians_warn(tmp_path):
    rows = [[round(math.radians(r[0]), 4)] + r[1:] for r in ROWS]
    d = _warns(_csv(tmp_path / "d.csv", REQ, rows), "saccade_amplitude_deg < 1", "radians", "read as degrees")
    assert d.amplitude_deg.max() < 1


def test_flash_times_that_look_like_seconds(tmp_path):
    rows = [r[:1] + [t] + r[2:] for r, t in zip(ROWS, [-1, 0, 1, 0])]
    _warns(_csv(tmp_path / "w.csv", REQ, rows), "flash_time_ms within [-1, 1]", "seconds", "milliseconds")
    rows = [r[:1] + [t] + r[2:] for r, t in zip(ROWS, [-0.05, 0, 0.05, 0.1])]  # not whole ms: an error that says so
    _fails(_csv(tmp_path / "e.csv", REQ, rows), 2, "flash_time_ms", "seconds", "multiply by 1000")


def test_every_flash_left_of_straight_ahead_warns(tmp_path):
    rows = [r[:2] + [-r[2]] + r[3:4] + [-r[4]] + r[5:] for r in ROWS]  # a leftward saccade, not mirrored
    _warns(_csv(tmp_path / "d.csv", REQ, rows), "every true_x_deg < 0", "mirror", "+A/2")


def test_anti_correlated_reports_warn(tmp_path):
    rng = np.random.default_rng(0)
    rows = []
    for k in range(12):
        tx, ty = float(rng.uniform(2, 18)), float(rng.uniform(-6, 6))
        rows.append([20, 10 * k, round(tx, 3), round(ty, 3), round(tx + 0.3, 3), round(-ty + 0.1, 3)])
    _warns(_csv(tmp_path / "d.csv", REQ, rows), "perceived_y_deg falls as true_y_deg rises")


# ---------------------------------------------------------------------------------------------- files that read
def test_the_bundled_example_reads_without_warnings():
    d = _read_quietly(EXAMPLE)
    assert len(d) == 576 and d.n_observations == 576 and set(d.condition) == {"references", "dark"}


def test_a_run_trials_table_reads(tmp_path):
    """The columns of ``python -m experiments run``'s trials.csv (many more than the format's, NaN in
    those that do not apply, CRLF): read as they are."""
    rows = []
    for k, (a, t, tx, ty, px, py) in enumerate(ROWS):
        row = {c: "nan" for c in TABLE_COLUMNS}
        row.update(trial_id=k, repetition=0, seed=k, saccade_amplitude_deg=a, flash_time_ms=t, flash_dx_deg=tx - a / 2,
                   flash_dy_deg=ty, true_x_deg=tx, true_y_deg=ty, perceived_x_deg=repr(px + 1e-9),
                   perceived_y_deg=py, model="mechanistic", condition="dark" if k % 2 else "references",
                   paradigm="localization", config_hash="49b76fb9cb1c", row_crc32="098e0e0e")
        rows.append([row[c] for c in TABLE_COLUMNS])
    d = _read_quietly(_csv(tmp_path / "trials.csv", list(TABLE_COLUMNS), rows))
    assert len(d) == 4 and list(d.condition) == ["references", "dark", "references", "dark"]
    assert d.perceived_deg[:, 0] == pytest.approx([r[4] for r in ROWS])


# ---------------------------------------------------------------------------------------------- 1-D localization
def test_one_dimensional_rows_read_with_an_empty_perceived_y(tmp_path):
    """Studies that measured only the error along the saccade (e.g. Honda 1989; Lappe, Awater &
    Krekelberg 2000, Fig. 2) leave ``perceived_y_deg`` empty: the row reads, with y unmeasured."""
    rows = [list(r) for r in ROWS]
    rows[0][5] = rows[2][5] = ""
    data = _read_quietly(_csv(tmp_path / "d.csv", REQ, rows))
    assert data.measured.tolist() == [[True, False], [True, True], [True, False], [True, True]]
    assert data.perceived_deg[1, 1] == -2 and math.isnan(data.perceived_deg[0, 1])
    # a 1-D row has no SD across either
    header = REQ + ["n", "sd_x_deg", "sd_y_deg"]
    rows = [r + [4, 1.0, 1.0] for r in rows]
    rows[0][-1] = rows[2][-1] = ""
    assert _read_quietly(_csv(tmp_path / "ok.csv", header, rows)).measured[0].tolist() == [True, False]
    rows[2][-1] = "1.0"
    _fails(_csv(tmp_path / "bad.csv", header, rows), 4, "sd_y_deg", "empty where perceived_y_deg is")
    # an empty perceived_x_deg is still an error: every row reports along the saccade
    rows = [list(r) for r in ROWS]
    rows[1][4] = ""
    _fails(_csv(tmp_path / "x.csv", REQ, rows), 3, "perceived_x_deg")


def test_one_dimensional_likelihood_uses_x_alone():
    """The log-likelihood of data with 1-D rows is the sum of the Gaussian log-densities of the
    reports that were measured (a direct sum with scipy.stats.norm), whatever the model predicts
    across on those rows; the noise MLE across uses the 2-D rows only, and with no y at all
    ``noise_y_deg`` is held at its default."""
    from scipy.stats import norm

    from experiments.modelfit.data import LocalizationData
    from experiments.modelfit.likelihood import FIT_MODELS, Evaluator

    perceived = np.array([[11.5, np.nan], [5.0, -2.0], [9.0, np.nan], [13.0, -3.5]])
    data = LocalizationData(np.array([20.0, 16, 20, 24]), np.array([-50, 0, 50, 100]),
                            np.array([[12.0, 3], [4, -3], [8, 1], [14, -4]]), perceived,
                            np.array(["references"] * 4), np.array([1, 2, 1, 3]), np.full((4, 2), np.nan))
    ev = Evaluator(FIT_MODELS["paper"], data, {}, {}, np.arange(4))
    pred = np.array([[11.0, 5.0], [4.5, -1.0], [9.5, 99.0], [12.0, -3.0]])
    ev.predict = lambda values: pred
    v = {"noise_x_deg": 0.8, "noise_y_deg": 1.5}
    n = data.n.astype(float)
    want = sum(norm.logpdf(perceived[i, 0], pred[i, 0], 0.8 / math.sqrt(n[i])) for i in range(4))
    want += sum(norm.logpdf(perceived[i, 1], pred[i, 1], 1.5 / math.sqrt(n[i])) for i in (1, 3))
    assert ev.log_likelihood(v) == pytest.approx(want, rel=1e-12)
    pred[2, 1] = -50.0  # a prediction across on a 1-D row changes nothing
    assert ev.log_likelihood(v) == pytest.approx(want, rel=1e-12)
    s = ev.noise_mle(v)
    assert s["noise_y_deg"] == pytest.approx(math.sqrt((2 * 1.0**2 + 3 * 0.5**2) / 2))
    x_only = dataclasses_replace(data, perceived_deg=np.column_stack([perceived[:, 0], np.full(4, np.nan)]))
    ev2 = Evaluator(FIT_MODELS["paper"], x_only, {}, {}, np.arange(4))
    ev2.predict = lambda values: pred
    assert ev2.noise_mle(v)["noise_y_deg"] == 1.0  # not identified: the default


def dataclasses_replace(obj, **kw):
    import dataclasses

    return dataclasses.replace(obj, **kw)
