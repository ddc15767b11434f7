"""A robustness corpus: bad documents of every kind through every command that reads them.

The corpus is generated from a fixed seed: each document is a shipped robot's document
with one mutation (a key removed, a value of the wrong type or size, a duplicated or
unknown id, broken JSON text, odd bytes, an empty file, deep nesting, ...). Each mutated
robot folder goes through the commands that read that kind of document, and each must
end with a documented exit code, never a traceback, and leave earlier output alone when
it fails. The test fails with the list of every command that did not, so a run shows
all of them at once.
"""

from __future__ import annotations

import copy
import json
import random
import re
import shutil
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest
from click.testing import CliRunner
from paths import ROOT

from motivml.cli import main

pytestmark = pytest.mark.slow  # the robustness corpus: every command on hundreds of bad inputs

SEED = 20261123
PER_KIND = 150  # 7 kinds: over 1,000 bad documents (and the importers', records' and options' below)
EXITS = {0, 1, 3}  # valid, invalid, environment (2 is click's usage error: never expected here)

# document kind -> (robot it is mutated in, its file in the folder, the variant to use)
KINDS = {
    "model": ("simplebot", "model.json", "field"),
    "configuration": ("simplebot", "variants/field.json", "field"),
    "decisions": ("simplebot", "variants/warehouse.json", "warehouse"),  # a partial one
    "architecture": ("simplebot", "architecture.json", "field"),
    "coordination": ("coordinated_arm", "coordination.json", "dmp"),
    "robot": ("simplebot", "robot.json", "field"),
    "manifest": ("simplebot", "../../plugins/python/hectorslam/plugin.json", "field"),
}

ODD = [
    None,
    True,
    -1,
    0,
    3.0,
    1e308,
    -(10**40),
    "",
    "x" * 300,
    "Early",
    "Any",
    "\u202e\x1b[31m",
    [],
    {},
    [[[[[]]]]],
    {"id": "a"},
]


def _paths(value: Any, path: tuple[Any, ...] = ()) -> Iterator[tuple[Any, ...]]:
    yield path
    if isinstance(value, dict):
        for key, item in value.items():
            yield from _paths(item, (*path, key))
    elif isinstance(value, list):
        for index, item in enumerate(value):
            yield from _paths(item, (*path, index))


def _ids(value: Any) -> list[str]:
    found = []
    for path in _paths(value):
        if path and path[-1] == "id":
            node = value
            for key in path:
                node = node[key]
            if isinstance(node, str):
                found.append(node)
    return found


def _set(document: Any, path: tuple[Any, ...], new: Any) -> Any:
    if not path:
        return new
    node = document
    for key in path[:-1]:
        node = node[key]
    node[path[-1]] = new
    return document


def _delete(document: Any, path: tuple[Any, ...]) -> Any:
    if not path:
        return {}
    node = document
    for key in path[:-1]:
        node = node[key]
    del node[path[-1]]
    return document


def mutate(rng: random.Random, text: str) -> bytes:
    """One bad version of a document's text."""
    document = json.loads(text)
    paths = list(_paths(document))
    way = rng.randrange(12)
    if way == 0:  # broken JSON text
        cut = rng.randrange(1, max(2, len(text)))
        return text[:cut].encode()
    if way == 1:  # odd bytes and encodings
        return rng.choice(
            [b"", b"\xff\xfe{}", b"\xef\xbb\xbf" + text.encode(), text.encode("utf-16"), b"null"]
        )
    if way == 2:  # a duplicated key in the text
        return text.replace("{", '{"id": "dup", "id": "dup2", ', 1).encode()
    if way == 3:  # NaN, Infinity, huge numbers in the text
        return text.replace(
            ": 1", rng.choice([": NaN", ": Infinity", ": 1e999", ": -1e999", ": 10000000000000000000000"]), 1
        ).encode()
    if way == 4:  # deep nesting
        depth = rng.choice([100, 5_000, 20_000])
        return ("[" * depth + "]" * depth).encode()
    path = rng.choice(paths)
    if way in (5, 6):  # a key removed
        if path:
            _delete(document, path)
        else:
            document = {}
    elif way in (7, 8):  # a value of another type or size
        document = _set(document, path, copy.deepcopy(rng.choice(ODD)))
    elif way == 9:  # an id duplicated, or an unknown one
        ids = _ids(document)
        strings = [p for p in paths if p and isinstance(_get(document, p), str)]
        if ids and strings:
            target = rng.choice(strings)
            document = _set(
                document, target, rng.choice([*ids, "nosuchfeature", "Root_Feature", ids[0].upper()])
            )
    elif way == 10:  # a list emptied or repeated
        lists = [p for p in paths if isinstance(_get(document, p), list)]
        if lists:
            target = rng.choice(lists)
            items = _get(document, target)
            document = _set(document, target, [] if rng.random() < 0.5 else items + items)
    else:  # a number scaled out of range
        numbers = [
            p
            for p in paths
            if isinstance(_get(document, p), int | float) and not isinstance(_get(document, p), bool)
        ]
        if numbers:
            target = rng.choice(numbers)
            document = _set(document, target, _get(document, target) * rng.choice([-1, 0, 1e6, 1e-9]))
    return json.dumps(document, indent=1, allow_nan=True).encode()


