"""plot: a run's record (motivml run --record) drawn as its spaces over time, with its events."""

from __future__ import annotations

import io
from pathlib import Path

import click

from ..errors import DocumentError, EnvironmentProblem, Location, MotivmlError, error
from .common import fail, out, plural

KINDS = {  # event kind -> (colour, line style, label in the legend)
    "reconfiguration": ("tab:blue", "-", "reconfiguration"),
    "fault": ("tab:red", "-", "fault"),
    "coordination": ("tab:green", ":", "coordination state"),
}


@click.command("plot")
@click.argument("record", type=click.Path())
@click.option("-o", "--output", required=True, type=click.Path(), help="The picture: PLOT.svg or PLOT.png.")
@click.option("--title", help="The picture's title (default: the record's file name).")
def plot_command(record: str, output: str, title: str | None) -> None:
    """Draw a run's record: each space over time, one panel per space, with the run's events marked.

    RECORD is the CSV that motivml run --record wrote. Reconfigurations are drawn as blue
    lines (labelled with the request), faults red, coordination states entered green dotted.
    """
    suffix = Path(output).suffix.lower()
    if suffix not in (".svg", ".png"):
        raise click.BadParameter(f"{output!r}: the picture is .svg or .png", param_hint="'-o'")
    from ..documents.writing import write_if_changed
    from ..runtime.record import RecordError, read_record

    try:
        try:
            data = read_record(record)
        except RecordError as exc:
            raise DocumentError(error(Location(record, exc.line, 1), exc.message, "record")) from None
        except UnicodeDecodeError:
            raise DocumentError(
                error(Location(record), "not UTF-8 text: not a run record", "record")
            ) from None
        except OSError as exc:
            raise EnvironmentProblem(
                error(Location(record), f"cannot read: {exc.strerror or exc}", "io")
            ) from None
        picture = _draw(data, title or Path(record).name, suffix[1:])
        write_if_changed(Path(output).parent, {Path(output).name: picture})
    except MotivmlError as exc:
        fail(exc)
    shown = sum(1 for _, event in data.events if _kind(event) is not None)
    out.print(
        f"wrote {output}: {plural(len(data.spaces), 'space')} over {data.time[-1]:g} s, "
        f"{plural(shown, 'event')} marked"
    )


def _kind(event: str) -> str | None:
    kind, _, text = event.partition(": ")
    if kind in ("reconfiguration", "fault"):
        return kind
    if kind == "note" and text.startswith("coordination: entered "):
        return "coordination"
    return None


def _draw(data: object, title: str, form: str) -> bytes:
    import matplotlib

    matplotlib.use("Agg")  # no display: over ssh and in CI alike
    matplotlib.rcParams["svg.hashsalt"] = "motivml"  # the same record draws the same bytes
    import matplotlib.pyplot as plt

    from ..runtime.record import Record

    assert isinstance(data, Record)
    panels = max(len(data.spaces), 1)
    figure, axes = plt.subplots(panels, 1, sharex=True, figsize=(8, 1.8 + 1.6 * panels), squeeze=False)
    for axis, (sid, values) in zip(axes[:, 0], data.spaces.items(), strict=False):
        for i in range(values.shape[1]):
            axis.plot(data.time, values[:, i], linewidth=1, label=f"{sid}[{i}]")
        axis.set_ylabel(sid)
        if values.shape[1] <= 6:
            axis.legend(loc="upper right", fontsize="x-small", ncols=min(values.shape[1], 3))
    if not data.spaces:
        axes[0, 0].text(
            0.5, 0.5, "no spaces in this record", ha="center", va="center", transform=axes[0, 0].transAxes
        )
    marked: set[str] = set()
    for at, event in data.events:
        kind = _kind(event)
        if kind is None:
            continue
        colour, style, label = KINDS[kind]
        for axis in axes[:, 0]:
            axis.axvline(
                at, color=colour, linestyle=style, linewidth=1, label="_" if kind in marked else label
            )
        marked.add(kind)
        text = event.partition(": ")[2].removeprefix("entered ").removeprefix("coordination: entered ")
        axes[0, 0].annotate(
            text[:40],
            (at, 1.0),
            xycoords=("data", "axes fraction"),
            rotation=90,
            fontsize="xx-small",
            va="top",
            ha="right",
            color=colour,
        )
    axes[-1, 0].set_xlabel("control time (s)")
    figure.suptitle(title)
    figure.tight_layout()
    buffer = io.BytesIO()
    figure.savefig(buffer, format=form, metadata={"Date": None} if form == "svg" else None)
    plt.close(figure)
    return buffer.getvalue()
