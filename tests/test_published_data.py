"""``experiments/data/published/``: every file has its provenance and loads through ``fit``'s reader
(issue 34, item 3)."""

from __future__ import annotations

import csv
import json
import shutil

import pytest

from experiments.modelfit.published import PROVENANCE_FIELDS, PUBLISHED_DIR, check, cited_papers, data_files


def test_the_published_folder_has_provenance_for_every_file():
    assert check(PUBLISHED_DIR) == []
    assert (PUBLISHED_DIR / "README.md").is_file()
    # what is in the folder is what the README says is in it
    text = (PUBLISHED_DIR / "README.md").read_text()
    files = data_files(PUBLISHED_DIR)
    if not files:
        assert "No condition-level data set" in text
    for f in files:
        assert f.name in (PUBLISHED_DIR / "sources.csv").read_text(), f


def test_every_paper_the_scoreboard_cites_has_a_sources_row():
    """Each paper of ``phenomena.ROWS``' citations (the scoreboard's published ranges) is in
    ``sources.csv``, and each row of it is cited there (no stale rows)."""
    from experiments.psychophysics.phenomena import ROWS

    cited = {p for _, source, rng, _ in ROWS.values() if rng is not None for p in cited_papers(source)}
    rows = list(csv.DictReader((PUBLISHED_DIR / "sources.csv").open(encoding="utf-8")))
    listed = {r["paper"] for r in rows}
    assert cited - listed == set(), "papers the scoreboard cites without a row in sources.csv"
    assert listed - cited == set(), "rows of sources.csv that the scoreboard no longer cites"
    for r in rows:  # the figure or abstract the scoreboard names is the one the table names
        sources = [s for _, s, rng, _ in ROWS.values() if rng is not None and r["paper"] in cited_papers(s)]
        places = {part.strip()[len(r["paper"]):].strip(" ,") for s in sources for part in s.split(";")
                  if part.strip().startswith(r["paper"])}
        for place in places - {""}:
            assert place in r["cited_at"], (r["paper"], place, r["cited_at"])


def test_cited_papers_parses_the_scoreboards_citations():
    assert cited_papers("Honda 1989, abstract; Honda 1991") == ["Honda 1989", "Honda 1991"]
    assert cited_papers("Kaiser & Lappe 2004, Fig. 3") == ["Kaiser & Lappe 2004"]
    assert cited_papers("Reeve, Clark & O'Regan 2008, abstract") == ["Reeve, Clark & O'Regan 2008"]
    assert cited_papers("none found") == []


@pytest.mark.adversarial
def test_the_check_finds_files_without_provenance(tmp_path):
    """A planted data file without a sidecar, a sidecar missing fields, a file fit's reader refuses,
    an orphan sidecar and a damaged sources table are each reported; a complete one is not."""
    folder = tmp_path / "published"
    shutil.copytree(PUBLISHED_DIR, folder)
    example = PUBLISHED_DIR.parent / "example_localization.csv"
    good = {f: f"the {f}" for f in PROVENANCE_FIELDS}
    shutil.copy(example, folder / "good.csv")
    (folder / "good.json").write_text(json.dumps(good))
    assert check(folder) == []
    shutil.copy(example, folder / "bare.csv")
    (folder / "partial.csv").write_text(example.read_text())
    (folder / "partial.json").write_text(json.dumps({**good, "licence": " ", "method": None}))
    (folder / "broken.csv").write_text("saccade_amplitude_deg,flash_time_ms\n20,0\n")
    (folder / "broken.json").write_text(json.dumps(good))
    (folder / "orphan.json").write_text(json.dumps(good))
    problems = "\n".join(check(folder))
    assert "bare.csv: no provenance sidecar" in problems
    assert "partial.json: provenance field(s) method, licence missing or empty" in problems
    assert "broken.csv: fit's reader refuses it" in problems
    assert "orphan.json: a sidecar without its data file" in problems
    assert "good" not in problems
    (folder / "sources.csv").write_text("paper,reports\nHonda 1989,x\n")
    assert any("columns paper, reports" in p for p in check(folder))
    (folder / "sources.csv").unlink()
    assert any("sources.csv: missing" in p for p in check(folder))