def _get(document: Any, path: tuple[Any, ...]) -> Any:
    node = document
    for key in path:
        node = node[key]
    return node


def commands(kind: str, folder: Path, variant: str, out: Path) -> list[list[str]]:
    """The commands that read a document of this kind (each writing, if at all, below `out`)."""
    robot = str(folder)
    run = [
        "run",
        robot,
        "--variant",
        variant,
        "--duration",
        "0.005",
        "--clock",
        "simulated",
        "--no-control",
        "--no-live",
    ]
    checking = [["validate", robot], ["validate", robot, "--variant", variant]]
    if kind in ("model", "configuration", "decisions"):
        return [
            *checking,
            ["show", robot, "--variant", variant],
            ["configure", robot, "--variant", variant, "-o", str(out / "configure")],
            ["diff", robot, variant, variant],
            run,
        ]
    if kind == "architecture":
        return [*checking, ["graph", robot, "--variant", variant, "-o", str(out / "graph")], run]
    if kind == "coordination":
        return [*checking, ["export", "scxml", robot, "-o", str(out / "chart.scxml")], run]
    return [*checking, ["configure", robot, "--variant", variant, "-o", str(out / "configure")], run]


def snapshot(out: Path) -> dict[str, bytes]:
    return {str(p.relative_to(out)): p.read_bytes() for p in sorted(out.rglob("*")) if p.is_file()}


def corpus(kind: str) -> Iterator[tuple[int, bytes]]:
    robot, name, _ = KINDS[kind]
    text = (ROOT / "feature_models" / robot / name).read_text()
    rng = random.Random(f"{SEED}-{kind}")
    for number in range(PER_KIND):
        yield number, mutate(rng, text)


def prepare(tmp: Path, kind: str) -> tuple[Path, Callable[[bytes], None]]:
    robot, name, _ = KINDS[kind]
    if kind == "manifest":  # the manifest lives in the plugin folders: copy them beside the robot
        shutil.copytree(ROOT / "plugins", tmp / "plugins")
    folder = tmp / "feature_models" / robot
    shutil.copytree(ROOT / "feature_models" / robot, folder)
    target = (folder / name).resolve()

    def put(data: bytes) -> None:
        target.write_bytes(data)

    return folder, put


@pytest.mark.parametrize("kind", sorted(KINDS))
def test_every_command_survives_the_corpus(tmp_path: Path, kind: str) -> None:
    folder, put = prepare(tmp_path, kind)
    _, _, variant = KINDS[kind]
    out = tmp_path / "out"
    runner = CliRunner()
    # earlier output that a failing command must leave as it was
    for args in commands(kind, folder, variant, out):
        if args[0] in ("configure", "graph", "export"):
            runner.invoke(main, args)
    failures: list[str] = []
    documents = 0
    for number, data in corpus(kind):
        put(data)
        documents += 1
        for args in commands(kind, folder, variant, out):
            before = snapshot(out)
            result = runner.invoke(main, args)
            exits = EXITS | ({4} if args[0] == "diff" else set()) | ({130} if args[0] == "run" else set())
            crashed = result.exception is not None and not isinstance(result.exception, SystemExit)
            if crashed or result.exit_code not in exits or "Traceback" in result.output:
                failures.append(f"{kind} #{number} {args[0]}: exit {result.exit_code} {result.exception!r}")
            elif result.exit_code != 0 and snapshot(out) != before:
                failures.append(f"{kind} #{number} {args[0]}: exit {result.exit_code} but its output changed")
    assert documents == PER_KIND
    assert not failures, "\n".join(failures[:40]) + f"\n({len(failures)} in all)"


