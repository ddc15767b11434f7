"""run --record and plot: one row per tick, every event at its tick, a picture per record,
and every bad record or path refused with its place, never a traceback or half a file."""

from __future__ import annotations

import csv
import re
import signal
import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner, Result
from hypothesis import given
from hypothesis import strategies as st
from paths import ROOT

from motivml.cli import main
from motivml.runtime import record
from motivml.runtime.events import Missed, Refused
from motivml.runtime.launch import launch
from motivml.runtime.record import SEPARATOR, Recorder, columns, escape, read_record, split_events

ARM = ROOT / "feature_models" / "reaching_arm"
SVG = "{http://www.w3.org/2000/svg}"


def invoke(*args: str) -> Result:
    return CliRunner().invoke(main, list(args))


def rows(path: Path) -> tuple[list[str], list[dict[str, str]]]:
    with open(path, newline="", encoding="utf-8") as handle:
        reader = csv.DictReader(handle)
        return list(reader.fieldnames or []), list(reader)


def arm_spaces() -> list[tuple[str, int]]:
    """The spaces the swappable arm may run, from its own documents."""
    robot = launch(ARM, "swappable")
    try:
        return columns(robot.architecture, {d.feature.id for d in robot.variant.selected()})
    finally:
        robot.close()


def record_swap(folder: Path, duration: float = 1.5, rate: float = 500.0, swap_at: float = 0.6) -> Result:
    return invoke(
        "run",
        str(ARM),
        "--variant",
        "swappable",
        "--duration",
        f"{duration:g}",
        "--rate",
        f"{rate:g}",
        "--clock",
        "simulated",
        "--no-live",
        "--no-control",
        "--at",
        f"{swap_at:g}",
        "swap dmp_reach attractor_reach",
        "--record",
        str(folder / "swap.csv"),
    )


def test_a_recorded_run_has_one_row_per_tick_and_its_events_at_their_ticks(tmp_path: Path) -> None:
    duration, rate, swap_at = 1.5, 500.0, 0.6
    result = record_swap(tmp_path, duration, rate, swap_at)
    assert result.exit_code == 0, result.output
    ticks = round(duration * rate)
    assert result.output.splitlines()[-1] == f"recorded {ticks} ticks in {tmp_path / 'swap.csv'}"
    names, table = rows(tmp_path / "swap.csv")
    spaces = arm_spaces()
    assert [name for name, _ in spaces] == ["ArmGoal", "ArmCommand", "HandPosition"]
    assert names == ["tick", "time", *(f"{s}[{i}]" for s, n in spaces for i in range(n)), "events"]
    assert len(table) == ticks
    assert [int(r["tick"]) for r in table] == list(range(1, ticks + 1))
    assert all(float(r["time"]) == int(r["tick"]) / rate for r in table)
    # the record says what the run printed, at the tick it printed
    swap_tick = round(swap_at * rate)
    assert f"changed at {swap_at:.3f} s (tick {swap_tick}): swap dmp_reach attractor_reach" in result.output
    events = {int(r["tick"]): split_events(r["events"]) for r in table if r["events"]}
    assert events[swap_tick] == ["change: swap dmp_reach attractor_reach"]
    fired = re.search(r"AttractorReacher .* converged .* ([0-9.]+) s", result.output)
    assert fired is not None
    assert events[round(float(fired.group(1)) * rate)] == ["status: AttractorReacher converged"]
    assert events[1] == [
        f"run: reaching_arm variant swappable at {rate:g} Hz on the simulated clock for 1.5 s"
    ]
    assert events[ticks] == ["end: its duration elapsed"]
    assert set(events) == {1, swap_tick, round(float(fired.group(1)) * rate), ticks}
    # the last row holds the values the summary prints
    for space, size in spaces:
        printed = re.search(rf"^space {space} = \[(.*)\]$", result.output, re.M)
        assert printed is not None
        recorded = [float(table[-1][f"{space}[{i}]"]) for i in range(size)]
        assert [f"{v:.3f}" for v in recorded] == printed.group(1).split(", ")
    assert [p.name for p in tmp_path.iterdir()] == ["swap.csv"]  # no hidden file left behind


