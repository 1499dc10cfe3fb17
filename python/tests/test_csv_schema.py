"""CSV files written from Python start with the schema line of every brachia CSV file
(``# brachia KIND schema N``, KIND the file name without ``.csv``; docs/formats.md), and brachia's
readers take them back: the benchmark's ``runs.csv`` of ``brachia.benchmark`` as the examples write it,
the training curve of ``train_ppo.py``, and every CSV file kept under python/examples."""

import csv
import json
import re
import sys
from pathlib import Path

import pytest

import brachia

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
SCHEMA_LINE = re.compile(r"# brachia (\S+) schema (\d+)")


def examples_module(name):
    """An example script imported as a module (its ``main`` does not run)."""
    pytest.importorskip("gymnasium")
    sys.path.insert(0, str(EXAMPLES))
    try:
        return __import__(name)
    finally:
        sys.path.remove(str(EXAMPLES))


@pytest.fixture(scope="module")
def card(scenario):
    return brachia.benchmark(
        scenario, builtin=["pd"], levels=2, monte_carlo_runs=0, family_runs=0, sweeps=["mass"]
    )


def test_runs_csv_of_the_benchmark_carries_the_schema_line_of_the_cli(card):
    first, header, *rows = card["runs_csv"].splitlines()
    assert first == "# brachia runs schema 2"
    assert header.split(",")[:2] == ["controller", "disturbance"] and header.endswith(",capture_t_s")
    assert [r.split(",")[0] for r in rows] == ["pd", "pd"]
    assert card["scorecard"]["schema_version"] == 2


def test_the_examples_benchmark_folder_reads_back(card, tmp_path):
    compare = examples_module("compare_policies")
    out = tmp_path / "bench"
    compare.write_benchmark(out, card)
    assert (out / "runs.csv").read_text().startswith("# brachia runs schema 2\n")
    page = brachia.view(out)
    assert page == out / "view.html" and "pd" in page.read_text()
    # the reader checks the line: without it the file is refused as an older brachia's
    body = (out / "runs.csv").read_text().split("\n", 1)[1]
    (out / "runs.csv").write_text(body)
    with pytest.raises(brachia.BrachiaError, match=r"runs\.csv.*older brachia"):
        brachia.view(out)
    # and a schema the reader does not know is refused naming it
    (out / "runs.csv").write_text("# brachia runs schema 3\n" + body)
    with pytest.raises(brachia.BrachiaError, match=r"runs\.csv.*= 3.*schema 1 to 2"):
        brachia.view(out)


def test_the_training_curve_starts_with_its_schema_line(tmp_path):
    train = examples_module("train_ppo")
    path = tmp_path / "curve.csv"
    f, writer = train.open_curve(path)
    writer.writerow({c: 1 for c in train.CURVE_COLUMNS})
    f.close()
    lines = path.read_text().splitlines()
    kind, _ = SCHEMA_LINE.fullmatch(lines[0]).groups()
    assert kind == path.stem and lines[0] == train.CURVE_SCHEMA_LINE
    # a reader that skips comment lines (pandas: comment="#") gets the header and the rows
    rows = list(csv.DictReader(line for line in lines if not line.startswith("#")))
    assert list(rows[0]) == train.CURVE_COLUMNS and rows[0]["steps"] == "1"


def test_every_csv_kept_under_examples_starts_with_its_schema_line():
    files = sorted(EXAMPLES.rglob("*.csv"))
    assert files, "no CSV files under python/examples"
    for f in files:
        first = f.read_text().split("\n", 1)[0]
        m = SCHEMA_LINE.fullmatch(first)
        assert m, f"{f}: first line {first!r}"
        assert m.group(1) == f.stem, f"{f}: kind {m.group(1)}"


def test_the_kept_benchmark_rows_read_back_with_a_scorecard(tmp_path, card):
    # the runs.csv kept beside the trained policy reads with brachia's reader (a scorecard beside it)
    kept = EXAMPLES / "swing_ppo" / "benchmark" / "runs.csv"
    out = tmp_path / "kept"
    out.mkdir()
    (out / "runs.csv").write_text(kept.read_text())
    (out / "scorecard.json").write_text(json.dumps(card["scorecard"]))
    assert brachia.view(out).is_file()