# --------------------------------------------- the importers, records for plot, numbers
TEXT_PER_KIND = 100  # bad UVL and FeatureIDE texts each
RECORDS = 40  # bad records (each drawn by matplotlib when it reads: the slowest part)
INSERTS = ["{", "}", "[", "]", "(", ")", "'", '"', "\t", "\\", "\x00", "\x1b", "!", "&", "|", "=>", "<", ">", "&amp;", "\u202e"]
WORDS = ["alternative", "or", "mandatory", "constraints", "cardinality [1..*]", "Integer", "imports", "<alt>", "</and>", "<!ENTITY a 'b'>", "x" * 5000]


def mutate_text(rng: random.Random, text: str, deep: Callable[[int], str]) -> bytes:
    """One bad version of a text document (UVL, XML, CSV): `deep(n)` nests it n deep."""
    lines = text.splitlines(keepends=True)
    way = rng.randrange(10)
    if way == 0:  # cut anywhere
        return text[: rng.randrange(len(text) + 1)].encode()
    if way == 1:  # odd bytes and encodings
        return rng.choice([b"", b"\xff\xfe", b"\xef\xbb\xbf" + text.encode(), text.encode("utf-16"), b"\x00" * 100])
    if way == 2:  # deep nesting
        return deep(rng.choice([50, 700, 5_000])).encode()
    k = rng.randrange(len(lines))
    if way == 3:  # a line gone
        del lines[k]
    elif way == 4:  # a line twice
        lines.insert(k, lines[k])
    elif way == 5:  # two lines swapped
        j = rng.randrange(len(lines))
        lines[k], lines[j] = lines[j], lines[k]
    elif way == 6:  # the indentation changed
        lines[k] = " " * rng.choice([0, 1, 3, 40]) + lines[k].lstrip(" ")
    elif way == 7:  # a character that means something, anywhere
        at = rng.randrange(len(lines[k]) + 1)
        lines[k] = lines[k][:at] + rng.choice(INSERTS) + lines[k][at:]
    elif way == 8:  # a word that means something else
        words = lines[k].split()
        if words:
            lines[k] = lines[k].replace(rng.choice(words), rng.choice(WORDS), 1)
    else:  # a text repeated, or a number out of range
        lines = lines * rng.choice([2, 50]) if rng.random() < 0.3 else [
            re.sub(r"\d+(\.\d+)?", rng.choice(["nan", "-1", "1e999", "99999999999999999999", ""]), line, count=1)
            for line in lines
        ]
    return "".join(lines).encode()


def _uvl_deep(n: int) -> str:
    return "features\n" + "".join("    " * (k + 1) + f"F{k}\n" + "    " * (k + 2) + "optional\n" for k in range(n))


def _xml_deep(n: int) -> str:
    return "<featureModel><struct>" + "".join(f"<and name='a{k}'>" for k in range(n)) + "</and>" * n + "</struct></featureModel>"


@pytest.mark.parametrize("kind", ["uvl", "featureide"])
def test_the_importers_survive_the_corpus(tmp_path: Path, kind: str) -> None:
    """Bad UVL and FeatureIDE texts through `import`: a documented exit code, no traceback,
    nothing written when refused, and what is written is what validate accepts (issue 31)."""
    from motivml.language.featureide import write_featureide
    from motivml.language.reader import load_model

    if kind == "uvl":
        text, deep = (ROOT / "guidelines" / "examples" / "mobile_base.uvl").read_text(), _uvl_deep
    else:
        model, _ = load_model(str(ROOT / "feature_models" / "simplebot" / "model.json"))
        assert model is not None
        text, deep = write_featureide(model), _xml_deep
    rng = random.Random(f"{SEED}-{kind}")
    runner = CliRunner()
    failures: list[str] = []
    codes: list[int] = []
    for number in range(TEXT_PER_KIND):
        source = tmp_path / f"m{number}.{'uvl' if kind == 'uvl' else 'xml'}"
        source.write_bytes(mutate_text(rng, text, deep))
        out = tmp_path / f"out{number}"
        result = runner.invoke(main, ["import", kind, str(source), "-o", str(out)])
        codes.append(result.exit_code)
        crashed = result.exception is not None and not isinstance(result.exception, SystemExit)
        if crashed or result.exit_code not in EXITS or "Traceback" in result.output:
            failures.append(f"{kind} #{number} import: exit {result.exit_code} {result.exception!r}")
        elif result.exit_code != 0 and (out / "model.json").exists():
            failures.append(f"{kind} #{number} import: exit {result.exit_code} but it wrote model.json")
        elif result.exit_code == 0:
            checked = runner.invoke(main, ["validate", str(out / "model.json")])
            if checked.exit_code != 0:
                failures.append(f"{kind} #{number}: imported, and validate says: {checked.output[-300:]}")
    assert not failures, "\n".join(failures[:40]) + f"\n({len(failures)} in all)"
    assert codes.count(0) >= 10 and codes.count(1) >= 10, codes  # (both ways are taken)