def test_the_recorded_run_plots_one_panel_per_space_with_its_events(tmp_path: Path) -> None:
    ran = record_swap(tmp_path)
    assert ran.exit_code == 0, ran.output
    fired = re.search(r"AttractorReacher .* converged .* ([0-9.]+) s", ran.output)
    assert fired is not None
    picture = tmp_path / "plots" / "swap.svg"
    result = invoke("plot", str(tmp_path / "swap.csv"), "-o", str(picture))
    assert result.exit_code == 0, result.output
    assert result.output.splitlines() == [
        f"{picture}: 3 spaces, 750 ticks (0.002 to 1.5 s), 2 events marked",
        "  0.600 s (tick 300): swap dmp_reach attractor_reach",
        f"  {fired.group(1)} s (tick {round(float(fired.group(1)) * 500)}): AttractorReacher converged",
    ]
    svg = ET.parse(picture).getroot()
    axes = [g for g in svg.iter(f"{SVG}g") if re.fullmatch(r"axes_\d+", g.get("id", ""))]
    assert len(axes) == len(arm_spaces())
    texts = ["".join(t.itertext()).strip() for t in svg.iter(f"{SVG}text")]
    for expected in ("ArmGoal", "ArmCommand", "HandPosition", "time [s]", "swap dmp_reach attractor_reach"):
        assert expected in texts
    assert "reconfiguration" in texts and "criterion" in texts  # the legend of event kinds
    lines = [g for g in svg.iter(f"{SVG}g") if g.get("id", "").startswith("line2d_")]
    assert len(lines) >= sum(n for _, n in arm_spaces())  # a line per number (and the legends' samples)
    assert [p.name for p in picture.parent.iterdir()] == ["swap.svg"]
    again = invoke("plot", str(tmp_path / "swap.csv"), "-o", str(tmp_path / "swap.png"))
    assert again.exit_code == 0, again.output
    assert (tmp_path / "swap.png").read_bytes().startswith(b"\x89PNG\r\n\x1a\n")
    default = invoke("plot", str(tmp_path / "swap.csv"))  # beside the record, .svg
    assert default.exit_code == 0 and (tmp_path / "swap.svg").read_bytes() == picture.read_bytes()


def test_the_guides_picture_is_the_plot_of_the_guides_record() -> None:
    """guidelines/images/reaching_arm/hot-swap.svg is what the guide's commands draw (its
    bytes follow matplotlib's version; what it shows is checked here)."""
    guide = (ROOT / "guidelines" / "the-motion-architecture.md").read_text()
    assert "![" in guide and "(images/reaching_arm/hot-swap.svg)" in guide
    svg = ET.parse(ROOT / "guidelines" / "images" / "reaching_arm" / "hot-swap.svg").getroot()
    axes = [g for g in svg.iter(f"{SVG}g") if re.fullmatch(r"axes_\d+", g.get("id", ""))]
    assert len(axes) == 3
    texts = {"".join(t.itertext()).strip() for t in svg.iter(f"{SVG}text")}
    assert {"ArmGoal", "ArmCommand", "HandPosition", "swap dmp_reach attractor_reach"} <= texts
    assert "reaching_arm variant swappable at 1000 Hz on the simulated clock for 3 s: 3,000 ticks" in texts


# ------------------------------------------------------------------ how a run ends
def test_a_failing_static_plugin_ends_the_record_with_its_fault(tmp_path: Path) -> None:
    from test_transactions import make_robot

    folder = make_robot(
        tmp_path / "bot",
        {"a": {"step": "if self.steps == 6: raise KeyError('calibration')"}},
        static=("alt", "a"),
    )
    target = tmp_path / "bot.csv"
    result = invoke(
        "run", str(folder), "--variant", "v", "--clock", "simulated", "--no-control", "--record", str(target)
    )
    assert result.exit_code == 1, result.output
    _, table = rows(target)
    assert [int(r["tick"]) for r in table] == list(range(1, 8))
    assert split_events(table[-1]["events"]) == [
        "fault: a raised in its step: KeyError: 'calibration' (at mod_a.py:10)",
        "end: a failed: the run stopped",
    ]
    assert [r["Out[0]"] for r in table] == ["1.0"] * 7  # the plugin's writes


