"""motivml menuconfig: the session behind it, and the application driven headless.

The application runs under Textual's pilot in an 80x24 screen: the keys a person presses
(arrows to navigate, y/n/u, t, m, ?, a digit, s, q), and what the tree, the detail panel and
the saved file show afterwards. The saved file is then checked by `validate` as any variant.
"""

from __future__ import annotations

import asyncio
import json
import shutil
from collections.abc import Awaitable, Callable
from pathlib import Path
from typing import Any

import pytest
from click.testing import CliRunner
from paths import SIMPLEBOT

from motivml.binding.configurator import Configurator
from motivml.cli import main
from motivml.cli.menuconfig import MenuConfig, open_session
from motivml.errors import repair_text
from motivml.language.model import Mode, Time
from motivml.language.reader import load_model


@pytest.fixture(autouse=True)
def no_live_counts(request: pytest.FixtureRequest, monkeypatch: pytest.MonkeyPatch) -> None:
    """The labels these tests read are those without live counts (whose compile in the
    background would add a share to them at a moment of its own); the tests of live counts
    are marked `live_counts`."""
    if request.node.get_closest_marker("live_counts") is None:
        from motivml.cli import menuconfig_app

        monkeypatch.setattr(menuconfig_app.LiveCounts, "start", lambda self: None)


@pytest.fixture
def robot(tmp_path: Path) -> Path:
    folder = tmp_path / "simplebot"
    shutil.copytree(SIMPLEBOT, folder)
    return folder


# ------------------------------------------------------------------------------ session
def test_a_decision_propagates_at_once() -> None:
    model, _ = load_model(SIMPLEBOT / "model.json")
    assert model is not None
    session = Configurator(model, "new.json")
    assert session.valid and session.decisions == {}
    assert "off" in session.possible("slam")
    session.select("kartoslam", True)
    assert "off" not in session.possible("slam") and "off" not in session.possible("grid_map")  # forced
    assert {str(b) for b in session.possible("grid_map")} == {"SE", "SL"}  # slam requires it: Static
    assert session.possible("amcl") == {"off"}  # amcl excludes slam, and amcl is Static only


def test_a_conflict_offers_repairs_and_one_applies() -> None:
    model, _ = load_model(SIMPLEBOT / "model.json")
    assert model is not None
    session = Configurator(model, "new.json")
    session.select("kartoslam", True)
    session.bind("grid_map", None, Mode.DYNAMIC)
    assert not session.valid
    assert [repair_text(r) for r in session.repairs] == ["deselect kartoslam", "make grid_map Static"]
    session.apply(session.repairs[1])
    assert session.valid
    assert json.loads(session.text())["properties"] == [
        {"id": "grid_map", "props": {"mode": "Static"}},
        {"id": "kartoslam"},
    ]


def test_deselecting_drops_a_binding_and_binding_selects() -> None:
    model, _ = load_model(SIMPLEBOT / "model.json")
    assert model is not None
    session = Configurator(model, "new.json")
    session.bind("navigation", Time.LATE, Mode.DYNAMIC)
    assert json.loads(session.text())["properties"] == [
        {"id": "navigation", "props": {"time": "Late", "mode": "Dynamic"}}
    ]
    session.select("navigation", False)
    assert json.loads(session.text())["properties"] == [{"id": "navigation", "selected": False}]
    session.select("navigation", None)
    assert session.decisions == {}
    with pytest.raises(ValueError, match="the root is always selected"):
        session.select("root_feature", False)


def test_an_existing_variant_is_read_with_its_x_keys(robot: Path) -> None:
    session, path = open_session(str(robot), "warehouse", None)
    assert path == robot / "variants" / "warehouse.json"
    assert list(session.decisions)[:2] == ["depth_camera", "teleoperation"]
    assert "x-description" in json.loads(session.text())
    assert not session.unsaved


# -------------------------------------------------------------------------- application
def drive(session: Configurator, path: Path, steps: Callable[[Any, Any], Awaitable[None]]) -> Any:
    """Run the application headless in an 80x24 screen and play `steps` on it."""
    app = MenuConfig(session, path)

    async def play() -> None:
        async with app.run_test(size=(80, 24)) as pilot:
            await steps(app, pilot)

    asyncio.run(play())
    return app


