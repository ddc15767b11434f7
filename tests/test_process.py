"""motivml.process: what a one-shot command may skip (a paused and frozen collector), and
that the CLI takes that policy for its one-shot commands only."""

from __future__ import annotations

from collections.abc import Iterator

import pytest

from motivml import process


def test_in_one_command_what_a_paused_collector_built_is_frozen_until_the_command_ends() -> None:
    import gc

    assert gc.get_freeze_count() == 0
    with process.no_gc():
        kept = [[k] for k in range(1000)]
    assert gc.get_freeze_count() == 0 and gc.isenabled()  # outside a command: nothing frozen
    with process.one_command():
        with process.no_gc():
            kept += [[k] for k in range(1000)]
        assert gc.get_freeze_count() >= 1000 and gc.isenabled()
        with process.one_command():  # nested: the outer command gives them back, not this one
            pass
        assert gc.get_freeze_count() >= 1000
    assert gc.get_freeze_count() == 0 and gc.isenabled()
    assert len(kept) == 2000


def test_the_cli_freezes_for_one_shot_commands_only(monkeypatch: pytest.MonkeyPatch) -> None:
    import contextlib
    import gc

    from click.testing import CliRunner

    from motivml.cli import main

    entered: list[bool] = []
    real = process.one_command

    @contextlib.contextmanager
    def watched() -> Iterator[None]:
        entered.append(True)
        with real():
            yield

    monkeypatch.setattr(process, "one_command", watched)
    runner = CliRunner()
    result = runner.invoke(main, ["validate", "feature_models/simplebot", "--variant", "field"])
    assert result.exit_code == 0, result.output
    assert entered == [True] and gc.get_freeze_count() == 0  # entered, and given back at the end
    result = runner.invoke(
        main,
        ["run", "feature_models/simplebot", "--variant", "field", "--duration", "0.01"]
        + ["--clock", "simulated", "--no-live", "--no-control"],
    )
    assert result.exit_code == 0, result.output
    assert entered == [True]  # run keeps its own collection policy
    from click.shell_completion import ShellComplete

    completions = ShellComplete(main, {}, "motivml", "_MOTIVML_COMPLETE").get_completions(["validate"], "--con")
    assert [c.value for c in completions] == ["--config"]
    assert entered == [True]  # (click never closes the context it completes in)