def test_a_stop_that_raises_at_the_end_is_in_the_last_row(tmp_path: Path) -> None:
    from test_transactions import lifecycle_robot

    folder = lifecycle_robot(tmp_path / "bot", {"a": {}, "a2": {"stop": "raise RuntimeError('busy')"}})
    result = invoke(
        "run", str(folder), "--variant", "v", "--duration", "0.01", "--clock", "simulated",
        "--no-control", "--record", str(tmp_path / "r.csv"),
    )  # fmt: skip
    assert result.exit_code == 1, result.output
    _, table = rows(tmp_path / "r.csv")
    assert len(table) == 10
    assert split_events(table[-1]["events"]) == [
        "fault: stop() of plugin a2 raised",
        "end: its duration elapsed",
    ]


def test_where_there_is_no_o_tmpfile_the_record_has_a_hidden_name_from_the_start(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The fallback (a system or file system without O_TMPFILE): the hidden file is there
    while the run goes on, renamed at the end, and removed when the run never started."""
    import os

    monkeypatch.delattr(os, "O_TMPFILE")
    target = tmp_path / "r.csv"
    result = invoke(
        "run", str(ROOT / "feature_models" / "simplebot"), "--variant", "field", "--duration", "0.01",
        "--clock", "simulated", "--no-control", "--no-live", "--record", str(target),
    )
    assert result.exit_code == 0, result.output
    assert [p.name for p in tmp_path.iterdir()] == ["r.csv"] and len(rows(target)[1]) == 10
    never = Recorder.create(tmp_path / "never.csv")
    assert never.temporary is not None and never.temporary.name.startswith(".never.csv.")
    never.discard()
    assert [p.name for p in tmp_path.iterdir()] == ["r.csv"]


def test_a_run_killed_outright_while_recording_leaves_no_file(tmp_path: Path) -> None:
    """Issue 31: `kill -9` during --record left a hidden temporary file beside the record.
    The record is written to a file without a name until the run ends: nothing is left."""
    target = tmp_path / "run.csv"
    command = [sys.executable, "-m", "motivml.cli", "run", str(ARM), "--variant", "swappable", "--no-live"]
    command += ["--no-control", "--duration", "60", "--at", "0.05", "swap dmp_reach attractor_reach"]
    process = subprocess.Popen(
        [*command, "--record", str(target)], stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, cwd=ROOT
    )
    assert process.stdout is not None
    with process.stdout:
        for line in process.stdout:  # the swap is seen: the record has rows by now
            if "swap dmp_reach attractor_reach" in line:
                break
        process.kill()
    process.wait(timeout=60)
    assert process.returncode == -signal.SIGKILL
    assert list(tmp_path.iterdir()) == []


def test_ctrl_c_on_the_real_clock_leaves_a_complete_record(tmp_path: Path) -> None:
    """Ctrl-C once the swap is seen (no guess at timing): every tick run is recorded, once."""
    target = tmp_path / "run.csv"
    command = [sys.executable, "-m", "motivml.cli", "run", str(ARM), "--variant", "swappable", "--no-live"]
    command += ["--no-control", "--duration", "60", "--at", "0.05", "swap dmp_reach attractor_reach"]
    process = subprocess.Popen(
        [*command, "--record", str(target)],
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        cwd=ROOT,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )
    assert process.stdout is not None
    before = []
    for line in process.stdout:  # blocks until the run prints
        before.append(line)
        if re.fullmatch(r"\d\d:\d\d:\d\d\.\d{3} tick \d+: swap dmp_reach attractor_reach\n", line):
            break
    else:
        raise AssertionError("the run ended before the swap was reported:\n" + "".join(before))
    assert not target.exists()  # written beside it, renamed when the run ends
    process.send_signal(signal.SIGINT)
    with process.stdout:
        output = process.stdout.read()
    process.wait(timeout=60)
    assert process.returncode == 130, "".join(before) + output
    ran = re.search(r"^(\d+) ticks, ", output, re.M)
    changed = re.search(
        r"^changed at [0-9.]+ s \(tick (\d+)\): swap dmp_reach attractor_reach$", output, re.M
    )
    assert ran is not None and changed is not None, output
    assert f"recorded {ran.group(1)} ticks in {target}" in output
    _, table = rows(target)
    assert [int(r["tick"]) for r in table] == list(range(1, int(ran.group(1)) + 1))
    assert "change: swap dmp_reach attractor_reach" in split_events(
        table[int(changed.group(1)) - 1]["events"]
    )
    assert split_events(table[-1]["events"])[-1] == "end: stopped by SIGINT"
    assert [p.name for p in tmp_path.iterdir()] == ["run.csv"]


def test_a_loop_stuck_in_a_plugin_still_completes_its_record(tmp_path: Path) -> None:
    """The second Ctrl-C while a plugin's step never returns completes the record (the ticks
    done, and why it ends) before giving up, and nothing is written to it after."""
    import threading

    from test_transactions import lifecycle_robot

    from motivml.runtime.session import Session

    gate = "import threading; self.gate, self.waiting = threading.Event(), threading.Event()"
    stuck_step = "if self.steps == 3: self.waiting.set(); self.gate.wait(60)"
    folder = lifecycle_robot(tmp_path / "bot", {"a": {}, "a2": {"start": gate, "step": stuck_step}})
    stuck = threading.Event()
    recorder = Recorder.create(tmp_path / "r.csv")
    session = Session(launch(folder, "v"), 1.0, "simulated", on_stuck=lambda signum: stuck.set(), record=recorder)
    session.open()
    session.start()
    plugin = session.runtime.plugins["a2"].instance
    try:
        assert plugin.waiting.wait(60)  # the loop is in a2's step
        stuck_tick = session.runtime.ticks  # (counted as the tick began stepping plugins)
        session._interrupt(signal.SIGINT, None)
        session._interrupt(signal.SIGINT, None)  # the loop did not stop: give up
        assert stuck.is_set()
        written = (tmp_path / "r.csv").read_text()
    finally:
        plugin.gate.set()
    assert session.wait(60)
    session.close()
    assert (tmp_path / "r.csv").read_text() == written and session.recorded == stuck_tick - 1
    _, table = rows(tmp_path / "r.csv")
    assert [int(r["tick"]) for r in table] == list(range(1, stuck_tick))  # every tick that ended
    assert split_events(table[-1]["events"]) == [
        f"end: the loop was stuck in a plugin's step: interrupted twice (at tick {stuck_tick})"
    ]


# ------------------------------------------------------------------ paths that cannot be
def test_parquet_and_other_suffixes_are_refused_before_the_run(tmp_path: Path) -> None:
    parquet = invoke("run", str(ARM), "--variant", "dmp", "--record", str(tmp_path / "x.parquet"))
    assert parquet.exit_code == 2 and "Parquet is not supported: a record is CSV" in parquet.output
    other = invoke("run", str(ARM), "--variant", "dmp", "--record", str(tmp_path / "x.json"))
    assert other.exit_code == 2 and "a record is CSV: give a FILE ending in .csv" in other.output
    assert "running" not in parquet.output + other.output
    assert not list(tmp_path.glob("x*")) and not list(tmp_path.glob(".x*"))


@pytest.mark.parametrize("where", ["under a file", "a name too long"])
def test_an_unwritable_record_path_is_an_environment_error_before_the_run(tmp_path: Path, where: str) -> None:
    (tmp_path / "file").write_text("in the way")
    target = tmp_path / "file" / "run.csv" if where == "under a file" else tmp_path / ("x" * 300 + ".csv")
    result = invoke("run", str(ARM), "--variant", "dmp", "--clock", "simulated", "--record", str(target))
    assert result.exit_code == 3, result.output
    assert result.output.startswith(f"{target}: cannot write the record: ")
    assert "running" not in result.output and isinstance(result.exception, SystemExit)
    assert [p.name for p in tmp_path.iterdir()] == ["file"]


def test_a_folder_in_the_records_place_is_a_usage_error(tmp_path: Path) -> None:
    (tmp_path / "run.csv").mkdir()
    result = invoke("run", str(ARM), "--variant", "dmp", "--record", str(tmp_path / "run.csv"))
    assert result.exit_code == 2 and "is a directory" in result.output
    assert list((tmp_path / "run.csv").iterdir()) == []


def test_a_run_that_cannot_start_leaves_no_record(tmp_path: Path) -> None:
    target = tmp_path / "broken.csv"
    quadruped = ROOT / "feature_models" / "quadruped"
    result = invoke("run", str(quadruped), "--variant", "broken_two_gaits", "--record", str(target))
    assert result.exit_code == 1 and "cannot run" in result.output
    assert list(tmp_path.iterdir()) == []  # neither the record nor its hidden file


# ------------------------------------------------------------------ bad records
BAD = {
    "empty": ("", 1, "empty: not a record of motivml run"),
    "not a record": ("name,value\nx,1\n", 1, "not a record of motivml run: its first line names the columns"),
    "a column not a space": ("tick,time,Arm,events\n", 1, "column 'Arm' is not a space's number, SPACE[i]"),
    "numbers out of order": (
        "tick,time,A[0],A[2],events\n",
        1,
        "column 'A[2]' where A[1] should be: a space's numbers come in order, together",
    ),
    "no ticks": ("tick,time,A[0],events\n", 2, "the record has no ticks: the run ended before its first"),
    "a short row": ("tick,time,A[0],events\n1,0.001,0.5,\n2,0.002\n", 3, "2 fields, where the first line names 4"),
    "a tick skipped": ("tick,time,A[0],events\n1,0.001,0.5,\n3,0.003,0.5,\n", 3, "tick 3 follows tick 1"),
    "a tick not a number": ("tick,time,A[0],events\nx,0.001,0.5,\n", 2, "tick 'x' is not a whole number"),
    "a time not a number": ("tick,time,A[0],events\n1,soon,0.5,\n", 2, "time 'soon' is not a number of seconds"),
    "a value not a number": ("tick,time,A[0],events\n1,0.001,0.5,\n2,0.002,high,\n", 3, "A[0]: 'high' is not a number"),
    "an event without its kind": ("tick,time,A[0],events\n1,0.001,0.5,swap a b\n", 2, "event 'swap a b' is not 'kind: text'"),
    "not text": (b"\x89PNG\r\n\x1a\n\x00\xff", 1, "not UTF-8 text: not a record of motivml run"),
    "a NUL byte": ("tick,time,A[0],events\n1,0.001,0.5\x00,\n", 2, "A[0]: '0.5\\x00' is not a number"),
    "an open quote": ('tick,time,A[0],events\n1,0.001,0.5,"change: x\n', 2, "not CSV: unexpected end of data"),
}  # fmt: skip


@pytest.mark.parametrize("case", BAD, ids=list(BAD))
def test_a_bad_record_is_refused_with_its_line(tmp_path: Path, case: str) -> None:
    text, line, message = BAD[case]
    bad = tmp_path / "bad.csv"
    bad.write_bytes(text if isinstance(text, bytes) else text.encode())
    result = invoke("plot", str(bad), "-o", str(tmp_path / "bad.svg"))
    assert result.exit_code == 1, result.output
    assert isinstance(result.exception, SystemExit)  # said, not a traceback
    (said,) = result.output.splitlines()
    assert said.startswith(f"{bad}:{line}:") and message in said, said
    assert [p.name for p in tmp_path.iterdir()] == ["bad.csv"]  # no picture, not half of one


def test_plot_refuses_a_missing_record_and_a_picture_format_it_does_not_draw(tmp_path: Path) -> None:
    missing = invoke("plot", str(tmp_path / "nothing.csv"))
    assert missing.exit_code == 3 and missing.output.startswith(f"{tmp_path / 'nothing.csv'}: cannot read: ")
    (tmp_path / "r.csv").write_text("tick,time,events\n1,0.001,\n")
    pdf = invoke("plot", str(tmp_path / "r.csv"), "-o", str(tmp_path / "r.pdf"))
    assert pdf.exit_code == 2 and "a picture is .svg or .png" in pdf.output
    (tmp_path / "r.svg").write_text("tick,time,events\n1,0.001,\n")  # a record by another name
    itself = invoke("plot", str(tmp_path / "r.svg"))
    assert itself.exit_code == 2 and "would replace the record" in itself.output
    nothing = invoke("plot", str(tmp_path / "r.csv"))  # a robot with plugins only: events, no spaces
    assert nothing.exit_code == 0, nothing.output
    assert nothing.output.startswith(f"{tmp_path / 'r.svg'}: 0 spaces, 1 tick")


def test_plot_reads_a_record_saved_with_a_byte_order_mark(tmp_path: Path) -> None:
    """Issue 31: a record opened and saved by a spreadsheet starts with a UTF-8 byte-order
    mark, and plot refused it ("column '\\ufefftick'"): the mark is not data."""
    record = tmp_path / "r.csv"
    record.write_bytes(b"\xef\xbb\xbftick,time,A[0],events\n1,0.001,0.5,\n2,0.002,0.25,\n")
    result = invoke("plot", str(record))
    assert result.exit_code == 0, result.output
    assert result.output.startswith(f"{tmp_path / 'r.svg'}: 1 space, 2 ticks")


def test_plot_draws_at_most_24_spaces_and_12_numbers_of_each_and_says_so(tmp_path: Path) -> None:
    """Issue 31: a record of 3,000 spaces ran past two minutes (a panel each). The first 24
    are drawn, or those named with --space; a space of many numbers shows its first 12."""
    header = ["tick", "time", *(f"S{k}[0]" for k in range(30)), *(f"Wide[{i}]" for i in range(20)), "events"]
    rows = [",".join(header)] + [",".join([str(t), f"{t / 1000}", *["0.5"] * 50, ""]) for t in (1, 2)]
    record_path = tmp_path / "r.csv"
    record_path.write_text("\n".join(rows) + "\n")

    def axes_and_texts(picture: Path) -> tuple[int, list[str]]:
        svg = ET.parse(picture).getroot()
        axes = [g for g in svg.iter(f"{SVG}g") if re.fullmatch(r"axes_\d+", g.get("id", ""))]
        return len(axes), ["".join(t.itertext()).strip() for t in svg.iter(f"{SVG}text")]

    first = invoke("plot", str(record_path))
    assert first.exit_code == 0, first.output
    assert first.output.splitlines()[:2] == [
        f"{tmp_path / 'r.svg'}: 24 of 31 spaces, 2 ticks (0.001 to 0.002 s), 0 events marked",
        "  (a picture draws at most 24 spaces: choose others with --space)",
    ]
    count, texts = axes_and_texts(tmp_path / "r.svg")
    assert count == 24 and "S23" in texts and "S24" not in texts
    chosen = invoke("plot", str(record_path), "--space", "Wide", "--space", "S29")
    assert chosen.exit_code == 0 and "2 of 31 spaces" in chosen.output, chosen.output
    count, texts = axes_and_texts(tmp_path / "r.svg")
    assert count == 2 and "S29" in texts and "Wide [0-11 of 20]" in texts
    unknown = invoke("plot", str(record_path), "--space", "Wid")
    assert unknown.exit_code == 2 and "the record has no space 'Wid' (did you mean 'Wide'?)" in unknown.output
    many = invoke("plot", str(record_path), *[f"--space=S{k}" for k in range(25)])
    assert many.exit_code == 2 and "25 spaces asked: a picture draws at most 24" in many.output


# ------------------------------------------------------------------ the recorder itself
PRINTABLE = st.characters(
    exclude_categories=["Cc", "Cf", "Cs", "Co", "Cn", "Zl", "Zp", "Zs"], include_characters=" "
)


@given(st.lists(st.text(alphabet=PRINTABLE)))
def test_events_escaped_and_joined_split_back_into_the_same_texts(texts: list[str]) -> None:
    texts = [t.strip(" ") for t in texts if t.strip(" ")]
    cell = SEPARATOR.join(escape(t) for t in texts)
    assert split_events(cell) == texts
    assert "\n" not in escape("a\nb") and split_events(escape("a\nb")) == ["a\\nb"]  # one line per row


def test_events_made_after_their_row_was_written_go_in_the_first_open_row(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(record, "CHUNK", 8)  # rows handed to the writer every 8 ticks
    robot = launch(ARM, "dmp")
    recorder = Recorder.create(tmp_path / "r.csv")
    try:
        recorder.start(robot.runtime, [("ArmCommand", 3)], "a test", simulated=True)
        for _ in range(10):
            robot.runtime.tick()
        recorder.event(Refused(3, "load x", "too late"))  # rows 1-7 are written already
        robot.runtime.told.publish(Missed(robot.runtime.ticks, 2))  # as the real clock does after tick 10 overran
        robot.runtime.tick()
        for _ in range(5):
            robot.runtime.tick()
        assert recorder.finish("done") == 16
    finally:
        robot.close()
    _, table = rows(tmp_path / "r.csv")
    events = {int(r["tick"]): split_events(r["events"]) for r in table if r["events"]}
    assert events == {
        1: ["run: a test"],
        10: ["missed: 2 deadlines"],
        8: ["refused: load x: too late (at tick 3)"],
        16: ["end: done"],
    }


def test_a_long_record_is_thinned_without_losing_a_peak(tmp_path: Path) -> None:
    ticks = 5000
    values = np.sin(np.arange(1, ticks + 1) / 300)
    values[2345] = 7.5  # one tick's peak
    lines = ["tick,time,A[0],B[0],events"]
    for tick, value in enumerate(values, 1):
        absent = "" if 1000 <= tick < 2000 else "1.0"  # B's feature inactive for a while
        lines.append(f"{tick},{tick / 1000!r},{float(value)!r},{absent},")
    (tmp_path / "long.csv").write_text("\n".join(lines) + "\n")
    read = read_record(tmp_path / "long.csv", points=100)
    assert read.ticks == ticks and read.bucket > 1 and len(read.time) <= 200
    assert np.all(np.diff(read.time) > 0) and read.time[0] == 0.001
    assert np.nanmax(read.high[:, 0]) == 7.5 and np.nanmin(read.low[:, 0]) == values.min()
    inactive = (read.time >= 1.0 + read.bucket / 1000) & (read.time < 1.999 - read.bucket / 1000)
    assert inactive.any() and np.isnan(read.low[inactive, 1]).all()
    exact = read_record(tmp_path / "long.csv", points=ticks)  # few enough rows: every one is a point
    assert exact.bucket == 1 and len(exact.time) == ticks


def test_a_disk_that_fills_up_leaves_no_half_record_and_exits_3(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The writer's thread fails (a full disk): the run goes on and says so, and the record
    is removed rather than left half-written."""
    import errno

    def full(self: Recorder, block: object) -> object:
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(Recorder, "_rows", full)
    result = record_swap(tmp_path)
    assert result.exit_code == 3, result.output
    lines = result.output.splitlines()
    assert any(
        line.endswith("swap.csv: cannot write: No space left on device: recording stopped") for line in lines
    )
    assert lines[-1] == f"{tmp_path / 'swap.csv'}: cannot write the record: No space left on device"
    assert "750 ticks, 1.500 s of control time" in lines  # the run itself went on to its end
    assert list(tmp_path.iterdir()) == []