async def go_to(app: Any, pilot: Any, feature: str) -> None:
    """Move the cursor down to `feature`, as a person would with the arrow keys."""
    tree = app.query_one("#features")
    for _ in range(len(app.nodes) + 1):
        if tree.cursor_node is not None and tree.cursor_node.data == feature:
            return
        await pilot.press("down")
    raise AssertionError(f"the cursor never reached {feature}")


def label(app: Any, feature: str) -> str:
    return str(app.nodes[feature].label)


def detail(app: Any) -> str:
    return str(app.query_one("#text").render())


def test_navigate_change_see_propagation_repair_and_save(robot: Path) -> None:
    session, path = open_session(str(robot), "sketch", None)
    seen: dict[str, str] = {}

    async def steps(app: Any, pilot: Any) -> None:
        seen["slam before"] = label(app, "slam")
        await go_to(app, pilot, "kartoslam")
        await pilot.press("y")  # select kartoslam
        seen["kartoslam"] = label(app, "kartoslam")
        seen["slam after"] = label(app, "slam")  # forced on, locked
        seen["grid_map after"] = label(app, "grid_map")  # forced on, forced Static
        await pilot.press("up", "up", "up")  # back to grid_map
        assert app.query_one("#features").cursor_node.data == "grid_map"
        await pilot.press("m", "m")  # Static, then Dynamic: slam requires it Static
        seen["conflict"] = detail(app)
        await pilot.press("s")  # refused while the decisions conflict
        seen["saved while invalid"] = str(path.exists())
        await pilot.press("2")  # make grid_map Static
        seen["repaired"] = detail(app)
        await pilot.press("question_mark")
        seen["why"] = detail(app)
        await pilot.press("s")
        await pilot.press("q")

    app = drive(session, path, steps)
    assert seen["slam before"] == "( ) ? slam  **"
    assert seen["kartoslam"] == "[x] [XOR] kartoslam  **"
    assert seen["slam after"] == "-x- ? slam  **"
    assert seen["grid_map after"] == "-x- ? grid_map  S*"
    assert seen["conflict"].startswith(
        "no valid variant: kartoslam is a sub-feature of slam; slam requires grid_map"
    )
    assert "repairs (press the digit):\n1 deselect kartoslam\n2 make grid_map Static" in seen["conflict"]
    assert seen["saved while invalid"] == "False"
    assert seen["repaired"].startswith("valid: 2 decisions")
    assert seen["why"].startswith("grid_map is selected: the configuration says so")
    assert "grid_map is Static: the configuration says so" in seen["why"]
    assert app.return_code in (None, 0)
    assert json.loads(path.read_text()) == {
        "partial": True,
        "properties": [{"id": "grid_map", "props": {"mode": "Static"}}, {"id": "kartoslam"}],
    }
    result = CliRunner().invoke(main, ["validate", str(robot / "model.json"), "--config", str(path)])
    assert result.exit_code == 0, result.output
    assert f"valid: {path} (16 features and 2 bindings left to the configurator)" in result.output


@pytest.mark.parametrize("key", ["q", "ctrl+q"])  # (issue 31: Textual's own Ctrl+Q lost them at once)
def test_quitting_with_unsaved_decisions_asks_again(robot: Path, key: str) -> None:
    session, path = open_session(str(robot), "warehouse", None)
    before = path.read_bytes()
    states: list[bool] = []

    async def steps(app: Any, pilot: Any) -> None:
        await go_to(app, pilot, "navigation")
        await pilot.press("n")
        await pilot.press(key)
        states.append(app.is_running)
        await pilot.press(key)

    app = drive(session, path, steps)
    assert states == [True] and not app.is_running and app.return_code == 0
    assert path.read_bytes() == before  # quit without saving: the file is as it was


def test_the_root_cannot_be_changed(robot: Path) -> None:
    session, path = open_session(str(robot), "fresh", None)

    async def steps(app: Any, pilot: Any) -> None:
        await pilot.press("n", "t", "m")
        await pilot.press("q")

    drive(session, path, steps)
    assert session.decisions == {} and not path.exists()


