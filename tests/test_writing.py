"""Generated files: one complete generation or the previous one, whatever happens meanwhile."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from paths import ROOT

from motivml.documents import writing
from motivml.documents.writing import write_generation
from motivml.errors import EnvironmentProblem

FIRST = {"a.h": "first a\n", "b.h": "first b\n", "lock": "first\n"}
SECOND = {"a.h": "second a\n", "b.h": "second b\n", "lock": "second\n"}


def contents(folder: Path) -> dict[str, str]:
    return {p.name: p.read_text() for p in folder.iterdir() if p.is_file()}


def test_a_generation_replaces_the_files_and_keeps_unchanged_ones_untouched(tmp_path: Path) -> None:
    out = tmp_path / "out"
    assert write_generation(out, FIRST) == dict.fromkeys(FIRST, True)
    stamp = (out / "lock").stat().st_mtime_ns
    assert write_generation(out, FIRST) == dict.fromkeys(FIRST, False)  # nothing to do
    changed = write_generation(out, {**FIRST, "a.h": "new a\n"})
    assert changed == {"a.h": True, "b.h": False, "lock": False}
    assert contents(out) == {**FIRST, "a.h": "new a\n"} and (out / "lock").stat().st_mtime_ns == stamp
    assert out.is_symlink() and len(os.listdir(tmp_path / ".out.generations")) == 1  # the old one is gone


def test_a_real_folder_becomes_the_first_generation_with_what_else_it_holds(tmp_path: Path) -> None:
    """An earlier version's output (it holds a file written here) with a person's notes."""
    out = tmp_path / "out"
    out.mkdir()
    (out / "lock").write_text("an earlier version's\n")
    (out / "notes.txt").write_text("mine\n")
    (out / "pictures").mkdir()
    (out / "pictures" / "a.svg").write_text("<svg/>")
    write_generation(out, FIRST)
    write_generation(out, SECOND)
    assert contents(out) == {**SECOND, "notes.txt": "mine\n"}
    assert (out / "pictures" / "a.svg").read_text() == "<svg/>"


def test_a_folder_motivml_did_not_make_and_names_that_are_not_plain_are_refused(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Issue 31: `configure -o proj` turned a checkout into a link with the generated files
    among its own; `-o .` left `..generations` and `..lock` in the current folder."""
    checkout = tmp_path / "proj"
    (checkout / ".git").mkdir(parents=True)
    (checkout / "README.md").write_text("mine\n")
    with pytest.raises(EnvironmentProblem, match="is a folder motivml did not make"):
        write_generation(checkout, FIRST)
    assert sorted(os.listdir(tmp_path)) == ["proj"] and not checkout.is_symlink()
    assert sorted(os.listdir(checkout)) == [".git", "README.md"]
    monkeypatch.chdir(checkout)
    for name in (".", "..", str(checkout)):
        with pytest.raises(EnvironmentProblem, match="is not a plain folder name"):
            write_generation(Path(name) if name != str(checkout) else Path("/"), FIRST)
    assert sorted(os.listdir(checkout)) == [".git", "README.md"]
    empty = tmp_path / "empty"
    empty.mkdir()
    write_generation(empty, FIRST)  # (an empty folder loses nothing)
    assert contents(empty) == FIRST


@pytest.mark.parametrize("crash_at", ["_write_new", "_fsync_dir", "_link", "_remove_stale"])
def test_a_writer_killed_anywhere_leaves_one_complete_generation(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, crash_at: str
) -> None:
    """The crash is an exception that no code of ours catches, as kill -9 would be."""
    out = tmp_path / "out"
    write_generation(out, FIRST)

    class Killed(BaseException):
        pass

    real = getattr(writing, crash_at)
    calls = []

    def dies(*args: object, **kwargs: object) -> object:
        calls.append(crash_at)
        if len(calls) == 2 or crash_at in ("_link", "_remove_stale"):
            raise Killed
        return real(*args, **kwargs)

    monkeypatch.setattr(writing, crash_at, dies)
    with pytest.raises(Killed):
        write_generation(out, SECOND)
    assert contents(out) in (FIRST, SECOND)  # whole, never a mix
    monkeypatch.undo()
    write_generation(out, SECOND)  # the next run cleans up after the killed one
    assert contents(out) == SECOND
    assert len(os.listdir(tmp_path / ".out.generations")) == 1
    assert not [p for p in os.listdir(tmp_path) if ".link-" in p]


def test_what_is_in_the_way_is_refused_and_nothing_changes(tmp_path: Path) -> None:
    out = tmp_path / "out"
    write_generation(out, FIRST)
    (out / "b.h").unlink()
    (out / "b.h").mkdir()
    with pytest.raises(EnvironmentProblem, match="something other than a file is in the way"):
        write_generation(out, SECOND)
    assert (out / "b.h").is_dir() and (out / "lock").read_text() == "first\n"
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    (tmp_path / "linked").symlink_to(elsewhere)
    with pytest.raises(EnvironmentProblem, match="which motivml did not write"):
        write_generation(tmp_path / "linked", FIRST)
    assert os.listdir(elsewhere) == []


