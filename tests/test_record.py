"""run --record and plot: a run's record, one CSV row per tick, and its picture.

The reaching arm's `swappable` variant runs 3 s on the simulated clock with its hot swap
(the DMP swapped for the point attractor at 1 s): the record has one row per tick, the
swap at its tick, the spaces' columns of the architecture; `plot` draws it as an SVG with
one panel per space; bad records and bad paths are located errors, and leave nothing.
"""

from __future__ import annotations

import csv
import json
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest
from click.testing import CliRunner

from motivml.cli import main

ROOT = Path(__file__).resolve().parent.parent
ARM = ROOT / "feature_models" / "reaching_arm"
RATE, DURATION = 500, 3  # Hz, s
SVG = "{http://www.w3.org/2000/svg}"


def record(path: Path, *more: str) -> tuple[int, str]:
    result = CliRunner().invoke(
        main,
        [
            "run",
            str(ARM),
            "--variant",
            "swappable",
            "--duration",
            str(DURATION),
            "--rate",
            str(RATE),
            "--clock",
            "simulated",
            "--no-live",
            "--no-control",
            "--at",
            "1",
            "swap dmp_reach attractor_reach",
            "--record",
            str(path),
            *more,
        ],
    )
    return result.exit_code, result.output


@pytest.fixture(scope="module")
def recorded(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("record") / "swap.csv"
    code, output = record(path)
    assert code == 0, output
    assert f"recorded {RATE * DURATION} ticks in {path}" in output
    return path


def test_one_row_per_tick_with_the_architecture_s_spaces(recorded: Path) -> None:
    with open(recorded, newline="") as handle:
        rows = list(csv.reader(handle))
    header, body = rows[0], rows[1:]
    spaces = json.loads((ARM / "architecture.json").read_text())["spaces"]
    expected = [f"{s['id']}[{i}]" for s in spaces for i in range(s["dimension"])]
    assert header == ["tick", "time", *expected, "events"]
    assert len(body) == RATE * DURATION  # one row per tick
    assert [int(r[0]) for r in body] == list(range(RATE * DURATION))
    assert float(body[RATE][1]) == pytest.approx(1.0)
    events = {int(r[0]): r[-1] for r in body if r[-1]}
    assert events[RATE] == "reconfiguration: swap dmp_reach attractor_reach"  # the tick it committed at
    assert any(e.startswith("component: AttractorReacher converged") for e in events.values())
    assert not list(recorded.parent.glob(".swap.csv.*"))  # no temporary left beside it


def test_the_record_plots(recorded: Path, tmp_path: Path) -> None:
    picture = tmp_path / "swap.svg"
    result = CliRunner().invoke(main, ["plot", str(recorded), "-o", str(picture)])
    assert result.exit_code == 0, result.output
    spaces = json.loads((ARM / "architecture.json").read_text())["spaces"]
    assert f"{len(spaces)} spaces over" in result.output and "1 event marked" in result.output
    tree = ET.parse(picture)
    axes = [g for g in tree.iter(f"{SVG}g") if (g.get("id") or "").startswith("axes_")]
    assert len(axes) == len(spaces)  # one panel per space
    texts = "".join(t.text or "" for t in tree.iter(f"{SVG}text")) + picture.read_text()
    assert "swap dmp_reach attractor_reach" in texts
    again = tmp_path / "again.svg"
    CliRunner().invoke(main, ["plot", str(recorded), "-o", str(again)])
    assert again.read_bytes() == picture.read_bytes()  # the same record draws the same bytes
    png = tmp_path / "swap.png"
    assert CliRunner().invoke(main, ["plot", str(recorded), "-o", str(png)]).exit_code == 0
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.parametrize(
    ("text", "where", "message"),
    [
        ("", ":1:1:", "the file is empty"),
        ("a,b\n1,2\n", ":1:1:", "not a run record"),
        ("tick,time,P[0],P[2],events\n", ":1:1:", "column 4, 'P[2]', is not SPACE[i] in order"),
        ("tick,time,P[0],events\n", ":2:1:", "the record has no rows"),
        ("tick,time,P[0],events\n0,0.0,1.5,\n1,0.001,x,\n", ":3:1:", "must be numbers"),
        ("tick,time,P[0],events\n0,0.0,1.5\n", ":2:1:", "3 fields where the header has 4"),
    ],
)
def test_a_bad_record_is_a_located_error_and_draws_nothing(
    tmp_path: Path, text: str, where: str, message: str
) -> None:
    bad = tmp_path / "bad.csv"
    bad.write_text(text)
    result = CliRunner().invoke(main, ["plot", str(bad), "-o", str(tmp_path / "bad.svg")])
    assert result.exit_code == 1, result.output
    assert f"{bad}{where}" in result.output and message in result.output
    assert not (tmp_path / "bad.svg").exists()


def test_plot_refuses_other_pictures_and_missing_records(tmp_path: Path) -> None:
    runner = CliRunner()
    wrong = runner.invoke(main, ["plot", str(tmp_path / "r.csv"), "-o", str(tmp_path / "r.pdf")])
    assert wrong.exit_code == 2 and "the picture is .svg or .png" in wrong.output
    missing = runner.invoke(main, ["plot", str(tmp_path / "r.csv"), "-o", str(tmp_path / "r.svg")])
    assert missing.exit_code == 3 and "cannot read" in missing.output
    binary = tmp_path / "b.csv"
    binary.write_bytes(b"\xff\xfe\x00tick")
    assert runner.invoke(main, ["plot", str(binary), "-o", str(tmp_path / "b.svg")]).exit_code == 1


def test_an_unwritable_record_stops_before_the_run(tmp_path: Path) -> None:
    blocked = tmp_path / "file"
    blocked.write_text("")
    code, output = record(blocked / "run.csv")
    assert code == 3 and "cannot write the record" in output
    assert "running reaching_arm" not in output  # nothing ran
    code, output = record(tmp_path / "run.parquet")
    assert code == 2 and "Parquet is not supported" in output
    assert not list(tmp_path.glob("*.parquet")) and not list(tmp_path.glob(".run*"))
