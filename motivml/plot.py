"""Pictures of a run's record (`motivml plot`): each space's numbers over time, events marked.

One panel per space, stacked on one time axis (at most PANELS: the first ones, or those
asked for), a line per number (`[0]`, `[1]`, ..., at most LINES per space); in a
record thinned to buckets (a long run) the line goes down to each bucket's lowest value and
up to its highest, so a one-tick peak still shows. Every event is a vertical line across all
panels, its kind told by colour and dash: reconfigurations (solid blue), refused ones
(dashed grey), faults (solid red), coordination states (dotted green), criteria (dash-dot
purple), missed deadlines (thin light grey). The most telling events are also written beside
their line at the top, at most LABELS of them: faults, then reconfigurations, refusals,
states entered and criteria; the rest are lines only. Labels of events close together stand
side by side, the first left of its line, the others right of theirs. The title is the run's own
description (its robot, variant, rate and clock).

matplotlib is imported here only, when a picture is drawn: a Figure of its own on the Agg
canvas, never pyplot, so no display is needed (ssh, CI) and no global backend is changed.
SVG keeps its text as text (small, searchable) and carries no date, so the same record
gives the same file.
"""

from __future__ import annotations

import difflib
import io
import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np

from .errors import DocumentError, EnvironmentProblem, Location, error
from .runtime.record import Record, RecordedEvent

FORMATS = ("svg", "png")
PANELS = 24  # spaces drawn at most, one panel each (3,000 panels ran past two minutes)
LINES = 12  # numbers drawn at most per panel, the first ones
LABELS = 24  # events written beside their line; more would be unreadable
LABEL_LENGTH = 40  # characters of one label
CROWDED = 0.015  # labels closer than this share of the time axis stand side by side


@dataclass(frozen=True)
class Look:
    colour: str
    dash: Literal["-", "--", "-.", ":"]
    width: float
    name: str  # in the legend


LOOKS = {
    "change": Look("#1f5fbf", "-", 1.2, "reconfiguration"),
    "refused": Look("#808080", "--", 1.0, "refused reconfiguration"),
    "fault": Look("#d62728", "-", 1.6, "fault"),
    "state": Look("#2ca02c", ":", 1.2, "coordination state"),
    "status": Look("#9467bd", "-.", 0.9, "criterion"),
    "missed": Look("#c8c8c8", "-", 0.5, "missed deadlines"),
}
OTHER = Look("#17becf", "--", 0.8, "other event")
PRIORITY = ("fault", "change", "refused", "state", "status")  # which events get a label first


def label(event: RecordedEvent) -> str | None:
    """The short text beside an event's line (None: a line only): the event's own label
    (events.py), cut to LABEL_LENGTH."""
    text = event.event.label
    if text is None:
        return None
    return text if len(text) <= LABEL_LENGTH else text[: LABEL_LENGTH - 1] + "…"


def marked(record: Record) -> list[RecordedEvent]:
    """The events drawn as lines (all but the run's start and end), in time order."""
    return [e for e in record.events if e.kind not in ("run", "end")]


def labelled(record: Record) -> list[tuple[RecordedEvent, str]]:
    """The events written beside their line, in time order: the LABELS most telling ones."""
    candidates = [(e, text) for e in marked(record) if (text := label(e)) is not None]
    rank = {kind: i for i, kind in enumerate(PRIORITY)}
    chosen = sorted(candidates, key=lambda c: (rank.get(c[0].kind, len(rank)), c[0].tick))[:LABELS]
    return sorted(chosen, key=lambda c: c[0].tick)


def panels(record: Record, spaces: Sequence[str] = ()) -> list[tuple[str, int, int]]:
    """(space, its size, its first column) of the spaces drawn: those named, in the record's
    order, or else the first PANELS; ValueError names a space the record does not have, or
    too many."""
    where: dict[str, tuple[int, int]] = {}
    column = 0
    for space, size in record.spaces:
        where[space] = (size, column)
        column += size
    unknown = [s for s in spaces if s not in where]
    if unknown:
        close = difflib.get_close_matches(unknown[0], list(where), n=1)
        hint = f" (did you mean {close[0]!r}?)" if close else ""
        raise ValueError(f"the record has no space {unknown[0]!r}{hint}")
    chosen = [space for space, _ in record.spaces if space in set(spaces)] if spaces else [s for s, _ in record.spaces]
    if spaces and len(chosen) > PANELS:
        raise ValueError(f"{len(chosen)} spaces asked: a picture draws at most {PANELS}")
    return [(space, *where[space]) for space in chosen[:PANELS]]