def test_plot_survives_a_corpus_of_records(tmp_path: Path) -> None:
    """Bad records (cut, odd bytes, cells that are no numbers, columns moved, ...) through
    `plot`: a documented exit code, no traceback, and the picture left as it was."""
    runner = CliRunner()
    record = tmp_path / "run.csv"
    made = runner.invoke(
        main,
        ["run", str(ROOT / "feature_models" / "simplebot"), "--variant", "field", "--duration", "0.05"]
        + ["--clock", "simulated", "--no-control", "--no-live", "--record", str(record)],
    )
    assert made.exit_code == 0, made.output
    text = record.read_text()
    header = text.splitlines()[0]
    picture = tmp_path / "picture.svg"
    assert runner.invoke(main, ["plot", str(record), "-o", str(picture)]).exit_code == 0
    before = picture.read_bytes()
    rng = random.Random(f"{SEED}-record")
    failures: list[str] = []
    for number in range(RECORDS):
        bad = tmp_path / "bad.csv"
        bad.write_bytes(mutate_text(rng, text, lambda n: header + "\n" + ",".join(["1"] * n) + "\n"))
        result = runner.invoke(main, ["plot", str(bad), "-o", str(picture)])
        crashed = result.exception is not None and not isinstance(result.exception, SystemExit)
        if crashed or result.exit_code not in EXITS or "Traceback" in result.output:
            failures.append(f"record #{number} plot: exit {result.exit_code} {result.exception!r}")
        elif result.exit_code != 0 and picture.read_bytes() != before:
            failures.append(f"record #{number} plot: exit {result.exit_code} but the picture changed")
        elif result.exit_code == 0:
            before = picture.read_bytes()
    assert not failures, "\n".join(failures[:40]) + f"\n({len(failures)} in all)"


NUMBERS = ["nan", "inf", "-inf", "-1", "0", "1e-320", "1e308", "1e999", str(10**30), "abc", "", "0x10", "1_0"]


def _numeric_commands(robot: str, out: Path) -> Iterator[tuple[str, list[str]]]:
    """(the option, a command giving it `{}`) for every option that takes a number."""
    run = ["run", robot, "--variant", "field", "--clock", "simulated", "--no-control", "--no-live"]
    yield "--duration", [*run, "--duration", "{}"]
    yield "--rate", [*run, "--duration", "0.01", "--rate", "{}"]
    yield "--priority", [*run, "--duration", "0.01", "--priority", "{}"]
    yield "--at", [*run, "--duration", "0.01", "--at", "{}", "swap hectorslam kartoslam"]
    yield "--cpus", [*run, "--duration", "0.01", "--cpus", "{}"]
    yield "--count-timeout", ["analyse", robot, "--count-timeout", "{}"]
    yield "--t", ["sample", robot, "--t", "{}", "-o", str(out / "sample")]


def test_every_option_that_takes_a_number_survives_odd_numbers(tmp_path: Path) -> None:
    """NaN, infinities, overflow, underflow, negative, huge and no numbers at all, for each
    option that takes one: a usage error (2) or an answer, never a traceback. (A run of
    `--duration inf` runs until stopped, as documented: not run here.)"""
    runner = CliRunner()
    robot = str(ROOT / "feature_models" / "simplebot")
    failures: list[str] = []
    for option, command in _numeric_commands(robot, tmp_path):
        for value in NUMBERS:
            if option == "--duration" and value == "inf":
                continue  # (until stopped)
            args = [value if word == "{}" else word for word in command]
            result = runner.invoke(main, args)
            crashed = result.exception is not None and not isinstance(result.exception, SystemExit)
            if crashed or result.exit_code not in {0, 1, 2, 3} or "Traceback" in result.output:
                failures.append(f"{option} {value!r}: exit {result.exit_code} {result.exception!r}")
            elif value in ("nan", "1e999", "abc", "") and result.exit_code != 2:  # (1e999 ran until stopped)
                failures.append(f"{option} {value!r}: exit {result.exit_code}, not a usage error")
    assert not failures, "\n".join(failures)