def test_menuconfig_needs_a_terminal_and_a_file(robot: Path) -> None:
    runner = CliRunner()
    no_file = runner.invoke(main, ["menuconfig", str(robot)])
    assert no_file.exit_code == 2 and "give --variant NAME (variants/NAME.json of the robot folder) or --config FILE" in no_file.output
    bad_name = runner.invoke(main, ["menuconfig", str(robot), "--variant", "../elsewhere"])
    assert bad_name.exit_code == 2 and "a variant's name is letters" in bad_name.output
    no_tty = runner.invoke(main, ["menuconfig", str(robot), "--variant", "lab"])
    assert no_tty.exit_code == 2 and "menuconfig needs a terminal" in no_tty.output
    broken = robot / "variants" / "broken.json"
    broken.write_text("{")
    unreadable = runner.invoke(main, ["menuconfig", str(robot), "--variant", "broken"])
    assert unreadable.exit_code == 1 and "broken.json:1:2" in unreadable.output


def test_time_mode_undecide_and_refusals_in_the_application(tmp_path: Path) -> None:
    """t and m cycle open -> Early/Static -> Late/Dynamic -> open; u undecides; a digit with
    no repair, ? while the decisions conflict and a save that cannot be written are said,
    and change nothing."""
    blocked = tmp_path / "not-a-folder"
    blocked.write_text("a file where the variant's folder would be\n")
    session, path = open_session(str(SIMPLEBOT / "model.json"), None, str(blocked / "v.json"))
    seen: list[str] = []

    async def steps(app: Any, pilot: Any) -> None:
        await go_to(app, pilot, "navigation")
        for key in ("t", "t", "t", "m", "u"):
            await pilot.press(key)
            seen.append(label(app, "navigation"))
        await pilot.press("5")  # no repair 5: the decisions are valid
        await go_to(app, pilot, "hands")
        await pilot.press("y", "m")  # hands Static: it allows only Dynamic
        seen.append(detail(app).splitlines()[0])
        await pilot.press("question_mark")  # refused: repair first
        seen.append(detail(app).splitlines()[0])
        await pilot.press("1", "s")
        await pilot.pause()
        seen.append(str([n.message for n in app._notifications]))
        await pilot.press("q", "q")

    drive(session, path, steps)
    assert seen[:5] == [
        "[x] ? navigation  *E",
        "[x] ? navigation  *L",
        "[x] ? navigation  **",  # still selected: only the time is open again
        "[x] ? navigation  S*",
        "( ) ? navigation  **",
    ]
    assert seen[5].startswith("no valid variant: hands allows only Dynamic binding")
    assert seen[6] == seen[5]  # ? did not replace the conflict
    assert "there is no repair 5" in seen[7] and "repair them first" in seen[7]
    assert "cannot write" in seen[7] and not path.exists()


def test_ctrl_c_and_sigterm_end_it_with_their_codes(robot: Path) -> None:
    """Issue 31: Ctrl-C did not end it as an interrupt (130); SIGTERM and SIGHUP left the
    terminal in the alternate screen. Now Ctrl-C ends it with 130, and SIGTERM through the
    application, which gives the terminal back, with 143."""
    import os
    import signal

    path = open_session(str(robot), "warehouse", None)[1]
    before = path.read_bytes()

    async def interrupt(app: Any, pilot: Any) -> None:
        await pilot.press("n", "ctrl+c")

    app = drive(*open_session(str(robot), "warehouse", None), interrupt)
    assert app.return_code == 130 and path.read_bytes() == before

    async def terminate(app: Any, pilot: Any) -> None:
        os.kill(os.getpid(), signal.SIGTERM)
        await pilot.pause()

    app = drive(*open_session(str(robot), "warehouse", None), terminate)
    assert app.return_code == 128 + signal.SIGTERM
    assert signal.getsignal(signal.SIGTERM) == signal.SIG_DFL  # (given back when the application ended)


