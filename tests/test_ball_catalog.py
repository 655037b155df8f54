"""The curated ball catalog: sourced spec sheets, and user-facing sources free of note tags."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest
from typer.testing import CliRunner

from bowlrec.bowling.catalog import Source, citation, internal_tags
from bowlrec.bowling.layout import BallEntry, ExampleLibrary, load_example_library
from bowlrec.bowling.legality import check_legality
from bowlrec.bowling.oil import preset, preset_names
from bowlrec.cli._app import app

LIBRARY = load_example_library()
#: the catalog's products: balls a maker sold (not illustrative, not a paper's model ball)
PRODUCTS = [
    e for e in LIBRARY.balls if not e.illustrative and e.sources[0].kind in ("review", "database")
]
#: ids that fail the current USBC rules on purpose (the 2004 paper's pre-2005 limits)
ILLEGAL_TODAY = {"frohlich-2004-low-rg-nonscalar", "frohlich-2004-high-rg-nonscalar"}
#: ids that other code, tests and examples use
STABLE_IDS = {
    "storm-the-road-15lb",
    "storm-the-road-14lb",
    "notes-example-15lb-symmetric",
    "illustrative-max-legal-asymmetric",
    "illustrative-polyester-spare",
    "frohlich-2004-low-rg-nonscalar",
    "frohlich-2004-high-rg-nonscalar",
}

_NUMBER = re.compile(r"(?<![\d.])\d*\.\d+")


def _numbers(text: str) -> list[float]:
    return [float(m) for m in _NUMBER.findall(text)]


def _quotes_rg(entry: BallEntry) -> bool:
    """The first source's quote prints the RG (in inches, or in cm for a paper)."""
    rg = entry.ball.rg_in
    return any(
        abs(x - rg) < 5e-4 or abs(x - rg * 2.54) < 5e-3 for x in _numbers(entry.sources[0].quote)
    )


# --- the catalog itself ---------------------------------------------------------------------
def test_catalog_loads_with_stable_ids_and_enough_products() -> None:
    ids = [e.id for e in LIBRARY.balls]
    assert set(ids) >= STABLE_IDS
    models = {(e.ball.brand, e.ball.name) for e in PRODUCTS}
    brands = {brand for brand, _ in models}
    assert len(models) >= 42, sorted(models)
    assert len(brands) >= 15, sorted(brands)
    assert {"Storm", "Roto Grip", "Hammer", "Brunswick", "900 Global", "Columbia 300"} <= brands
    assert {"Motiv", "Track", "Radical", "DV8", "Ebonite", "Pyramid", "AMF"} <= brands
    covers = {e.ball.coverstock for e in PRODUCTS}
    assert {
        "polyester",
        "urethane",
        "reactive_solid",
        "reactive_pearl",
        "reactive_hybrid",
        "particle",
    } <= covers
    assert {e.ball.core_type for e in PRODUCTS} == {"symmetric", "asymmetric"}


@pytest.mark.parametrize("entry", LIBRARY.balls, ids=lambda e: e.id)
def test_every_entry_is_sourced(entry: BallEntry) -> None:
    b = entry.ball
    assert b.weight_lb > 0 and b.rg_in > 0 and b.differential_in >= 0
    assert entry.year_note.strip()
    assert entry.year is None or 1960 <= entry.year <= 2030
    if entry.year is None:
        assert "not" in entry.year_note  # says that the sources do not give it
    assert entry.sources
    for s in entry.sources:
        assert s.publisher.strip() and s.title.strip()
        assert s.kind == "illustrative" or re.match(r"https?://\S+$", s.url), s
    if b.core_type == "symmetric":
        assert b.intermediate_differential_in == 0.0
    else:
        assert 0.0 < b.intermediate_differential_in <= b.differential_in
    if entry.illustrative:
        return
    first = entry.sources[0]
    assert first.kind in ("manufacturer", "review", "database", "paper", "usbc")
    assert first.url.startswith(("http://", "https://"))
    assert _quotes_rg(entry), (entry.id, b.rg_in, first.quote)
    if first.kind != "paper":  # a paper prints three RGs, not a differential
        assert any(abs(x - b.differential_in) < 5e-4 for x in _numbers(first.quote)), first.quote
        if "weight_lb" not in entry.assumed:
            assert f"{b.weight_lb:g}" in " ".join(s.quote for s in entry.sources)
    if entry.assumed:
        assert "assum" in entry.note


def test_reviews_are_marked_and_assumptions_declared() -> None:
    reviews_only = [e for e in PRODUCTS if e.second_hand == "review"]
    assert reviews_only, "specs found only in reviews are marked"
    for e in reviews_only:
        assert all(s.kind != "manufacturer" for s in e.sources)
        assert "(review)" in e.source
    # the sources do not name the weight for most magazine reviews: that must be declared
    iq = next(e for e in LIBRARY.balls if e.id == "storm-iq-15lb")
    assert "weight_lb" in iq.assumed
    # where sources disagree, the note says so
    road = next(e for e in LIBRARY.balls if e.id == "storm-the-road-15lb")
    assert "disagree" in road.note and "2.55" in road.note and "DNA Coil" in road.note
    assert {s.kind for s in road.sources} == {"review", "database"}
    assert road.second_hand == "review"
    databases = [e for e in PRODUCTS if e.second_hand == "database"]
    assert databases and all("(spec database)" in e.source for e in databases)


