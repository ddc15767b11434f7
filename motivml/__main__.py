"""python -m motivml, and the installed `motivml` script: the command line.

Ctrl-C while the command line is still being imported (click, rich and the command's
stages: the first tenth of a second or so) ends it as Ctrl-C does later, with one line
and exit code 130, not with a traceback from the import that it interrupted. This module
imports nothing of motivml's until `run` is called, so that the script's own import of it
cannot be interrupted past a line of Python.
"""

import sys

INTERRUPTED = 130  # (motivml.cli's: not imported from there, which is what may be interrupted)


def run() -> None:
    """The `motivml` program."""
    try:
        from .cli import console

        console()
    except KeyboardInterrupt:  # (a command's own Ctrl-C is caught in motivml.cli: this is start-up's)
        sys.stderr.write("interrupted\n")
        raise SystemExit(INTERRUPTED) from None


if __name__ == "__main__":
    run()
