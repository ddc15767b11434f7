"""The package's floors and the CLI's start-up: what a command imports is what it uses."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest
from paths import ROOT

HEAVY = (
    "numpy",
    "sismic",
    "rich.live",
    "pluginbase",
    "motivml._cpp_plugins",
    "rclpy",
    "motivml.ros2",
    "matplotlib",
)

PROBE = """
import sys
from motivml.cli import main
try:
    main(sys.argv[1:], prog_name="motivml")
except SystemExit:
    pass
heavy = [name for name in {heavy!r} if name in sys.modules]
print("HEAVY:" + ",".join(heavy), file=sys.stderr)
"""


def _heavy_modules_after(*args: str) -> list[str]:
    done = subprocess.run(
        [sys.executable, "-c", PROBE.format(heavy=HEAVY), *args], cwd=ROOT, capture_output=True, text=True
    )
    (line,) = [line for line in done.stderr.splitlines() if line.startswith("HEAVY:")]
    return [name for name in line.removeprefix("HEAVY:").split(",") if name]


@pytest.mark.parametrize(
    "args",
    [
        ("--help",),
        ("--version",),
        ("validate", "feature_models/simplebot"),
        ("validate", "feature_models/simplebot", "--variant", "lab"),
        ("validate", "feature_models/coordinated_arm"),  # with a coordination statechart
        ("validate", "feature_models/simplebot", "--format", "sarif"),
        ("validate", "feature_models/simplebot", "--format", "junit"),
        ("configure", "feature_models/simplebot", "--variant", "lab", "-o", "/dev/null/never"),
        ("show", "feature_models/simplebot", "--variant", "lab"),
    ],
    ids=" ".join,
)
def test_checking_commands_load_neither_numpy_nor_sismic_nor_the_live_view_nor_plugin_loaders(
    args: tuple[str, ...],
) -> None:
    assert _heavy_modules_after(*args) == []


def test_the_probe_sees_heavy_imports_where_they_are_used() -> None:
    """The check above can fail: `run --help` lists options only, but `graph` draws the start state."""
    assert "numpy" in _heavy_modules_after(
        "graph", "feature_models/quadruped", "--variant", "trot", "-o", "/dev/null/x"
    )


def test_matplotlib_is_imported_only_to_draw_a_picture(tmp_path: Path) -> None:
    record = tmp_path / "run.csv"
    record.write_text("tick,time,A[0],events\n1,0.001,0.5,\n")
    assert _heavy_modules_after("plot", "--help") == []
    assert "matplotlib" not in _heavy_modules_after("run", "--help")
    assert "matplotlib" in _heavy_modules_after("plot", str(record), "-o", str(tmp_path / "run.svg"))
    assert (tmp_path / "run.svg").is_file()


def test_the_import_contract_holds() -> None:
    """lint-imports (make test runs it too): no loop, no upward import, pysat and click where they belong."""
    linter = Path(sys.executable).with_name("lint-imports")
    if not linter.exists():
        pytest.skip("import-linter is not installed (pip install -e '.[dev]')")
    done = subprocess.run([str(linter)], cwd=ROOT, capture_output=True, text=True)
    assert done.returncode == 0, done.stdout + done.stderr


def test_python_dash_m_runs_the_cli(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    import runpy

    from motivml import __version__

    monkeypatch.setattr(sys, "argv", ["motivml", "--version"])
    with pytest.raises(SystemExit) as ended:
        runpy.run_module("motivml.cli", run_name="__main__")
    assert ended.value.code == 0 and capsys.readouterr().out == f"motivml, version {__version__}\n"


def test_an_unknown_command_is_a_usage_error_listing_none_of_the_modules() -> None:
    from click.testing import CliRunner

    from motivml.cli import COMMANDS, main

    result = CliRunner().invoke(main, ["valdate", "x"])
    assert result.exit_code == 2 and "No such command 'valdate'" in result.output
    assert sorted(main.list_commands(None)) == sorted(COMMANDS)  # type: ignore[arg-type]


LONGEST_CLASS, LONGEST_FUNCTION = 250, 80  # lines, in runtime/ and cli/ (issue 34)


def test_classes_and_functions_of_the_runtime_and_the_cli_stay_short() -> None:
    """No class over 250 lines and no function over 80 (its signature and docstring
    included) in motivml/runtime/ and motivml/cli/: the stages that hold state and policy
    stay readable in pieces."""
    import ast

    too_long: list[str] = []
    for path in sorted([*(ROOT / "motivml" / "runtime").glob("*.py"), *(ROOT / "motivml" / "cli").glob("*.py")]):
        for node in ast.walk(ast.parse(path.read_text())):
            limit = (
                LONGEST_CLASS
                if isinstance(node, ast.ClassDef)
                else LONGEST_FUNCTION
                if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef)
                else None
            )
            if limit is not None and node.end_lineno is not None and node.end_lineno - node.lineno + 1 > limit:
                too_long.append(f"{path.relative_to(ROOT)}:{node.lineno} {node.name}: {node.end_lineno - node.lineno + 1} lines")
    assert too_long == []


# ----------------------------------------------------------- the flow down the floors
def _floors() -> dict[str, int]:
    """Each package or module of the floors contract, by its floor (0 is the top: the CLI)."""
    import tomllib

    contracts = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["importlinter"]["contracts"]
    (layers,) = [c["layers"] for c in contracts if c["type"] == "layers"]
    return {name.strip(): floor for floor, entry in enumerate(layers) for name in entry.split("|")}


def _returns_up(args: list[str]) -> dict[tuple[str, str], int]:
    """The calls that go back up to a floor the flow had left, followed through one command
    (every thread it starts): a function of a lower floor calling one of a higher floor, as
    a callback does. Caller and callee are the nearest frames in motivml (the standard
    library's and other packages' frames between them are skipped). Each place counts
    once, however often it is called: (caller, callee) -> calls."""
    import threading
    from types import FrameType

    from click.testing import CliRunner

    from motivml.cli import main

    floors = _floors()

    def floor(frame: FrameType) -> int | None:
        parts = str(frame.f_globals.get("__name__", "")).split(".")
        for n in range(len(parts), 1, -1):
            found = floors.get(".".join(parts[:n]))
            if found is not None:
                return found
        return None

    def where(frame: FrameType) -> str:
        return f"{frame.f_globals['__name__']}.{frame.f_code.co_qualname}"

    up: dict[tuple[str, str], int] = {}

    def profile(frame: FrameType, event: str, _: object) -> None:
        if event != "call" or (callee := floor(frame)) is None:
            return
        caller = frame.f_back
        while caller is not None and floor(caller) is None:
            caller = caller.f_back
        if caller is not None and callee < (floor(caller) or 0):
            key = (where(caller), where(frame))
            up[key] = up.get(key, 0) + 1

    threading.setprofile(profile)
    sys.setprofile(profile)
    try:
        result = CliRunner().invoke(main, args)
    finally:
        sys.setprofile(None)
        threading.setprofile(None)
    assert result.exit_code == 0, result.output
    return up


@pytest.mark.parametrize(
    "args",
    [
        ["validate", "feature_models/simplebot/model.json", "--config", "feature_models/simplebot/variants/field.json"],
        ["validate", "feature_models/simplebot/model.json"],
        [
            "run", "feature_models/simplebot", "--variant", "field", "--duration", "0.01", "--clock", "simulated",
            "--no-control", "--no-live", "--at", "0.005", "swap hectorslam kartoslam",
        ],
    ],
    ids=["validate a variant", "validate a model", "a hot swap"],
)
def test_a_model_and_a_request_go_down_the_floors_with_at_most_five_returns(
    args: list[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    """How issue 34 tells the layers are kept: a model in `validate` and a request in a hot
    swap go down the floors, going back up to a floor already left at most five times
    (the schema check calling its reader back, a plugin reading and writing its spaces)."""
    monkeypatch.chdir(ROOT)
    up = _returns_up(args)
    assert len(up) <= 5, "\n".join(f"{caller} -> {callee} ({calls} calls)" for (caller, callee), calls in up.items())
    assert all(caller.startswith("motivml.") and callee.startswith("motivml.") for caller, callee in up)
