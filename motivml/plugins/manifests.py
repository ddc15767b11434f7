"""Plugin manifests: which plugin implements which feature, from the folders a robot declares.

A robot folder may hold `robot.json` with `pluginDirectories` (relative to the robot
folder). Each sub-folder of those holding a `plugin.json` is a plugin; its manifest is
validated (schema, a feature of the model, an entry that stays inside the plugin folder)
before anything else looks at it. Nothing is imported or loaded here: this module only
says where each feature's implementation is, for `configure`'s plugins.json and, later,
for the runtime.
"""

from __future__ import annotations

import difflib
from pathlib import Path

from ..documents.loader import load_file
from ..documents.robot_folder import MANIFEST_FILE, SETTINGS_FILE, Plugin, RobotFolder, optional_document
from ..documents.schema import PLUGIN, ROBOT, check_document, read_checked
from ..errors import Diagnostic, EnvironmentProblem, Location, error, warning
from ..language.model import FeatureModel
from .registry import KINDS


def _read(path: Path, schema: str, what: str) -> tuple[dict[str, object] | None, list[Diagnostic]]:
    doc, problems = read_checked(path, lambda d: check_document(d, schema, what))
    return (doc.root if doc is not None else None), problems


def plugin_directories(robot: RobotFolder) -> tuple[list[Path], list[Diagnostic]]:
    """The plugin directories robot.json declares (none without robot.json)."""
    settings_path = robot.settings_path
    if optional_document(settings_path) is None:
        return [], []
    settings, problems = _read(settings_path, ROBOT, SETTINGS_FILE)
    if settings is None:
        return [], problems
    folders: list[Path] = []
    found: list[Diagnostic] = []
    listed = settings.get("pluginDirectories", [])
    assert isinstance(listed, list)
    for position, name in enumerate(listed):
        folder = robot.path / str(name)
        if not folder.is_dir():
            doc = load_file(settings_path)
            found.append(
                error(
                    doc.locate(("pluginDirectories", position)),
                    f"plugin directory {name!r} does not exist (relative to {robot.path})",
                    "plugins.directory",
                )
            )
            continue
        folders.append(folder)
    return folders, found


def discover(robot: RobotFolder, model: FeatureModel) -> tuple[dict[str, Plugin], list[Diagnostic]]:
    """Every declared plugin by feature id; errors for bad manifests, in a stable order."""
    folders, diagnostics = plugin_directories(robot)
    plugins: dict[str, Plugin] = {}
    modules: dict[tuple[str, str], Path] = {}  # (kind, top-level entry module) -> its manifest
    for folder in folders:
        try:
            candidates = sorted(p for p in folder.iterdir() if p.is_dir() and not p.name.startswith("."))
        except OSError as exc:
            raise EnvironmentProblem(
                error(Location(str(folder)), f"cannot read: {exc.strerror}", "io")
            ) from None
        for candidate in candidates:
            manifest_path = candidate / MANIFEST_FILE
            if optional_document(manifest_path) is None:  # (a folder without one is not a plugin)
                continue
            manifest, problems = _read(manifest_path, PLUGIN, "a plugin manifest")
            diagnostics += problems
            if manifest is None:
                continue
            doc = load_file(manifest_path)
            feature, kind, entry = str(manifest["feature"]), str(manifest["kind"]), manifest["entry"]
            assert isinstance(entry, dict)
            unusable = KINDS[kind].check_entry(entry)
            if unusable is not None:
                place, problem = unusable
                where = doc.locate(("entry", *place))
                rule = (
                    "plugins.parameter"
                    if place[:1] == ("parameters",)
                    else "plugins.escape"
                    if place
                    else "plugins.entry"
                )
                diagnostics.append(error(where, problem, rule, feature))
                continue
            if feature not in model.index:
                close = difflib.get_close_matches(feature, list(model.index), n=1, cutoff=0.75)
                hint = f" (did you mean {close[0]!r}?)" if close else ""
                diagnostics.append(
                    error(
                        doc.locate(("feature",)),
                        f"the plugin implements {feature!r}, which is not a feature of the model{hint}",
                        "plugins.unknown-feature",
                        feature,
                    )
                )
                continue
            if feature in plugins:
                diagnostics.append(
                    error(
                        doc.locate(("feature",)),
                        f"a second plugin for {feature} (the first is {plugins[feature].manifest})",
                        "plugins.duplicate",
                        feature,
                    )
                )
                continue
            if not KINDS[kind].path_is_file:  # modules share one namespace per robot, nodes one graph
                key = KINDS[kind].path_key
                root = str(entry[key]).split(".")[0] if key == "module" else str(entry[key])
                other = modules.setdefault((kind, root), manifest_path)
                if other != manifest_path:
                    what = "modules" if key == "module" else "nodes"
                    diagnostics.append(
                        error(
                            doc.locate(("entry", key)),
                            f"{key} {root!r} is also the entry of {other}: entry {what} need distinct names",
                            "plugins.load",
                            feature,
                        )
                    )
                    continue
            plugins[feature] = Plugin(feature, kind, dict(entry), candidate, manifest_path)
    return plugins, diagnostics


def missing(model: FeatureModel, features: list[str], plugins: dict[str, Plugin]) -> list[Diagnostic]:
    """Warnings for selected Dynamic or Late features that no declared plugin implements
    (abstract features expect none)."""
    found = []
    for feature_id in features:
        index = model.index[feature_id]
        if feature_id in plugins or model.features[index].abstract:
            continue
        where = model.source.locate(model.path(index, "id"))
        found.append(
            warning(
                where,
                f"no plugin implements {feature_id}, which the variant binds Dynamic or Late "
                f"(declare a plugin directory in {SETTINGS_FILE} holding its {MANIFEST_FILE})",
                "plugins.missing",
                feature_id,
            )
        )
    return found