def test_the_road_carries_its_own_numbers_not_the_dna_coils() -> None:
    """Two sources give The Road a symmetric 2.55 / 0.045 core; 2.47 / .053 / .023 is the DNA Coil
    II's spec, which a review of The Road prints."""
    by_id = {e.id: e for e in LIBRARY.balls}
    for weight in (15, 14):
        road = by_id[f"storm-the-road-{weight}lb"]
        b = road.ball
        assert (b.weight_lb, b.rg_in, b.differential_in) == (weight, 2.55, 0.045)
        assert b.core_type == "symmetric" and b.intermediate_differential_in == 0.0
        publishers = [s.publisher for s in road.sources]
        assert "Bowling This Month" in publishers
        assert any(p.startswith("bowwwl.com") for p in publishers)
    coil = by_id["storm-dna-coil-ii-15lb"].ball
    assert (coil.rg_in, coil.differential_in, coil.intermediate_differential_in) == (
        2.47,
        0.053,
        0.023,
    )


def test_github_tables_are_marked_as_spec_databases() -> None:
    """A table found in a public repository is a third-party database, never the maker."""
    github = [s for e in LIBRARY.balls for s in e.sources if "github.com" in s.url]
    assert len(github) >= 20
    for s in github:
        assert s.kind == "database", s
        assert s.quote and "/blob/" in s.url, s


@pytest.mark.parametrize("entry", LIBRARY.balls, ids=lambda e: e.id)
def test_usbc_legality_is_as_expected(entry: BallEntry) -> None:
    current = check_legality(entry.ball, "current")
    assert current.is_legal is (entry.id not in ILLEGAL_TODAY), str(current)
    assert check_legality(entry.ball, "paper_era").is_legal


def test_the_models_reject_unsourced_or_unexplained_entries() -> None:
    good = next(e for e in LIBRARY.balls if e.id == "storm-crux-15lb").model_dump(mode="json")
    no_quote = json.loads(json.dumps(good))
    no_quote["sources"][0]["quote"] = ""
    with pytest.raises(ValueError, match="quote"):
        BallEntry.model_validate(no_quote)
    unexplained = json.loads(json.dumps(good))
    unexplained["assumed"] = ["surface"]
    with pytest.raises(ValueError, match="note"):
        BallEntry.model_validate(unexplained)
    with pytest.raises(ValueError, match="http"):
        Source(kind="review", publisher="p", title="t", url="ftp://x")
    with pytest.raises(ValueError, match="url"):
        Source(kind="manufacturer", publisher="p", title="t")
    assert citation(Source(kind="review", publisher="P", title="T", url="https://x.org")) == (
        "P — T — https://x.org (review)"
    )


# --- no note tags in user-facing text ---------------------------------------------------------
def test_the_tag_finder_finds_tags() -> None:
    for bad in ("[TAMER]", "[F04] Table III", "[BBC-PAP2]", "domain-notes", "Sec. 1.1", "§6.2"):
        assert internal_tags(f"x {bad} y"), bad
    assert internal_tags("Frohlich (2004), Table III, https://doi.org/10.1119/1.1767099") == []


def _library_texts(lib: ExampleLibrary) -> list[str]:
    texts = [lib.description]
    for e in lib.balls:
        texts += [e.note, e.year_note, e.source]
        texts += [s.quote for s in e.sources]
    for group in (lib.layouts, lib.paps, lib.static_weights):
        texts += [e.source for e in group] + [e.note for e in group]
    return texts


def test_data_files_carry_no_note_tags() -> None:
    for text in _library_texts(LIBRARY):
        assert internal_tags(text) == [], text
    for name in preset_names():
        assert internal_tags(preset(name).source) == [], name
    raw = (Path(__file__).parents[1] / "bowlrec" / "bowling" / "data" / "balls.json").read_text()
    assert internal_tags(raw) == []


def _cli_outputs() -> dict[str, str]:
    runner = CliRunner()
    commands = [["sheet"], ["patterns"], ["patterns", "--json"]]
    commands += [["sheet", e.id] for e in LIBRARY.balls]
    commands += [["patterns", name] for name in preset_names()]
    out = {}
    for args in commands:
        result = runner.invoke(app, args)
        assert result.exit_code == 0, (args, result.output)
        out[" ".join(args)] = result.stdout
    return out


def test_cli_output_cites_publishers_not_tags(tmp_path: Path) -> None:
    outputs = _cli_outputs()
    for command, text in outputs.items():
        assert internal_tags(text) == [], (command, internal_tags(text))
    road = outputs["sheet storm-the-road-15lb"]
    assert "sources:" in road
    assert "Bowling This Month — Storm The Road" in road
    assert "https://www.bowlingthismonth.com/bowling-ball-review/storm-the-road/ (review)" in road
    assert "maker's own spec sheet was not read" in road
    paper = outputs["sheet frohlich-2004-high-rg-nonscalar"]
    assert "https://doi.org/10.1119/1.1767099 (paper)" in paper
    assert "(review)" not in paper
    big_ben = json.loads(outputs["patterns kegel_big_ben"])
    assert "https://www.kegel.net" in big_ben["source"]
    runner = CliRunner()
    arch = str(tmp_path / "arch")
    added = runner.invoke(app, ["balls", "add-examples", "-a", arch])
    assert added.exit_code == 0, added.output
    listed = runner.invoke(app, ["balls", "list", "-a", arch, "--json"])
    assert listed.exit_code == 0, listed.output
    notes = [row["note"] for row in json.loads(listed.stdout)]
    assert len(notes) == len(LIBRARY.balls)
    for note in notes:
        assert internal_tags(note) == [] and note.strip()