def test_the_command_says_interrupted_and_exits_with_the_applications_code(
    robot: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from motivml.cli import menuconfig

    class Ended:
        def __init__(self, code: int) -> None:
            self.return_code = code

        def run(self) -> None:
            pass

    monkeypatch.setattr(menuconfig, "_on_a_terminal", lambda: True)
    for code, said in ((130, "interrupted"), (143, ""), (0, "")):
        monkeypatch.setattr(menuconfig, "MenuConfig", lambda session, path, code=code: Ended(code))
        result = CliRunner().invoke(main, ["menuconfig", str(robot), "--variant", "warehouse"])
        assert result.exit_code == code and said in result.output, result.output


def test_slash_searches_ids_and_names_and_jumps_to_the_next_match(robot: Path) -> None:
    """Issue 33: menuconfig had no search (Kconfig's `/`). Typing lists the features whose
    id or name holds the text; Enter jumps to the next match after the cursor, opening the
    tree down to it, and the keys act on it at once; Escape closes the search."""
    session, path = open_session(str(robot), "sketch", None)
    seen: dict[str, Any] = {}

    async def steps(app: Any, pilot: Any) -> None:
        tree = app.query_one("#features")
        await pilot.press("slash", *"SLAM")  # (any case: slam, hectorslam, kartoslam, orbslam)
        seen["listed"] = detail(app)
        await pilot.press("enter")
        seen["first"] = tree.cursor_node.data
        await pilot.press("slash", "enter")
        seen["second"] = tree.cursor_node.data
        await pilot.press("y")  # the keys are the tree's again
        seen["selected"] = label(app, seen["second"])
        await pilot.press("slash", "ctrl+a", "ctrl+k", *"nothing like it")
        seen["none"] = detail(app)
        await pilot.press("escape")
        seen["closed"] = app.query_one("#search").display
        await pilot.press("q", "q")

    drive(session, path, steps)
    assert seen["listed"].startswith(
        "4 matches (Enter jumps to the first one after the cursor)\nslam (SLAM) in root_feature > localization\n"
    )
    assert "hectorslam (HectorSLAM) in root_feature > localization > slam" in seen["listed"]
    assert (seen["first"], seen["second"]) == ("slam", "hectorslam")
    assert seen["selected"] == "[x] [XOR] hectorslam  **"
    assert seen["none"] == "no feature's id or name holds 'nothing like it'"
    assert seen["closed"] is False


def held_propagations(robot: Path, monkeypatch: pytest.MonkeyPatch, mark_after: float) -> tuple[Any, Path, Any]:
    """A session of simplebot counted as large (its propagations off the UI thread), with
    the mark due after `mark_after` seconds, whose propagations wait until the test sets
    the event returned."""
    import threading

    from motivml.binding.configurator import Configurator as Session
    from motivml.cli import menuconfig_app

    monkeypatch.setattr(menuconfig_app.Propagation, "LARGE", 1)
    monkeypatch.setattr(menuconfig_app.Propagation, "MARK_AFTER", mark_after)
    session, path = open_session(str(robot), "sketch", None)
    go = threading.Event()
    real = Session.propagate

    def held(self: Session, decisions: dict[str, Any]) -> Any:
        assert go.wait(30), "the test never let the propagation go"
        return real(self, decisions)

    monkeypatch.setattr(Session, "propagate", held)
    return session, path, go


def test_on_a_large_model_a_key_press_redraws_before_the_propagation_ends(
    robot: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Issue 33: a decision on a large model is drawn at once and propagated off the UI
    thread, "propagating" shown meanwhile, and what needs the consequences (save, why, a
    repair) waits for them. The propagation is held here until the test lets it go; of two
    decisions made meanwhile, the second's consequences are the ones shown."""
    from motivml.binding.configurator import Configurator as Session

    # (the mark as soon as the loop turns)
    session, path, go = held_propagations(robot, monkeypatch, mark_after=0.001)
    installed: list[Any] = []
    real_install = Session.install

    def counted(self: Session, found: Any) -> None:
        installed.append(found)
        real_install(self, found)

    monkeypatch.setattr(Session, "install", counted)
    seen: dict[str, Any] = {}

    async def steps(app: Any, pilot: Any) -> None:
        await go_to(app, pilot, "kartoslam")
        await pilot.press("y")
        seen["drawn"] = label(app, "kartoslam")  # the decision, at once
        seen["slam while busy"] = label(app, "slam")  # its consequences not yet
        seen["panel"] = detail(app)
        seen["title"] = app.sub_title
        await pilot.press("s")  # needs the consequences: waits, nothing saved
        seen["saved while busy"] = path.exists()
        await pilot.press("n")  # a second decision before the first is propagated
        go.set()
        await app.workers.wait_for_complete()
        await pilot.pause()
        seen["after"] = label(app, "kartoslam")
        seen["slam after"] = label(app, "slam")
        seen["panel after"] = detail(app)
        seen["title after"] = app.sub_title
        seen["mark after"] = (app.propagation.marked, app.propagation._timer)
        await pilot.press("q", "q")

    drive(session, path, steps)
    assert seen["drawn"] == "[x] [XOR] kartoslam  **"
    assert seen["slam while busy"] == "( ) ? slam  **"
    assert seen["panel"] == "propagating the decision..." and seen["title"].endswith("(propagating...)")
    assert seen["saved while busy"] is False
    assert seen["after"].startswith("[ ] [XOR] kartoslam")  # the second decision's answer
    assert seen["slam after"] == "( ) ? slam  **"  # (kartoslam deselected forces nothing)
    assert seen["panel after"].startswith("valid: 1 decision")
    assert seen["title after"] == str(path) and seen["mark after"] == (False, None)  # (the mark taken back)
    assert len(installed) == 1  # the first decision's propagation, no longer the last, never installed


def test_consequences_that_come_before_the_mark_is_due_are_drawn_without_it(
    robot: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The "propagating" mark is drawn only once a propagation has taken MARK_AFTER seconds
    (two frames saved on each quick one). Here it is never due: the propagation is held
    while the test looks, and still nothing says "propagating"; the decision itself is
    drawn at once, and what needs the consequences waits for them all the same."""
    session, path, go = held_propagations(robot, monkeypatch, mark_after=3600.0)
    seen: dict[str, Any] = {}

    async def steps(app: Any, pilot: Any) -> None:
        await go_to(app, pilot, "kartoslam")
        await pilot.press("y")
        seen["drawn"] = label(app, "kartoslam")
        seen["panel"] = detail(app)
        seen["title"] = app.sub_title
        await pilot.press("s")  # needs the consequences: waits, nothing saved
        seen["saved while busy"] = path.exists()
        go.set()
        await app.workers.wait_for_complete()
        await pilot.pause()
        seen["panel after"] = detail(app)
        seen["slam after"] = label(app, "slam")
        seen["timer after"] = app.propagation._timer  # (stopped: it can no longer draw the mark)
        app.propagation._mark()  # (a timer that fires late anyway draws nothing: nothing is under way)
        seen["title after"] = app.sub_title
        await pilot.press("q", "q")

    drive(session, path, steps)
    assert seen["drawn"] == "[x] [XOR] kartoslam  **"
    assert "propagating" not in seen["panel"] and seen["title"] == str(path)
    assert seen["saved while busy"] is False
    assert seen["panel after"].startswith("valid: 1 decision")
    assert seen["slam after"].startswith("-x- ? slam")  # (kartoslam selected forces slam)
    assert seen["timer after"] is None and seen["title after"] == str(path)


def test_a_redraw_sets_only_the_labels_whose_feature_changed(robot: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Each label set has Textual look for its node's lines: a redraw sets only the labels
    of the features whose decision or states changed (and each of those), and what lives
    as long as the session is frozen out of the collector's way while it runs."""
    import gc

    from textual.widgets.tree import TreeNode

    session, path = open_session(str(robot), "sketch", None)
    set_labels: list[str] = []
    real = TreeNode.set_label

    def counted(node: Any, text: Any) -> None:
        set_labels.append(node.data)
        real(node, text)

    monkeypatch.setattr(TreeNode, "set_label", counted)
    seen: dict[str, Any] = {}

    async def steps(app: Any, pilot: Any) -> None:
        seen["frozen"] = gc.get_freeze_count()
        set_labels.clear()
        app.redraw()
        seen["nothing changed"] = list(set_labels)
        before = {f.id: (session.decided(f.id), frozenset(session.possible(f.id))) for f in session.model.features}
        await go_to(app, pilot, "kartoslam")
        set_labels.clear()
        await pilot.press("y")
        await app.workers.wait_for_complete()
        await pilot.pause()
        seen["set"] = sorted(set(set_labels))
        seen["changed"] = sorted(
            f.id
            for f in session.model.features
            if before[f.id] != (session.decided(f.id), frozenset(session.possible(f.id)))
        )
        for feature, key in (("kartoslam", "n"), ("hectorslam", "y"), ("kartoslam", "y"), ("hectorslam", "u")):
            app.query_one("#features").move_cursor(app.nodes[feature])  # (into a conflict and out of it)
            await pilot.pause()
            await pilot.press(key)
            await app.workers.wait_for_complete()
            await pilot.pause()
        seen["stale"] = [
            f.id for f in session.model.features if str(app.nodes[f.id].label) != str(app.labels.label(f.index))
        ]
        await pilot.press("q", "q")

    drive(session, path, steps)
    assert seen["frozen"] > 0
    assert seen["nothing changed"] == []
    assert "kartoslam" in seen["changed"] and "slam" in seen["changed"]
    assert seen["set"] == seen["changed"]
    assert len(seen["changed"]) < len(session.model.features)
    assert seen["stale"] == []  # every label as drawn from the session now


def test_a_propagation_that_fails_is_said_and_leaves_the_application_usable(
    robot: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from motivml.binding.configurator import Configurator as Session
    from motivml.cli import menuconfig_app

    monkeypatch.setattr(menuconfig_app.Propagation, "LARGE", 1)
    session, path = open_session(str(robot), "sketch", None)

    def broken(self: Session, decisions: dict[str, Any]) -> Any:
        raise RuntimeError("the solver fell over")

    monkeypatch.setattr(Session, "propagate", broken)
    seen: dict[str, Any] = {}

    async def steps(app: Any, pilot: Any) -> None:
        await go_to(app, pilot, "kartoslam")
        await pilot.press("y")
        await app.workers.wait_for_complete()
        await pilot.pause()
        seen["busy"] = app.propagation.busy
        seen["title"] = app.sub_title
        seen["said"] = [n.message for n in app._notifications]
        await pilot.press("q", "q")

    drive(session, path, steps)
    assert seen["busy"] is False and seen["title"] == str(path)
    assert "propagation failed: the solver fell over" in seen["said"]


@pytest.mark.live_counts
def test_live_counts_show_the_variants_left_and_each_open_features_share(robot: Path) -> None:
    """With the compiled form (made in the background on first use), the panel says how many
    variants the decisions leave and each open feature's label its share of them; a decision
    counts again at once. Checked against the form's own counts."""
    session, path = open_session(str(robot), "sketch", None)
    seen: dict[str, Any] = {}

    async def steps(app: Any, pilot: Any) -> None:
        await app.workers.wait_for_complete()
        await pilot.pause()
        seen["before"] = (detail(app), label(app, "slam"), session.left)
        await go_to(app, pilot, "slam")
        await pilot.press("y")
        await pilot.pause()
        seen["after"] = (detail(app), label(app, "slam"), session.left)
        await pilot.press("q", "q")

    drive(session, path, steps)
    form = session.form
    assert form is not None and form.kind == "variants"
    total = form.count()
    slam = form.literal(session.model.index["slam"])
    with_slam = form.count([slam])
    before, slam_label, left = seen["before"]
    assert left == total and f"{total:,} variants left" in before
    assert slam_label.endswith(f"{round(100 * with_slam / total)}%")
    after, slam_label, left = seen["after"]
    assert left == with_slam and f"{with_slam:,} variants left" in after
    assert not slam_label.endswith("%")  # (decided: no share)


@pytest.mark.live_counts
def test_quitting_stops_a_compile_under_way(robot: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Leaving menuconfig does not wait for the live counts' compile: it is told to stop."""
    import threading

    from motivml.binding import compiled

    started = threading.Event()
    ended: list[bool] = []

    def endless(variables: int, clauses: Any, projection: Any, deadline: Any, stop: Any = None) -> Any:
        started.set()
        ended.append(stop.__self__.wait(60))  # (stop is the app's Event.is_set: True once it is set)
        raise compiled.CompileTimeout

    monkeypatch.setattr(compiled, "compile_cnf", endless)
    monkeypatch.setenv(compiled.ELSEWHERE, str(robot / "forms"))
    session, path = open_session(str(robot), "sketch", None)

    async def steps(app: Any, pilot: Any) -> None:
        await asyncio.to_thread(started.wait, 60)
        await pilot.press("q", "q")

    drive(session, path, steps)
    assert ended == [True]