def draw(record: Record, fmt: str, spaces: Sequence[str] = ()) -> bytes:
    """The picture of a record, as the bytes of an SVG or PNG file: the spaces `panels`
    chooses, at most LINES numbers of each."""
    if fmt not in FORMATS:
        raise ValueError(f"{fmt!r}: the formats are {', '.join(FORMATS)}")
    drawn = panels(record, spaces)
    try:
        import matplotlib
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure
        from matplotlib.lines import Line2D
    except ImportError as exc:
        raise EnvironmentProblem(
            error(
                Location("motivml plot"),
                f"matplotlib is not installed ({exc}): pip install matplotlib",
                "plot",
            )
        ) from None
    style = matplotlib.rc_context(
        {
            "svg.fonttype": "none",  # text as text: a few kilobytes, not a path per glyph
            "svg.hashsalt": "motivml",  # the same ids in every file
            "font.size": 8,
            "axes.titlesize": 9,
            "lines.linewidth": 1.0,
            "path.simplify_threshold": 0.2,  # fewer points where they would fall on the same pixels
        }
    )
    with style, warnings.catch_warnings():
        warnings.simplefilter("ignore")  # e.g. a panel of gaps only: drawn empty, not warned about
        count = max(len(drawn), 1)
        figure = Figure(figsize=(9.0, 1.2 + 1.7 * count), layout="constrained")
        FigureCanvasAgg(figure)
        axes = figure.subplots(count, 1, sharex=True, squeeze=False)[:, 0]
        for ax, (space, size, column) in zip(axes, drawn, strict=False):
            colours = matplotlib.colormaps["tab10"]
            for i in range(min(size, LINES)):
                colour = colours(i % 10)
                low, high = record.low[:, column + i], record.high[:, column + i]
                if record.bucket == 1:
                    ax.plot(record.time, low, color=colour, label=f"[{i}]")
                else:  # down to each bucket's lowest value and up to its highest: a band where it moves
                    ax.plot(
                        np.repeat(record.time, 2),
                        np.column_stack([low, high]).ravel(),
                        color=colour,
                        label=f"[{i}]",
                    )
            ax.set_ylabel(space if size <= LINES else f"{space} [0-{LINES - 1} of {size}]")
            if size <= LINES:
                ax.legend(loc="upper left", bbox_to_anchor=(1.0, 1.0), fontsize=7, frameon=False)
        if not record.spaces:
            axes[0].set_yticks([])
            axes[0].set_ylabel("(no spaces)")
        events = marked(record)
        kinds = sorted(
            {e.kind for e in events}, key=lambda k: list(LOOKS).index(k) if k in LOOKS else len(LOOKS)
        )
        for kind in kinds:
            look = LOOKS.get(kind, OTHER)
            times = [e.time for e in events if e.kind == kind]
            for ax in axes:
                ax.vlines(
                    times,
                    0,
                    1,
                    transform=ax.get_xaxis_transform(),
                    colors=look.colour,
                    linestyles=look.dash,
                    linewidth=look.width,
                    zorder=0.5,
                )
        span = max(record.end - min(0.0, record.start), 1e-9)
        crowd, beside = -1.0, 0  # where the crowd of labels began, and how many stand in it
        for event, text in labelled(record):
            look = LOOKS.get(event.kind, OTHER)
            if event.time - crowd < CROWDED * span:  # too close to the one before: to the right of its line
                beside += 1
            elif event.time - min(0.0, record.start) < CROWDED * span:  # at the left edge: right of it
                crowd, beside = event.time, 1
            else:
                crowd, beside = event.time, 0
            axes[0].annotate(
                text,
                xy=(event.time, 0.98),
                xycoords=axes[0].get_xaxis_transform(),
                xytext=(-2.0 if beside == 0 else 2.0 + 9.0 * (beside - 1), 0.0),
                textcoords="offset points",
                rotation=90,
                ha="right" if beside == 0 else "left",
                va="top",
                fontsize=6.5,
                color=look.colour,
                bbox={"facecolor": "white", "alpha": 0.75, "edgecolor": "none", "pad": 0.6},
            )
        if kinds:
            handles = [
                Line2D(
                    [], [], color=(look := LOOKS.get(k, OTHER)).colour, linestyle=look.dash, label=look.name
                )
                for k in kinds
            ]
            figure.legend(handles=handles, loc="outside lower center", ncols=len(handles), frameon=False)
        start = min(0.0, record.start)
        axes[-1].set_xlim(start, max(record.end, start + 1e-9))
        axes[-1].set_xlabel("time [s]")
        title = record.description or record.path.name
        figure.suptitle(f"{title}: {record.ticks:,} ticks")
        buffer = io.BytesIO()
        # no date, and no matplotlib version: the file changes only when the picture does
        metadata = {"Date": None, "Creator": "motivml plot"} if fmt == "svg" else {"Software": "motivml plot"}
        try:
            figure.savefig(buffer, format=fmt, dpi=110, metadata=metadata)
        except (ValueError, OverflowError, MemoryError) as exc:  # e.g. a picture too large for PNG
            raise DocumentError(
                error(Location(str(record.path)), f"cannot draw it as {fmt.upper()}: {exc}", "plot")
            ) from None
    return buffer.getvalue()