WRITER = """
import sys
from pathlib import Path
from motivml.documents.writing import write_generation
name = sys.argv[2]
for round in range(int(sys.argv[3])):
    files = {f"{i}.txt": f"{name} {round}\\n" for i in range(20)}
    write_generation(Path(sys.argv[1]), files)
"""

READER = """
import sys, json
from pathlib import Path
out, seen = Path(sys.argv[1]), set()
mixed = 0
for _ in range(int(sys.argv[2])):
    try:
        snapshot = out.resolve()  # the folder as it is at one moment: one generation
        texts = {p.read_text() for p in snapshot.iterdir()}
    except OSError:  # the generation it listed was replaced under it: list again
        continue
    if len(texts) > 1:
        mixed += 1
    seen |= texts
print(json.dumps({"mixed": mixed, "seen": len(seen)}))
"""


def test_concurrent_writers_take_turns_and_a_reader_never_sees_a_mix(tmp_path: Path) -> None:
    out = tmp_path / "out"
    write_generation(out, {f"{i}.txt": "start\n" for i in range(20)})
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    writers = [
        subprocess.Popen([sys.executable, "-c", WRITER, str(out), name, "30"], env=env)
        for name in ("lab", "field")
    ]
    reader = subprocess.run(
        [sys.executable, "-c", READER, str(out), "400"], env=env, capture_output=True, text=True, timeout=120
    )
    assert [w.wait(timeout=120) for w in writers] == [0, 0]
    verdict = json.loads(reader.stdout)
    assert verdict["mixed"] == 0
    final = set(contents(out).values())
    assert final in ({"lab 29\n"}, {"field 29\n"})  # the last writer's generation, whole


def test_bytes_are_written_as_they_are_and_rewritten_only_when_they_change(tmp_path: Path) -> None:
    """A picture (plot's PNG) goes through the same atomic writing as generated text."""
    png = b"\x89PNG\r\n\x1a\n\x00\xff"
    assert writing.write_if_changed(tmp_path, {"a.png": png, "a.txt": "é"}) == {"a.png": True, "a.txt": True}
    assert (tmp_path / "a.png").read_bytes() == png and (tmp_path / "a.txt").read_bytes() == "é".encode()
    assert writing.write_if_changed(tmp_path, {"a.png": png}) == {"a.png": False}
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.png", "a.txt"]  # no temporary left


_scalars = st.none() | st.booleans() | st.integers() | st.floats(allow_nan=False) | st.text()
_json_values = st.recursive(
    _scalars | st.lists(st.text()),
    lambda inner: st.lists(inner, max_size=4)
    | st.lists(inner, max_size=3).map(tuple)
    | st.dictionaries(st.text(), inner, max_size=4),
    max_leaves=30,
)


@settings(max_examples=300, deadline=None)
@given(_json_values)
def test_indented_json_is_what_json_dumps_writes_with_an_indent(value: object) -> None:
    assert writing.indented_json(value) == json.dumps(value, indent=2)


def test_indented_json_of_an_analysis_shaped_document() -> None:
    document = {
        "model": "m\u00e9/\"x\".json",
        "features": 3,
        "void": False,
        "core": ["a", "b"],
        "dead": [],
        "atomic_sets": [["a", "b"], ["c"]],
        "impossible_bindings": [{"feature": "c", "aspect": "time", "value": "Early"}],
        "selection_count": None,
        "uncounted": [],
    }
    assert writing.indented_json(document) == json.dumps(document, indent=2)


@pytest.mark.parametrize("ascii", [True, False])
def test_indented_json_is_jsons_indented_text_however_deep(ascii: bool) -> None:
    """indented_json is json.dumps(indent=2) (with the same ensure_ascii), and iterative: a
    document nested 5,000 deep, past Python's recursion limit, is written too."""
    from motivml.documents.writing import indented_json

    sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "bench"))
    from families import family

    samples: list[object] = [
        {},
        [],
        {"a": [1, 2.5, None, True, "ß\u2603\x1b"], "b": {"c": [], "d": {}}, "é": ["x", "y"]},
        [[["deep"]], {"k": [{"l": []}]}],
        family("groups", 60, seed=3),
    ]
    for value in samples:
        assert indented_json(value, ascii=ascii) == json.dumps(value, indent=2, ensure_ascii=ascii)
    deep: dict[str, object] = {"id": "leaf"}
    for d in range(5_000):
        deep = {"id": f"f{d}", "sub": [deep]}
    text = indented_json(deep, ascii=ascii)
    assert text.count('"sub"') == 5_000 and text.endswith("}")


def test_a_real_folder_of_what_else_motivml_puts_there_is_taken_over(tmp_path: Path) -> None:
    """A variant's build folder after a run (its `run/`) or graph (its pictures), before any
    configure: motivml's own, so configure takes it over (review of issue 31's refusal)."""
    out = tmp_path / "out"
    (out / "run").mkdir(parents=True)
    (out / "feature-model.svg").write_text("<svg/>")
    write_generation(out, FIRST, also_ours={"run", "feature-model.svg"})
    assert contents(out) == {**FIRST, "feature-model.svg": "<svg/>"} and (out / "run").is_dir()
