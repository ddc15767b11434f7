"""The `motivml` command line: parse, call the library, print with rich, pick exit codes.

Exit codes: 0 valid, 1 invalid (model or configuration), 2 usage, 3 environment, 130
interrupted (Ctrl-C). An OSError no stage turned into a located error (a permission, a name
too long) still ends with its path and reason and exit code 3, never a traceback.
This package is the only place that imports click or rich, and the only place that turns
errors into exit codes. One module per family of commands, imported only when one of its
commands runs (or `--help` lists them), and each command imports the stages it uses only
when it runs, so that `motivml validate` pays for neither numpy nor sismic:

* `checking`: validate, show, configure, diff (the model and its variants);
* `analysing`: analyse and sample (what a model allows: section 7's analyses and counts,
  t-wise samples);
* `running`: run and ctl (the robot at run time);
* `drawing`: graph, plot, export and import (pictures of the model, the architecture and a
  run's record; SCXML, DIMACS and UVL);
* `menuconfig`: the terminal configurator (Textual, imported only when it runs);
* `building`: cmake-dir (the CMake package for C++ projects).

`common` holds what the commands share (printing diagnostics, --variant and --config),
`reports` validate's machine formats (JSON, SARIF, JUnit XML).
"""

from __future__ import annotations

import atexit
import importlib
import os
import sys
import threading

import click

from .. import __version__

INTERRUPTED = 130  # the exit code of a command ended by Ctrl-C, as a shell reports SIGINT

COMMANDS = {  # command name -> the module of this package that defines it, and its function
    "validate": ("checking", "validate_command"),
    "configure": ("checking", "configure_command"),
    "diff": ("checking", "diff_command"),
    "show": ("checking", "show_command"),
    "menuconfig": ("menuconfig", "menuconfig_command"),
    "cmake-dir": ("building", "cmake_dir_command"),
    "analyse": ("analysing", "analyse_command"),
    "sample": ("analysing", "sample_command"),
    "compile": ("analysing", "compile_command"),
    "run": ("running", "run_command"),
    "ctl": ("running", "ctl_command"),
    "graph": ("drawing", "graph_command"),
    "plot": ("drawing", "plot_command"),
    "export": ("drawing", "export_command"),
    "import": ("drawing", "import_command"),
    "fleet": ("fleeting", "fleet_group"),
}

LONG_RUNNING = frozenset({"run", "ctl", "menuconfig"})  # the others use loader.one_command


class LazyGroup(click.Group):
    """A group that imports a command's module when the command is looked up."""

    def list_commands(self, ctx: click.Context) -> list[str]:
        return sorted(COMMANDS)

    def get_command(self, ctx: click.Context, cmd_name: str) -> click.Command | None:
        if cmd_name not in COMMANDS:
            return None
        module, function = COMMANDS[cmd_name]
        command: click.Command = getattr(importlib.import_module(f".{module}", __name__), function)
        return command

    def resolve_command(
        self, ctx: click.Context, args: list[str]
    ) -> tuple[str | None, click.Command | None, list[str]]:
        """The command to run; a command that does one job and ends runs in
        `loader.one_command` (its collector policy) until the group's context closes."""
        name, command, rest = super().resolve_command(ctx, args)
        # (not while the shell completes a command line: click never closes that context)
        if command is not None and name not in LONG_RUNNING and not ctx.resilient_parsing:
            from ..process import one_command

            ctx.with_resource(one_command())
            global _one_job
            _one_job = True
        return name, command, rest

    def invoke(self, ctx: click.Context) -> object:
        """Run the command; Ctrl-C anywhere (a solver, a file read) ends it with one line and 130."""
        try:
            return super().invoke(ctx)
        except KeyboardInterrupt:
            click.echo("interrupted", err=True)
            raise click.exceptions.Exit(INTERRUPTED) from None
        except OSError as exc:  # the environment (permissions, a name too long): exit 3, located
            from .common import environment_problem, fail

            fail(environment_problem(exc))
        except Exception as exc:
            if "pysolvers" not in sys.modules:  # (no solver has run: not a solver's error)
                raise
            from ..binding.encoding import solver_interrupted

            if not solver_interrupted(exc):
                raise
            click.echo("interrupted", err=True)  # (as above: pysat turns Ctrl-C in a solve into its own error)
            raise click.exceptions.Exit(INTERRUPTED) from None


@click.group(cls=LazyGroup, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="motivml")
def main() -> None:
    """motivml: variability models for robot software (MoTiVML)."""


_one_job = False  # a command that does one job and ends (not run, ctl or menuconfig) was started


def console() -> None:
    """The `motivml` program (its installed script, and `python -m motivml`): `main`, and
    then, after a command that does one job, the process ends at once, its output flushed
    and its atexit handlers run, without freeing what the command built object by object
    (as mypy does): at 100,000 features that took 0.1 s of a 1.8 s `validate --config`.

    Where another thread still runs, or the output cannot be flushed (a closed pipe), the
    process ends as Python ends it. Callers in this process (tests, scripts) use `main`.
    """
    from ..process import ending_with_the_command

    global _one_job
    _one_job = False
    ending_with_the_command()
    try:
        main(prog_name="motivml")
    except SystemExit as exc:
        code = exc.code
        if _one_job and (code is None or isinstance(code, int)) and threading.active_count() == 1:
            _end_now(code or 0)
        raise


def _end_now(code: int) -> None:
    """Flush, run the atexit handlers, flush again and end the process with `code`; return
    (ending nothing) when the output cannot be flushed."""
    try:
        sys.stdout.flush()
        sys.stderr.flush()
    except (OSError, ValueError):  # (Python's own exit says what became of the output)
        return
    atexit._run_exitfuncs()
    try:
        sys.stdout.flush()
        sys.stderr.flush()
    except (OSError, ValueError):
        code = code or 1
    os._exit(code)

