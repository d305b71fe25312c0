"""The ``spotfree`` command (contract in DESIGN.md).

Exit status: 0 on success, 2 on bad input with a one-line message that says what to fix.
"""

from __future__ import annotations

import contextlib
import functools
import importlib.util
import json
import re
import warnings
from pathlib import Path
from typing import Callable, Optional

import typer
from rich.console import Console
from rich.markup import escape

from spotfree.errors import InputError, SpotfreeError

app = typer.Typer(
    name="spotfree",
    help="Ride assistance for two-wheeled mobility robots: spotting-free continuous signal pattern classification.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)
hand_app = typer.Typer(help="Hand posture and gesture recognition for steering a power wheelchair.", no_args_is_help=True)
fleet_app = typer.Typer(help="Fleet scale: the ride database and batch processing.", no_args_is_help=True)
# scikit-learn's forests fitted on joblib threads sometimes warn that its ``delayed`` should be used with its ``Parallel``
# (a thread-safety race in the check, scikit-learn issue #32631): nothing is wrong with the fit, and a user of the
# command line cannot act on it.
warnings.filterwarnings("ignore", message=r".sklearn\.utils\.parallel\.delayed. should be used", category=UserWarning)
app.add_typer(hand_app, name="hand")
app.add_typer(fleet_app, name="fleet")

PIPED_WIDTH = 1000
"""Columns of a console whose output is not a terminal: a table keeps its natural width and no line wraps."""


def _console(stderr: bool = False) -> Console:
    """A console that wraps at the terminal's width on a terminal, and never when piped to a file or a program."""
    console = Console(stderr=stderr, highlight=False, soft_wrap=True)
    if not console.is_terminal:
        console.width = PIPED_WIDTH
    return console


err = _console(stderr=True)
out = _console()


QUIET = typer.Option(False, "--quiet", "-q", help="print nothing but errors (with --json: the JSON alone)")
MOUNT = typer.Option("auto", "--mount", help="device-to-vehicle mount of a raw log's ride features: auto (estimated "
                     "from the log; the nominal flat mount when the estimate is within 15 deg of it), estimate (always "
                     "the estimate), flat (on the handlebar, screen up, top edge forward), upright (in a holder, "
                     "portrait, screen towards the rider)")


def _json_option(keys: str):
    """The ``--json`` option of a command whose document holds ``keys`` (their description, for --help)."""
    return typer.Option(False, "--json", help="print one JSON document on standard output and nothing else there "
                        f"(notes and warnings stay on standard error, and are in the document): {keys}")


@contextlib.contextmanager
def _silenced(stdout: bool, stderr: bool):
    """Silence the :data:`out` and :data:`err` consoles for the block (``stdout``, ``stderr``: which)."""
    before = out.quiet, err.quiet
    out.quiet, err.quiet = out.quiet or stdout, err.quiet or stderr
    try:
        yield
    finally:
        out.quiet, err.quiet = before


def _print_json(document: dict) -> None:
    """``document`` as indented JSON on standard output (paths as text, NumPy numbers as numbers)."""

    def plain(value):
        if isinstance(value, Path):
            return str(value)
        if hasattr(value, "item"):
            return value.item()
        raise TypeError(f"{type(value).__name__} is not JSON")

    typer.echo(json.dumps(document, indent=2, default=plain))


def user_errors(command: Callable) -> Callable:
    """Turn spotfree's own errors (and unreadable files) into one line on stderr and exit status 2.

    A command with the :data:`QUIET` option (parameter ``quiet``) prints nothing on either console while it runs
    when it is given; one with :func:`_json_option` (parameter ``as_json``) prints nothing on the standard-output
    console, and prints its JSON document itself with :func:`_print_json`. Errors are printed after the command
    has stopped, so always."""

    @functools.wraps(command)
    def wrapper(*args, **kwargs):
        try:
            with _silenced(stdout=kwargs.get("quiet", False) or kwargs.get("as_json", False),
                           stderr=kwargs.get("quiet", False)):
                return command(*args, **kwargs)
        except SpotfreeError as exc:
            err.print(f"[bold red]error:[/] {escape(str(exc))}", markup=True)
        except OSError as exc:
            where = f"{exc.filename}: " if getattr(exc, "filename", None) else ""
            err.print(f"[bold red]error:[/] {where}{exc.strerror or exc}", markup=True)
        raise typer.Exit(2)

    return wrapper


EXTRAS = {
    "serve": ("server", ("fastapi", "uvicorn", "websockets", "cryptography", "orjson")),
    "fleet": ("fleet", ("distributed", "pyarrow", "duckdb", "orjson")),
}
"""Optional dependencies (``pyproject.toml``): extra -> (what it is called in a message, its top-level modules)."""


def _require_extra(command: str, extra: str) -> None:
    """Refuse ``spotfree COMMAND`` in one line naming the extra to install when one of its modules is missing (the
    check finds the modules without importing them)."""
    what, modules = EXTRAS[extra]
    for module in modules:
        try:
            found = importlib.util.find_spec(module) is not None
        except (ImportError, ValueError):
            found = False
        if not found:
            raise SpotfreeError(f"spotfree {command} needs the {what} extra: pip install 'spotfree[{extra}]'")


def _read_log(source: str, rate: float):
    """The log ``source`` read at ``rate`` Hz (marked so that :func:`_report_repairs_and_gaps` describes it)."""
    from spotfree.io import read_recording

    rec = read_recording(source, rate=rate)
    rec.meta["describe"] = True
    return rec


def _mount_choice(rec, mount: str):
    """Record the ``--mount`` choice in ``rec`` for the ride features and return the mount estimate of a raw IMU
    log (None for a log of feature channels)."""
    from spotfree.signal.mount import estimate_mount

    rec.meta["mount_choice"] = mount
    return estimate_mount(rec, mount) if rec.has_imu else None


def _report_mount(line: str, warnings: list[str]) -> None:
    """The mount that features used, and any doubt about it, on stderr."""
    err.print(line)
    for warning in warnings:
        err.print(f"warning: {warning}")


def _report_repairs_and_gaps(rec) -> dict:
    """:func:`_report_logs` of one recording without a mount, its ``read`` the line or None."""
    said = _report_logs([rec])
    return {"read": said["read"][0] if said["read"] else None, "notes": said["notes"], "warnings": said["warnings"]}


def _report_logs(recs: list, mounts: list | None = None) -> dict:
    """Refuse a recording outside what a phone records (:func:`spotfree.limits.check_recording`), then tell the
    user what was read (for a sensor log), every repair a reader made, every gap it found (never silently) and, when
    ``mounts`` gives one ``(line, warnings)`` per recording (None: no mount), the mount its features used; called
    once the command's work is done, so that a refusal stays one line. Up to :data:`READ_LINES` recordings are told
    one after the other; of more, the read lines become one and a message that several share (their source and
    numbers aside) is said once, with how many said it. Returns them all for a JSON summary:
    ``{"read": [...], "notes": [...], "warnings": [...], "mounts": [...]}`` (a read line per sensor log)."""
    from spotfree.io import describe
    from spotfree.limits import check_recording

    mounts = mounts or [None] * len(recs)
    said = {"read": [], "notes": [], "warnings": [], "mounts": []}
    told = []  # the lines of a few recordings, one recording after the other
    for rec, mount in zip(recs, mounts):
        check_recording(rec)
        lines = [("read", describe(rec))] if rec.meta.get("describe") else []
        lines += [("notes", note) for note in rec.meta.get("repairs", [])]
        lines += [("warnings", w) for w in rec.meta.get("warnings", [])]
        lines += [("warnings", f"{rec.source}: {gap}; no output there") for gap in rec.gaps]
        if mount is not None:  # its line says "mount: ..." itself
            lines += [("mounts", mount[0])] + [("warnings", w) for w in mount[1]]
        for key, line in lines:
            said[key].append(line)
            told.append(line if key == "mounts" else f"{TOLD_AS[key]}: {line}")
    if len(recs) > READ_LINES:
        seconds = sum(len(rec) / rec.rate for rec in recs)
        told = ([f"read: {len(said['read'])} logs, {seconds:.1f} s in all; the first: {said['read'][0]}"]
                if said["read"] else [])
        sources = [rec.source for rec in recs]
        mounted = [f"{rec.source}: {m[0].removeprefix('mount: ')}" for rec, m in zip(recs, mounts) if m is not None]
        for key, lines in (("notes", said["notes"]), ("warnings", said["warnings"]), ("mounts", mounted)):
            told += [f"{TOLD_AS[key]}: {line}" for line in _grouped(lines, sources)]
    for line in told:
        err.print(line)
    return said


TOLD_AS = {"read": "read", "notes": "note", "warnings": "warning", "mounts": "mount"}
"""The word that starts each kind of line :func:`_report_logs` prints."""


READ_LINES = 5
"""Most recordings whose read line :func:`_report_logs` prints one by one."""


def _grouped(lines: list[str], sources: list[str]) -> list[str]:
    """``lines`` in order, those that differ only in the leading ``source: `` of one of ``sources`` and in their
    numbers said once, as the first of them says it: ``N logs, the first FIRST: message``."""
    groups: dict[str, list[tuple[str, str]]] = {}
    for line in lines:
        source = next((s for s in sources if line.startswith(f"{s}: ")), "")
        message = line[len(source) + 2:] if source else line
        groups.setdefault(re.sub(r"\d+(\.\d+)?", "#", message), []).append((source, message))
    said = []
    for said_by in groups.values():
        source, message = said_by[0]
        if len(said_by) == 1:
            said.append(f"{source}: {message}" if source else message)
        else:
            said.append(f"{len(said_by)} logs, the first {source}: {message}")
    return said


@app.command()
@user_errors
def simulate(
    scenario: str = typer.Argument(..., help="normal-braking | sudden-braking | cruising | lateral | road"),
    output: Path = typer.Option(..., "-o", "--output", help="CSV file to write"),
    repeats: int = typer.Option(7, "--repeats", min=1, help="number of separate experiments (rides)"),
    seed: int = typer.Option(0, "--seed", help="random seed; the same seed gives the same file"),
    rate: float = typer.Option(20.0, "--rate", help="IMU sampling rate, Hz"),
    manoeuvres: str | None = typer.Option(
        None, "--manoeuvres", help="lateral and road only: what the rides hold, comma-separated from gentle, sharp, "
        "slalom (lateral) or rough-asphalt, cobblestone, kerb (road); none for straight rides on smooth asphalt "
        "(default: all)"),
    quiet: bool = QUIET,
) -> None:
    """Simulate rides of a self-balancing transporter with a tablet on the handlebar."""
    from spotfree.sim.scenarios import simulate_scenario
    from spotfree.io.csvlog import write_csv

    kinds = None if manoeuvres is None else tuple(k.strip() for k in manoeuvres.split(",") if k.strip() != "none")
    rec = simulate_scenario(scenario, repeats=repeats, seed=seed, rate=rate, manoeuvres=kinds)
    write_csv(rec, output)
    out.print(f"wrote {output}: {repeats} experiment(s), {len(rec)} samples at {rate:g} Hz, {rec.duration:.1f} s")


@app.command()
@user_errors
def features(
    source: str = typer.Argument(..., metavar="IN", help="any supported log; PATH@K selects experiment K"),
    output: Path = typer.Option(..., "-o", "--output", help="CSV file to write"),
    orientation: str = typer.Option("default", "--orientation", help="default | paper | vqf"),
    rate: float = typer.Option(20.0, "--rate", help="grid rate, Hz"),
    zero_phase: bool = typer.Option(False, "--zero-phase", help="offline zero-phase Butterworth on accelerations"),
    mount: str = MOUNT,
    quiet: bool = QUIET,
    as_json: bool = _json_option('{"output", "samples", "rate", "features" (ride | gps), "channels", '
                                 '"orientation", "mount" ({"line", "warnings"}, none for GPS features), '
                                 '"read", "notes", "warnings"}.'),
) -> None:
    """Vehicle roll, pitch, pitch rate and gravity-free vehicle-frame accelerations from a raw IMU log (from a
    GPS-only track: speed, distance and the GPS longitudinal acceleration)."""
    from spotfree.io.csvlog import write_csv
    from spotfree.signal.features import ride_features
    from spotfree.signal.gps import GPS_FEATURES, gps_features, has_gps

    rec = _read_log(source, rate)
    if not any(c in rec.channels for c in ("ax", "gx")) and has_gps(rec):
        feats = gps_features(rec)
        write_csv(feats, output, truth=False)
        said = _report_repairs_and_gaps(rec)
        lacking = rec.missing_advice() or f"{rec.source} has no motion sensors"
        out.print(f"wrote {output}: {len(feats)} samples of GPS features ({', '.join(GPS_FEATURES)}) only: "
                  f"roll, pitch and the accelerations need the accelerometer and gyroscope, and {lacking}")
        kind, mounted = "gps", None
    else:
        feats = ride_features(rec, orientation=orientation, zero_phase=zero_phase, mount=mount)
        write_csv(feats, output, truth=False)
        said = _report_repairs_and_gaps(rec)
        _report_mount(feats.meta["mount"], feats.meta["mount_warnings"])
        out.print(f"wrote {output}: {len(feats)} samples, orientation '{orientation}'")
        kind, mounted = "ride", {"line": feats.meta["mount"], "warnings": list(feats.meta["mount_warnings"])}
    if as_json:
        _print_json({"output": output, "samples": len(feats), "rate": feats.rate, "features": kind,
                     "channels": feats.names, "orientation": orientation if kind == "ride" else None,
                     "mount": mounted, **said})


@app.command()
@user_errors
def train(
    ctx: typer.Context,
    output: Path = typer.Option(..., "-o", "--output", help="model file to write (.npz)"),
    experiment: list[str] = typer.Option([], "--experiment", help="PATH=CLASS[,CLASS...]: classes that occur in it"),
    sets: Optional[Path] = typer.Option(None, "--sets", help="CSV of training recordings, one per row: recording "
                                        "(PATH or PATH@K, relative to the file), classes (that occur in it) and "
                                        "optionally start, end (s: a span of the log)"),
    channels: Optional[str] = typer.Option(None, "--channels", help="feature channels, comma-separated"),
    window: Optional[int] = typer.Option(None, "--window", min=1, help="window length, samples (20, or the "
                                         "preset's)"),
    step: int = typer.Option(1, "--step", min=1, help="stride of the windows, samples (training and classification)"),
    orientation: str = typer.Option("default", "--orientation", help="default | paper | vqf"),
    features: Optional[str] = typer.Option(None, "--features", help="what a raw IMU log becomes: ride (a phone on "
                                           "the handlebar: vehicle-frame ride features) | body (a phone in a pocket, "
                                           "a watch: device axes and magnitudes); default: chosen from the sets "
                                           "(ride with a preset or --channels)"),
    preset: Optional[str] = typer.Option(None, "--preset", help="braking | lateral | road: the channels, window, "
                                         "representation, prior, column share and most columns of spotfree's ride "
                                         "model of that name (any of them given here overrides it)"),
    recipe: str = typer.Option("sets", "--recipe", help="sets (the general learner from class sets) | paper (the "
                               "paper's recipe, literally: a baseline)"),
    prior: Optional[str] = typer.Option(None, "--prior",
                                        help="ride: braking loses GPS speed, a turn yaws (sets learner only)"),
    role: list[str] = typer.Option([], "--role", metavar="CLASS=ROLE", help="what a declared class is to the ride "
                                   "prior: slowing (loses GPS speed: a braking, a stop), turn (yaws) or none; a "
                                   "preset's own classes have theirs; repeat for several"),
    representation: str = typer.Option("summary", "--representation", help="sets learner: summary (level, spread, "
                                       "their change and band powers of each window) | hankel (the paper's raw "
                                       "windows)"),
    max_columns: int = typer.Option(300, "--max-columns", min=1,
                                    help="most dictionary columns per class (300, or the preset's)"),
    column_share: Optional[float] = typer.Option(None, "--column-share", help="sets learner: share of each "
                                                 "class's windows, those named most surely, that its columns are "
                                                 "drawn from, > 0 and <= 1 (0.5, or the preset's)"),
    share_power: Optional[float] = typer.Option(None, "--share-power", help="sets learner: how much a class's share "
                                                "of the windows weighs in its names, >= 0 (0.5, or the preset's; 1 "
                                                "for a short rare event)"),
    smoothing: Optional[float] = typer.Option(None, "--smoothing", help="sets learner: seconds a change of class "
                                              "must gain, and the offline labels' vote (0.5, or "
                                              "the preset's)"),
    auto_settings: bool = typer.Option(False, "--auto-settings", help="sets learner: choose the window, share "
                                       "power, column share and smoothing not given from the sets by the held-out set "
                                       "risk (docs/training.md; several times the training time)"),
    seed: int = typer.Option(0, "--seed"),
    figure: Optional[Path] = typer.Option(None, "--figure", help="also draw the training logs (the first 12; the "
                                          "spans of a log on its row) coloured by "
                                          "the names the learner gave their windows (.png)"),
    mount: str = MOUNT,
    quiet: bool = QUIET,
    as_json: bool = _json_option('{"output", "learner" (sets | paper), "features", "channels", '
                                 '"representation", "window", "step", "prior", "column_share" (sets learner), '
                                 '"settings" ([{"setting", "value", "given", "candidates": {value: set risk}}], '
                                 'sets learner; "features" among them), '
                                 '"classes", "columns", '
                                 '"columns_per_class", "recordings" ([{"source", "declared", '
                                 '"windows"}], sets learner), "rounds_changed" (fraction of names moved per '
                                 'round, sets learner), "read" (one line per log), "notes", "mounts" (the mount '
                                 'of each log, ride features), "warnings" (the logs\', the mounts\' and the '
                                 'learner\'s), "figure"}.'),
) -> None:
    """Build a dictionary of pure class representatives from whole recordings, without spotting."""
    from spotfree.pipeline import FEATURES

    if features is not None and features not in FEATURES:
        raise InputError(f"--features {features!r}: use one of {', '.join(FEATURES)}")
    from spotfree.presets import PRESETS, PRIORS, prior_named
    from spotfree.representation import REPRESENTATIONS

    for option, value, choices in (("--recipe", recipe, ("sets", "paper")),
                                   ("--representation", representation, REPRESENTATIONS),
                                   ("--prior", prior, (None, *PRIORS)), ("--preset", preset, (None, *PRESETS))):
        if value not in choices:
            raise InputError(f"{option} {value!r}: use one of {', '.join(c for c in choices if c)}")
    given = [p.opts[0] for p in ctx.command.params
             if p.name and getattr(ctx.get_parameter_source(p.name), "name", "") == "COMMANDLINE"]
    misplaced = [o for o in given if o in ("--prior", "--representation", "--column-share", "--share-power",
                                           "--smoothing", "--auto-settings", "--figure", "--preset", "--role")
                 and recipe != "sets"]
    if misplaced:
        raise InputError(f"{misplaced[0]} is an option of --recipe sets; leave it out with --recipe {recipe}")
    chosen = tuple(c.strip() for c in channels.split(",")) if channels else None
    params = {"step": step, "seed": seed}
    settings = {"--channels": ("channels", chosen), "--window": ("window", window),
                "--representation": ("representation", representation), "--prior": ("prior", prior_named(prior)),
                "--column-share": ("column_share", column_share), "--max-columns": ("max_columns", max_columns),
                "--share-power": ("share_power", share_power), "--smoothing": ("smoothing", smoothing)}
    params.update(item for option, item in settings.items() if (preset is None or option in given)  # else the preset's
                  and not (item[1] is None and option in CHOSABLE))  # else the learner's default
    if auto_settings:
        params.update((settings[option][0], "auto") for option in CHOSABLE if option not in given)
    if features is None and (preset or chosen or recipe != "sets"):
        features = "ride"  # the presets' channels are ride channels; named channels are of one kind
    from spotfree.io.class_sets import read_class_sets

    declared = [_parse_experiment(spec) for spec in experiment] + (read_class_sets(sets) if sets else [])
    if not declared:
        raise InputError("no training recording: give --experiment PATH=CLASS[,CLASS...] or --sets FILE")
    summary = _train(output, declared, orientation, features, recipe, preset, params, figure, mount, role,
                     [o for o in given if o in (*CHOSABLE, "--features", "--channels")])
    if as_json:
        _print_json(summary)


def _train(output: Path, declared: list, orientation: str, features: str, recipe: str, preset: Optional[str],
           params: dict, figure: Optional[Path], mount: str, roles: list[str] = (),
           options: list[str] = ()) -> dict:
    """``spotfree train``: :class:`~spotfree.learner.SetSupervisedLearner` (``recipe`` sets; of ``preset``'s
    settings when given, :func:`~spotfree.presets.preset_learner`, ``params`` overriding them) or
    :class:`~spotfree.paper_recipe.PaperRecipe` (``recipe`` paper) on the ``declared`` recordings and their sets
    (:class:`~spotfree.io.class_sets.Declared`: each log read and turned into features once, then cut into its
    spans), the ride prior's ``roles`` (``--role CLASS=ROLE``: :func:`_prior_roles`); ``features`` None: ride or
    body features, chosen from the sets (:func:`~spotfree.selection.select_features`) for raw IMU logs; ``options``:
    the learner's options given on the command line (a preset's others are the preset's). Prints the summary and
    returns it (the document of ``--json``)."""
    from collections import Counter

    from spotfree.learner import SetSupervisedLearner
    from spotfree.paper_recipe import PaperRecipe
    from spotfree.pipeline import feature_recording
    from spotfree.presets import preset_learner, prior_name

    logs = {}
    for item in declared:
        if item.recording not in logs:
            logs[item.recording] = _read_log(item.recording, 20.0)
            logs[item.recording].meta["mount_choice"] = mount
    kinds = [features] if features else (["ride", "body"] if all(log.has_imu for log in logs.values()) else ["ride"])
    read = {kind: {spec: feature_recording(log, orientation=orientation, features=kind) for spec, log in logs.items()}
            for kind in kinds}  # per kind, each log's features: a span is cut from its log's
    candidates = {kind: [item.take(read[kind][item.recording]) for item in declared] for kind in kinds}
    sets = [list(item.classes) for item in declared]
    if recipe == "paper":
        learner = PaperRecipe(**{"window": 20, **{k: params[k] for k in ("channels", "window", "step", "max_columns",
                                                                         "seed") if params.get(k) is not None}})
    else:
        learner = preset_learner(preset, **params) if preset else SetSupervisedLearner(**params)
    roled, unroled = "", []
    if recipe == "sets":
        roled, learner.prior, unroled = _prior_roles(learner.prior, preset, sets, roles)
    kind, risks = kinds[0], {}
    if len(kinds) > 1:
        from spotfree.selection import select_features

        kind, risks = select_features(learner, candidates, [set(s) for s in sets])
    recordings, read, logs = candidates[kind], read[kind], list(logs.values())
    learner.fit(recordings, sets)
    model = learner.model_
    model.save(output)
    said = _report_logs(logs, [(rec.meta["mount"], rec.meta["mount_warnings"]) if "mount" in rec.meta else None
                               for rec in read.values()])
    if kind == "ride" and not risks and mount in ("auto", "estimate") and any(
            rec.meta.get("mount_warnings") for rec in recordings):  # chosen features weighed body already
        err.print("note: ride features assume a phone on a vehicle's handlebar; for a phone in a pocket or a watch, "
                  "train with --features body")
    counts = Counter(model.classes[k] for k in model.column_class)
    summary = {"output": output, "learner": recipe, "features": model.features, "channels": model.channels,
               "representation": model.representation, "window": model.window, "step": model.step,
               "prior": prior_name(learner.prior) if recipe == "sets" else None,
               "column_share": learner.settings_["column_share"] if recipe == "sets" else None,
               "settings": _settings_rows(learner, kind, risks, preset, options) if recipe == "sets" else None,
               "classes": model.classes,
               "columns": model.dictionary.shape[1], "columns_per_class": {c: counts[c] for c in model.classes},
               "recordings": [{"source": rec["source"], "declared": rec["classes"], "windows": rec["windows"]}
                              for rec in model.summary.get("recordings", [])],
               "rounds_changed": model.summary.get("rounds_changed", []),
               "read": said["read"], "notes": said["notes"], "mounts": said["mounts"],
               "warnings": said["warnings"] + unroled + model.summary.get("warnings", []), "figure": figure}
    if recipe == "paper":
        out.print(f"learner: the paper's recipe (hankel of {_channels_said(model)})")
        out.print("columns per class: " + ", ".join(f"{c} {counts[c]}" for c in model.classes))
        return summary
    out.print(f"learner: sets ({model.representation} of {_channels_said(model)}; "
              f"prior: {prior_name(learner.prior) or 'none'}{roled}; column share {learner.settings_['column_share']:g})")
    for line in _settings_lines(summary["settings"], model.rate):
        out.print(line)
    for warning in unroled:
        err.print(f"[bold yellow]warning:[/] {escape(warning)}", markup=True)
    out.print(_naming_table(model.summary["recordings"], f"{output}: {model.dictionary.shape[1]} columns, window "
                            f"{model.window} samples"))
    out.print("columns per class: " + ", ".join(f"{c} {k}" for c, k in model.summary["columns_per_class"].items()))
    out.print("names moved per round: " + (", ".join(f"{100 * h:.1f} %" for h in learner.history_) or "none"))
    for warning in learner.warnings_:
        err.print(f"[bold yellow]warning:[/] {warning}", markup=True)
    if figure is not None:
        from spotfree.evaluation.figures import training_figure

        shown = training_figure(learner, recordings, figure, [item.recording for item in declared])
        out.print(f"figure: {figure} ({shown})")
    return summary


def _prior_roles(prior, preset: Optional[str], sets: list, given: list[str]) -> tuple[str, object, list[str]]:
    """``(said, prior, warnings)``: the learner's ``prior`` with the declared classes of ``sets`` matched to their
    roles (:func:`spotfree.ride_prior.with_roles`: the ``--role CLASS=ROLE`` options ``given``, then ``preset``'s
    classes, or every preset's without one), the roles given as the learner line says them, and a warning naming
    any class of no role; a prior other than the ride prior is kept as it is."""
    from spotfree.presets import PRESET_ROLES
    from spotfree.ride_prior import ROLES, RidePrior, with_roles

    classes = list(dict.fromkeys(c for classes in sets for c in classes))
    roles = {}
    for spec in given:
        name, sep, role = spec.rpartition("=")
        if not sep or role not in ROLES:
            raise InputError(f"--role '{spec}': write CLASS=ROLE with ROLE one of {', '.join(ROLES)}")
        if name not in classes:
            raise InputError(f"--role '{spec}': no recording declares class '{name}'; declared: {', '.join(classes)}")
        roles[name] = role
    if not isinstance(prior, RidePrior):
        if roles:
            raise InputError("--role gives classes their role in the ride prior: add --prior ride, or train with "
                             "--preset braking or lateral")
        return "", prior, []
    known = PRESET_ROLES[preset] if preset else {c: r for table in PRESET_ROLES.values() for c, r in table.items()}
    prior, warnings = with_roles(prior, classes, known, roles)
    said = "; ".join(f"{r}: {','.join(c for c, x in roles.items() if x == r)}" for r in ROLES if r in roles.values())
    return f" ({said})" if said else "", prior, warnings


def _settings_rows(learner, kind: str, risks: dict, preset: Optional[str], said: list[str]) -> list[dict]:
    """The learner's :attr:`~spotfree.learner.SetSupervisedLearner.selection_` with the features first, each row's
    ``given`` said as ``"option"`` (on the command line), ``"preset"`` (the preset's), ``"default"`` (the learner's),
    or False (chosen)."""
    implied = "preset" if preset and "--features" not in said and "--channels" not in said else "option"
    rows = [{"setting": "features", "value": kind, "given": False if risks else implied,
             "candidates": {k: None if r is None else round(float(r), 4) for k, r in risks.items()}}]
    for row in learner.selection_:
        option = "--" + row["setting"].replace("_", "-")
        source = (False if not row["given"] else "option" if option in said else "preset" if preset else
                  "default")
        rows.append({**row, "given": source})
    return rows


def _settings_lines(rows: list[dict], rate: float) -> list[str]:
    """One line per setting of :func:`_settings_rows`: its value and whether it was given, the preset's, or chosen
    with the set risk of each candidate (lower is better)."""
    def value(row: dict, v, short: bool = False) -> str:
        if row["setting"] == "window":
            return f"{v / rate:g} s" if short else f"{v} samples = {v / rate:.2f} s"
        return f"{v:g}" if isinstance(v, (int, float)) else str(v)

    lines = []
    for row in rows:
        if row["given"]:
            how = {"option": "given", "preset": "the preset's", "default": "the learner's default"}[row["given"]]
        elif row["candidates"]:
            how = "chosen; set risk " + ", ".join(f"{value(row, v, short=True)} {'-' if r is None else f'{r:.3f}'}"
                                                  for v, r in row["candidates"].items())
        else:
            how = "default; too little to hold out"
        lines.append(f"setting: {row['setting']} {value(row, row['value'])} ({how})")
    return lines


CHOSABLE = ("--window", "--share-power", "--column-share", "--smoothing")
"""Options of the learner's settings that :mod:`spotfree.selection` can choose (``--auto-settings``)."""
TABLE_ROWS = 20
"""Most recordings :func:`_naming_table` shows a row each; of more, a row per declared set."""


def _channels_said(model) -> str:
    """A model's channels as the summaries say them: ``ride channels a,b``, ``body channels ...`` or, for a log used
    as it was read, ``the log's channels ...``."""
    kind = "the log's" if model.features == "channels" else model.features
    return f"{kind} channels {','.join(model.channels)}"


def _naming_table(recordings: list[dict], title: str):
    """A rich Table of what the learner named in each training recording (``{"source", "classes", "windows"}`` of
    the model summary): a row a recording, or, of more than :data:`TABLE_ROWS`, a row per declared set with how
    many recordings declare it and the windows named in them all."""
    from collections import Counter

    from rich.table import Table

    table = Table(title=title)
    if len(recordings) <= TABLE_ROWS:
        for column in ("recording", "declared", "windows named"):
            table.add_column(column)
        for rec in recordings:
            table.add_row(rec["source"], ",".join(rec["classes"]),
                          " ".join(f"{c} {k}" for c, k in rec["windows"].items()))
        return table
    groups: dict[tuple, tuple[int, Counter]] = {}  # declared set: recordings, windows named
    for rec in recordings:
        count, windows = groups.get(tuple(rec["classes"]), (0, Counter()))
        groups[tuple(rec["classes"])] = (count + 1, windows + Counter(rec["windows"]))
    for column in ("declared", "recordings", "windows named"):
        table.add_column(column)
    for classes, (count, windows) in sorted(groups.items(), key=lambda item: -item[1][0]):
        table.add_row(",".join(classes), str(count), " ".join(f"{c} {windows[c]}" for c in classes if windows[c]))
    return table


def _parse_experiment(spec: str):
    """``--experiment PATH=CLASS[,CLASS...]`` as a :class:`~spotfree.io.class_sets.Declared` recording."""
    from spotfree.io.class_sets import Declared, class_names

    path, sep, classes = spec.rpartition("=")
    names = class_names(classes, ",")
    if not sep or not path or not names:
        raise InputError(f"--experiment '{spec}': write PATH=CLASS[,CLASS...], e.g. ride.csv@1=cruising,sudden-braking")
    return Declared(path, names)


@app.command()
@user_errors
def classify(
    paths: list[str] = typer.Argument(..., metavar="MODEL.npz [MODEL2.npz ...] IN [IN2 ...]",
                                      help="model file(s) written by 'spotfree train' or the name of a model "
                                      "shipped with spotfree (braking), then any supported log(s) "
                                      "(PATH@K selects experiment K)"),
    output: Path = typer.Option(..., "-o", "--output", help="CSV file to write: time, label (and experiment); "
                                "with several models one label column per model, named by its file stem; with "
                                "several logs a folder (made when new), one NAME.csv per log (NAME@K.csv for PATH@K)"),
    method: str = typer.Option("kcrc", "--method", help="kcrc | crc | src | bsrc | nearest (kcrc: kernel "
                               "CRC_RLS, amplitude-aware, the default; crc: the paper's CRC_RLS; kcrc and nearest are "
                               "not in the paper)"),
    centred: bool = typer.Option(False, "--centred", help="label each sample by the window centred on it "
                                 "(offline; implied by the offline votes and --offline); default: the window ending "
                                 "at it, as a live stream does"),
    smooth: Optional[int] = typer.Option(None, "--smooth", help="majority vote over N samples (0: none; default "
                                         "with --centred: the model's smoothing span, 11 samples at 20 Hz for the "
                                         "learner's 0.5 s; none live)"),
    segments: list[str] = typer.Option([], "--segments", metavar="[MODEL=]PENALTY",
                                       help="offline segment vote: cut the ride where the model's channels change "
                                       "(PELT, this penalty per change; larger: fewer segments; 4 suits the lateral "
                                       "model, 8 the road model) and give each segment its majority label (0: none); "
                                       "MODEL=PENALTY for the model of that file stem alone, repeat for several"),
    keep: list[str] = typer.Option([], "--keep", help="a class the segment and event votes leave as labelled (short "
                                   "events such as kerb); repeat for several"),
    events: list[str] = typer.Option([], "--events", help="offline event vote: a model's background class (straight "
                                     "for the lateral model); each run of its other labels is one manoeuvre and "
                                     "takes its majority label; repeat for several models"),
    edges: list[str] = typer.Option([], "--edges", metavar="CHANNEL=LEVEL",
                                    help="offline, after the event vote: move each event's start and end, by at most "
                                    "a window, to where CHANNEL's distance from its background median crosses LEVEL "
                                    "(its units; yaw_rate=0.09 for the lateral model)"),
    offline: bool = typer.Option(False, "--offline", help="centred windows and each model's offline votes stored "
                                 "in its file ('spotfree votes'), instead of the vote options"),
    mount: str = MOUNT,
    quiet: bool = QUIET,
    as_json: bool = _json_option('{"output", "samples", "method", "alignment" (causal | centred), '
                                 '"smoothing", "votes", "models" (per model, by file stem: {"features", '
                                 '"channels", "representation", "window", "labelled", "labels": samples '
                                 'per class}), "breaks" ([{"experiment", "stopped", "resumed"}], one '
                                 'model), "mount" ({"line", "warnings"}), "read", "notes", '
                                 '"warnings"}; with several logs {"logs": [one such document per log]}.'),
) -> None:
    """Label every sample of a log with a trained model, or with several models at once (one feature pass); several
    logs in one call, each to its own file."""
    from spotfree.classify.multi import model_names
    from spotfree.votes.options import edge_levels, model_penalties

    model_paths, sources = _models_and_logs(paths)
    names = model_names(model_paths)
    if offline and (segments or keep or events or edges):
        raise InputError("--offline takes the votes stored in the model files; give either --offline or the vote "
                         "options --segments, --keep, --events, --edges")
    centred = centred or offline or bool(segments or keep or events or edges)  # the votes run on offline labels
    penalties = model_penalties(segments, names)
    vote = {"segments": penalties if len(names) > 1 else penalties[names[0]], "keep": tuple(keep),
            "events": tuple(events), "edges": edge_levels(edges)}
    from spotfree.classify.batch import dictionary_classifier, offline_vote
    from spotfree.classify.smoothing import alignment_smoothing
    from spotfree.model import DictionaryModel
    from spotfree.votes.options import Votes, stored_votes, votes_per_model

    targets = _log_outputs(sources, output)
    models = {name: DictionaryModel.load(path) for name, path in zip(names, model_paths)}  # once for every log
    from spotfree.ride.default_model import shipped_models, trained_on

    for name, path in zip(names, model_paths):
        if Path(path) in shipped_models().values():
            out.print(f"model {name}: shipped with spotfree, {trained_on(models[name])}")
    if offline:
        votes = {name: stored_votes(model) for name, model in models.items()}
    else:
        votes = votes_per_model(models, **vote) if len(models) > 1 else {names[0]: Votes(**vote)}
    note = _stored_note(votes) if offline else _vote_note(vote)
    voting = {name: alignment_smoothing(smooth, centred, offline_vote(model)) or 0 for name, model in models.items()}
    classifiers = {name: dictionary_classifier(model, method, causal=not centred) for name, model in models.items()}
    summaries = []
    if len(sources) > 1:
        output.mkdir(parents=True, exist_ok=True)
    for source, target in targets.items():
        if len(models) > 1:
            summaries.append(_classify_several(models, classifiers, source, target, method, centred, smooth, voting,
                                               votes, note, mount))
        else:
            summaries.append(_classify_one(models[names[0]], classifiers[names[0]], names[0], source, target, method,
                                           centred, voting[names[0]], votes[names[0]], note, mount))
    if as_json:
        _print_json(summaries[0] if len(summaries) == 1 else {"logs": summaries})


def _models_and_logs(paths: list[str]) -> tuple[list[str], list[str]]:
    """``classify``'s paths split into the model files (the leading ``.npz`` files or names of shipped models,
    :func:`~spotfree.ride.default_model.shipped_models`, which become their files; with none, all but the last
    path) and the logs after them."""
    from spotfree.ride.default_model import shipped_models

    if len(paths) < 2:
        raise InputError("classify needs MODEL.npz [MODEL2.npz ...] IN: at least one model file and the log")
    shipped = {name: str(path) for name, path in shipped_models().items() if not Path(name).exists()}

    def is_model(path: str) -> bool:
        return path.lower().endswith(".npz") or path in shipped

    models = 0
    while models < len(paths) and is_model(paths[models]):
        models += 1
    if models == 0:
        models = len(paths) - 1
        missing = next((p for p in paths[:models] if not Path(p).exists()), None)
        if missing is not None and not any(is_model(p) for p in paths[models:]):
            raise InputError(f"classify: {missing} is neither a model file nor a shipped model ("
                             f"{', '.join(shipped_models())}); give a file written by 'spotfree train' or that name")
    if models == len(paths):
        raise InputError(f"classify: {paths[-1]} is a model file; give the log to label after the model files")
    stray = [p for p in paths[models:] if is_model(p)]
    if stray:
        raise InputError(f"classify: {stray[0]} is a model file among the logs; give the model files first")
    return [shipped.get(p, p) for p in paths[:models]], paths[models:]


def _log_outputs(sources: list[str], output: Path) -> dict[str, Path]:
    """The CSV file of each log: ``output`` for one log; for several, ``output / NAME.csv`` (the log's file name
    without its extension, ``NAME@K.csv`` for ``PATH@K``) in the folder ``output``, an existing one or a new name
    without an extension (made before the first log is written)."""
    if len(sources) == 1:
        return {sources[0]: output}
    if not (output.is_dir() or (not output.exists() and not output.suffix)):
        raise InputError(f"-o {output}: with {len(sources)} logs give a folder, existing or a new name without an "
                         "extension (one CSV per log is written into it)")
    from spotfree.io import split_spec

    targets: dict[str, Path] = {}
    for source in sources:
        path, experiment = split_spec(source)
        target = output / f"{path.stem}{'' if experiment is None else f'@{experiment}'}.csv"
        if source in targets:
            raise InputError(f"classify: {source} is given twice; give each log once")
        if target in targets.values():
            raise InputError(f"classify: two logs would write {target}; give logs of different names")
        targets[source] = target
    return targets


def _classify_one(dictionary, classifier, name: str, source: str, output: Path, method: str, centred: bool,
                  smooth: int, votes, note: str, mount: str) -> dict:
    """``classify`` with one model (``dictionary``, named ``name``; ``classifier`` fitted on its columns for this
    alignment) on the log ``source`` with its ``votes`` (described by ``note``): writes ``output`` and prints the
    summary; returns the ``--json`` document."""
    from spotfree.votes.options import voted_labels

    rec = _read_log(source, dictionary.rate)
    if dictionary.features == "ride" and not rec.has_imu and not set(dictionary.channels) <= set(rec.channels):
        rec.require_imu("the model's ride features")
    estimate = _mount_choice(rec, mount) if dictionary.features == "ride" else None
    labels = voted_labels(dictionary, rec, votes, method=method, centred=centred, smoothing=smooth,
                          classifier=classifier)
    labels.write_csv(output)
    said = _report_repairs_and_gaps(rec)
    if estimate is not None:
        _report_mount(estimate.describe(), estimate.warnings)
    window = f"{dictionary.window} samples = {dictionary.window / dictionary.rate:.2f} s"
    where = f"centred on it (offset {labels.meta['offset']} samples)" if centred else "ending at it"
    out.print(f"model: {_channels_said(dictionary)}, {dictionary.representation} windows")
    out.print(f"wrote {output}: {int(labels.labelled().sum())} of {len(labels)} samples labelled by {method}; "
              f"windows: {labels.meta['alignment']}, each label from the window of {window} {where}"
              + (f"; majority vote over {smooth} samples" if smooth else "") + note)
    for gap in labels.breaks():
        out.print(f"{gap} (gap in {rec.source}; no label across it)")
    return {**_classify_summary(output, {name: (dictionary, labels.label)}, method, centred, smooth, note,
                                estimate, said),
            "breaks": [vars(gap) for gap in labels.breaks()]}


def _classify_summary(output: Path, labelled: dict, method: str, centred: bool, smooth: int, note: str, estimate,
                      said: dict) -> dict:
    """The ``classify --json`` document (see ``classify``) but its breaks; ``labelled``: per model name, the model
    and its labels (``""`` where none)."""
    import numpy as np

    models = {}
    for name, (model, labels) in labelled.items():
        named = np.asarray(labels)[np.asarray(labels) != ""]
        models[name] = {"features": model.features, "channels": model.channels,
                        "representation": model.representation, "window": model.window, "labelled": len(named),
                        "labels": {c: int(np.sum(named == c)) for c in model.classes}}
    return {"output": output, "samples": len(next(iter(labelled.values()))[1]), "method": method,
            "alignment": "centred" if centred else "causal", "smoothing": smooth,
            "votes": note.removeprefix("; ") or None, "models": models,
            "mount": None if estimate is None else {"line": estimate.describe(), "warnings": list(estimate.warnings)},
            **said}


def _stored_note(votes: dict) -> str:
    """The summary's words on the offline votes stored in the model files (``votes``: per model name)."""
    from spotfree.votes.options import describe

    return "; offline votes stored in the model: " + ", ".join(
        f"{name} {describe(vote) or 'none'}" if len(votes) > 1 else describe(vote) or "none"
        for name, vote in votes.items())


def _vote_note(vote: dict) -> str:
    """The summary's words on the segment and event votes (``vote``: the fields of
    :class:`~spotfree.votes.options.Votes`, ``segments`` one penalty or one per model name)."""
    penalties = vote["segments"] if isinstance(vote["segments"], dict) else {"": vote["segments"]}
    if len(set(penalties.values())) == 1:
        penalties = {"": next(iter(penalties.values()))}
    said = ", ".join(f"{name} {p:g}".strip() for name, p in penalties.items() if p)
    votes = ([f"segment vote at penalty {said}"] if said else []) \
        + ([f"event vote outside {', '.join(vote['events'])}"] if vote["events"] else []) \
        + [f"event edges at {c} {level:g} off its background median" for c, level in vote["edges"].items()]
    if not votes:
        return ""
    return "; " + " and ".join(votes) + (f", {', '.join(vote['keep'])} kept" if vote["keep"] else "")


def _classify_several(models: dict, classifiers: dict, source: str, output: Path, method: str, centred: bool,
                      smooth: int | None, voting: dict, votes: dict, note: str, mount: str = "auto") -> dict:
    """``classify`` with several models (by name, each with its ``classifiers`` fitted for this alignment and its
    ``votes``, described by ``note``) on the log ``source``: one label column per model, see
    :mod:`spotfree.classify.multi`; ``smooth`` the ``--smooth`` asked for (None: each model's default), ``voting``
    the majority vote it gives per model (samples, for the summary); ``mount`` the ``--mount`` choice. Returns the
    ``--json`` document."""
    from spotfree.classify.multi import write_labels
    from spotfree.votes.options import voted_models

    rec = _read_log(source, next(iter(models.values())).rate)
    if not rec.has_imu and any(m.features == "ride" and not set(m.channels) <= set(rec.channels)
                               for m in models.values()):
        rec.require_imu("the models' ride features")
    estimate = _mount_choice(rec, mount) if any(m.features == "ride" for m in models.values()) else None
    table = voted_models(models, rec, votes, method=method, centred=centred, smoothing=smooth,
                         classifiers=classifiers)
    write_labels(table, output)
    said = _report_repairs_and_gaps(rec)
    if estimate is not None:
        _report_mount(estimate.describe(), estimate.warnings)
    windows = ", ".join(f"{name} {m.window} samples" for name, m in models.items())
    out.print(f"wrote {output}: {len(table)} samples, one label column per model ({', '.join(models)}) by {method}; "
              f"windows {'centred on' if centred else 'ending at'} each sample: {windows}"
              + _smooth_note(voting) + note)
    return _classify_summary(output, {name: (model, table[name].to_numpy(str)) for name, model in models.items()},
                             method, centred, voting if len(set(voting.values())) > 1 else next(iter(voting.values())),
                             note, estimate, said)


def _smooth_note(voting: dict) -> str:
    """The summary's words on the majority votes (``voting``: samples per model name, 0 for none)."""
    if len(set(voting.values())) == 1:
        n = next(iter(voting.values()))
        return f"; majority vote over {n} samples" if n else ""
    return "; majority vote over " + ", ".join(f"{name} {n}" for name, n in voting.items()) + " samples"


@app.command()
@user_errors
def votes(
    model_path: Path = typer.Argument(..., metavar="MODEL.npz", help="model file written by 'spotfree train'"),
    segments: Optional[float] = typer.Option(None, "--segments", metavar="PENALTY",
                                             help="segment-vote penalty (as for classify)"),
    keep: list[str] = typer.Option([], "--keep", help="a class the votes leave as labelled; repeat for several"),
    events: list[str] = typer.Option([], "--events", help="the model's background class for the event vote"),
    edges: list[str] = typer.Option([], "--edges", metavar="CHANNEL=LEVEL", help="event edges (as for classify)"),
    clear: bool = typer.Option(False, "--clear", help="remove the stored votes"),
) -> None:
    """Show a model's offline votes, or store them in its file for 'spotfree classify --offline' (all replaced)."""
    from spotfree.model import DictionaryModel
    from spotfree.votes.options import Votes, describe, edge_levels, stored_votes, with_votes

    model = DictionaryModel.load(model_path)
    given = segments is not None or keep or events or edges
    if clear and given:
        raise InputError("--clear removes the stored votes; give either --clear or the votes to store")
    if not (clear or given):
        out.print(f"{model_path}: {describe(stored_votes(model)) or 'no offline vote stored'}")
        return
    model = with_votes(model, Votes(segments, keep, events, edge_levels(edges)))
    model.save(model_path)
    if clear:
        out.print(f"removed the offline votes from {model_path}")
        return
    out.print(f"stored in {model_path}: {describe(stored_votes(model))}; 'spotfree classify --offline' uses them")


@app.command()
@user_errors
def evaluate(
    output: Path = typer.Option(..., "-o", "--output", help="folder to write report.md and figures into"),
    seed: int = typer.Option(0, "--seed", help="seed of the simulated rides and of the training clustering"),
    quick: bool = typer.Option(False, "--quick", help="two experiments per scenario (for tests; not the paper's "
                               "protocol)"),
    quiet: bool = QUIET,
) -> None:
    """Reproduce the paper's section V on the simulator: accuracy, the 6-of-7800 count, timings, peers, figures."""
    from spotfree.evaluation.run import evaluate as run_evaluation
    from spotfree.evaluation.report import headline

    ev = run_evaluation(output, seed=seed, quick=quick, progress=lambda message: err.print(message))
    for line in headline(ev):
        out.print(line, soft_wrap=True)
    out.print(f"wrote {output / 'report.md'} and {len(ev.files)} figures; run took {ev.seconds:.0f} s",
              soft_wrap=True)


@app.command()
@user_errors
def serve(
    host: str = typer.Option("127.0.0.1", "--host", help="address to listen on (0.0.0.0 for phones on the LAN)"),
    port: int = typer.Option(8000, "--port", help="TCP port, 1 to 65535 (0: any free port)"),
    database: str = typer.Option("spotfree-rides.db", "--database",
                                 help="SQLite file, or a postgresql:// URL"),
    https: bool = typer.Option(False, "--https", help="TLS with a self-signed certificate (phones need it)"),
    replay: Optional[str] = typer.Option(None, "--replay", help="replay this log as a live ride (real time)"),
    simulate: Optional[str] = typer.Option(None, "--simulate", help="ride this simulator scenario live"),
    model_path: Optional[Path] = typer.Option(None, "--model", help="model file (default: spotfree's braking "
                                              "model, shipped with it)"),
    speed: float = typer.Option(1.0, "--speed", min=0.1, help="replay/simulate at this many times real time"),
    seed: int = typer.Option(0, "--seed", help="seed of --simulate"),
    sync: str = typer.Option("full", "--sync", help="SQLite durability of an acknowledged sample: full (survives "
                             "a power loss) | normal (survives the server being killed; faster)"),
    workers: int = typer.Option(0, "--workers", min=0, help="classify and record rides in this many worker "
                                "processes (0: in the server's process)"),
    new_operator_token: bool = typer.Option(False, "--new-operator-token", help="issue a new operator token "
                                            "(the old one stops working) and write it beside the store"),
    cert: Optional[Path] = typer.Option(None, "--cert", help="your own TLS certificate (PEM) for https; "
                                        "with --key"),
    key: Optional[Path] = typer.Option(None, "--key", help="the private key (PEM) of --cert"),
) -> None:
    """The live ride assistant: phone page (/), rider view (/rider), operator view (/operator)."""
    _require_extra("serve", "serve")
    from spotfree.ride.server import run_server

    if sync not in ("full", "normal"):
        raise InputError(f"--sync {sync}: use full or normal")
    if (cert is None) != (key is None):
        raise InputError("--cert and --key go together: give both, or neither (--https makes its own)")

    run_server(host=host, port=port, database=database, https=https, replay=replay, simulate=simulate,
               model_path=model_path, speed=speed, seed=seed, say=err.print, synchronous=sync,
               workers=workers, new_operator_token=new_operator_token,
               certificate=(cert, key) if cert is not None else None)


@hand_app.command("simulate")
@user_errors
def hand_simulate(
    output: Path = typer.Option(..., "-o", "--output", help="JSON lines file to write (one tracking frame a line)"),
    people: int = typer.Option(6, "--people", min=1, help="simulated people, one session each"),
    seed: int = typer.Option(0, "--seed", help="random seed; the same seed gives the same file"),
    rounds: int = typer.Option(3, "--rounds", min=1, help="how often each of the eight gestures occurs per person"),
    protocol: str = typer.Option("test", "--protocol", help="test (one session per person) | training (the nine "
                                 "sessions per person that 'spotfree hand train' reads)"),
) -> None:
    """Simulate hand-tracking frames: people holding the five postures and moving between them."""
    from spotfree.hand.log import write_hand_log
    from spotfree.sim.hand import simulate_hands

    frames = simulate_hands(people=people, seed=seed, rounds=rounds, protocol=protocol)
    write_hand_log(frames, output)
    with_hand = sum(1 for f in frames if f.hands)
    out.print(f"wrote {output}: {frames[-1].session} session(s), {len(frames)} frames "
              f"({len(frames) - with_hand} without a hand), {frames[-1].time - frames[0].time:.1f} s of service clock")


@hand_app.command("train")
@user_errors
def hand_train(
    output: Path = typer.Option(..., "-o", "--output", help="model file to write (.npz; two siblings go next to it)"),
    logs: Optional[list[Path]] = typer.Argument(None, metavar="[LOG.jsonl ...]",
                                                help="training-protocol logs (none: simulate one)"),
    people: int = typer.Option(8, "--people", min=1, help="simulated people when no LOG is given "
                               "(spotfree.sim.hand.TRAINING_PEOPLE)"),
    seed: int = typer.Option(0, "--seed", help="seed of the simulation and of the clustering"),
) -> None:
    """Train the two-stage posture / gesture recogniser without spotting."""
    from spotfree.hand.log import frames_to_recording, read_hand_log
    from spotfree.hand.recognition import HandTrainingConfig, features_of, session_tasks, train_hand
    from spotfree.sim.hand import simulate_hands

    if logs:
        recordings = [read_hand_log(log) for log in logs]
    else:
        err.print(f"simulating the training protocol of {people} people (seed {seed})")
        recordings = [frames_to_recording(simulate_hands(people=people, seed=seed, protocol="training"),
                                          source="simulated training protocol")]
    sessions = []
    for rec in recordings:
        _report_repairs_and_gaps(rec)
        sessions += [(features_of(part), task) for part, task in session_tasks(rec)]
    result = train_hand(sessions, HandTrainingConfig(seed=seed), progress=lambda m: err.print(m))
    result.model.save(output)
    for stage, model in result.model.stages().items():
        columns = ", ".join(f"{c} {k}" for c, k in model.summary["columns_per_class"].items())
        out.print(f"{stage}: window {model.window} samples, channels {','.join(model.channels)}; columns: {columns}")
    out.print(f"wrote {output} and its live-state, posture and gesture stages next to it, from {len(sessions)} "
              "sessions")


@hand_app.command("run")
@user_errors
def hand_run(
    model: Path = typer.Argument(..., metavar="MODEL.npz", help="model written by 'spotfree hand train'"),
    log: Path = typer.Argument(..., metavar="LOG.jsonl", help="hand-tracking log"),
    output: Path = typer.Option(..., "-o", "--output", help="CSV file to write: time, state, label, command"),
    offline: bool = typer.Option(False, "--offline", help="centred windows and one gesture per gesture stretch "
                                 "(sees half a window ahead; default: causal, as live)"),
    events: Optional[Path] = typer.Option(None, "--events", help="also write the gestures as events to this CSV: "
                                          "start, stop (s), gesture"),
) -> None:
    """Recognise postures and gestures in a log and emit wheelchair commands."""
    from spotfree.hand.log import read_hand_log
    from spotfree.hand.recognition import HandModel, features_of, recognise

    hand_model = HandModel.load(model)
    rec = read_hand_log(log, rate=hand_model.state.rate)
    labels = recognise(hand_model, features_of(rec), offline=offline)
    labels.write_csv(output)
    if events is not None:
        labels.write_events_csv(events)
    _report_repairs_and_gaps(rec)
    labelled = labels.state != ""
    out.print(f"wrote {output}: {int(labelled.sum())} of {len(labels.time)} samples labelled; no label and the "
              f"command 'stop' where there is no hand")
    if events is not None:
        out.print(f"wrote {events}: {len(labels.events)} gesture event(s)")


@fleet_app.callback()
@user_errors
def fleet() -> None:
    """Fleet scale: the ride database and batch processing."""
    _require_extra("fleet", "fleet")


@fleet_app.command("generate")
@user_errors
def fleet_generate(
    output: Path = typer.Option(..., "-o", "--output", help="folder to write: riders.csv, rides.csv, logs/"),
    riders: int = typer.Option(50, help="riders in the population"),
    rides: int = typer.Option(1000, help="rides among them"),
    vehicles: int = typer.Option(10, help="vehicles in the fleet"),
    days: int = typer.Option(7, help="days the rides are spread over (from 2024-04-01 UTC)"),
    seed: int = typer.Option(0, help="random seed: the same seed writes the same files"),
) -> None:
    """Simulate a fleet: riders whose age band and skill shape their rides, written as ride logs."""
    from spotfree.fleet.generator import generate_fleet

    fleet = generate_fleet(output, riders=riders, rides=rides, vehicles=vehicles, days=days, seed=seed)
    out.print(f"wrote {len(fleet.rides)} ride logs of {len(fleet.riders)} riders into {output}")


@fleet_app.command("ingest")
@user_errors
def fleet_ingest(
    logs: Optional[list[str]] = typer.Argument(None, metavar="[LOG ...]", help="ride logs (PATH or PATH@K)"),
    store: str = typer.Option(..., "--store", help="ride store: SQLite file or postgresql:// URL"),
    manifest: Optional[Path] = typer.Option(None, help="CSV of logs: file, vehicle, rider_id[, started, ...]"),
    riders: Optional[Path] = typer.Option(None, help="CSV of riders: rider_id, age_band, gender, skill"),
    from_store: Optional[str] = typer.Option(None, help="copy the ended rides of this ride store"),
    vehicle: Optional[str] = typer.Option(None, help="vehicle of the LOGs"),
    rider: Optional[str] = typer.Option(None, help="rider id of the LOGs"),
    started: Optional[float] = typer.Option(None, help="UNIX s the LOG started (else from the log)"),
) -> None:
    """Ingest ride logs (any supported format) or another store's rides into the ride store; idempotent."""
    from spotfree.fleet.ingest import LogEntry, ingest_logs, ingest_store, read_manifest
    from spotfree.ride.store import RideStore

    if logs and not (vehicle and rider):
        raise InputError("fleet ingest: LOGs need --vehicle and --rider (or list them in a --manifest)")
    if not (logs or manifest or from_store):
        raise InputError("fleet ingest: nothing to ingest; give LOGs, --manifest or --from-store")
    entries = [LogEntry(path, vehicle, rider, started) for path in logs or []]
    entries += read_manifest(manifest, riders) if manifest else []
    with RideStore(store) as target:
        out.print(f"logs: {ingest_logs(target, entries)}")
        if from_store:
            with RideStore(from_store) as source:
                out.print(f"{source.name}: {ingest_store(target, source)}")


@fleet_app.command("process")
@user_errors
def fleet_process(
    store: str = typer.Option(..., "--store", help="ride store: SQLite file or postgresql:// URL"),
    output: Path = typer.Option(..., "-o", "--output", help="Parquet folder: rides/, samples/, events/"),
    model: Optional[list[str]] = typer.Option(None, help="NAME=MODEL.npz (braking, lateral, road...); "
                                              "braking defaults to the built-in model"),
    scheduler: Optional[str] = typer.Option(None, help="tcp://HOST:PORT of a Dask scheduler (else a local cluster)"),
    workers: int = typer.Option(2, help="worker processes of the local cluster"),
    database: Optional[str] = typer.Option(None, help="postgresql:// URL to write fleet_rides and fleet_events"),
    redo: bool = typer.Option(False, help="process rides already done with the same models again"),
    quiet: bool = QUIET,
    as_json: bool = _json_option('{"output", "models", "processed" (ride ids), "skipped", "failed" '
                                 "(reason by ride id)}."),
) -> None:
    """Process every ended ride (features, all models, events) in parallel on Dask; idempotent."""
    from spotfree.fleet.engine import process_fleet
    from spotfree.model import DictionaryModel
    from spotfree.ride.default_model import default_model

    models = {}
    for spec in model or []:
        name, sep, path = spec.partition("=")
        if not (sep and name and path):
            raise InputError(f"--model {spec!r}: write NAME=MODEL.npz")
        models[name] = DictionaryModel.load(path)
    if "braking" not in models:
        models["braking"] = default_model()
    report = process_fleet(store, output, models, scheduler=scheduler, workers=workers, database=database,
                           redo=redo)
    out.print(f"{report}; results in {output}")
    if as_json:
        _print_json({"output": output, "models": sorted(models), "processed": report.processed,
                     "skipped": report.skipped, "failed": report.failed})


@fleet_app.command("stats")
@user_errors
def fleet_stats(
    results: Path = typer.Argument(..., help="folder written by 'spotfree fleet process'"),
    output: Path = typer.Option(..., "-o", "--output", help="folder for stats.md, by_<group>.csv and .png"),
    quiet: bool = QUIET,
    as_json: bool = _json_option('{"output", "stats": per grouping, the rows of its by_<group>.csv as objects '
                                 "(null where a value is missing)}."),
) -> None:
    """Braking events per km, sudden-stop rate, speed and deceleration by rider group, vehicle and place."""
    from spotfree.fleet.stats import fleet_stats as write_stats

    tables = write_stats(results, output)
    out.print(f"wrote {output}/stats.md and a CSV and PNG for each of {', '.join(tables)}")
    if as_json:
        _print_json({"output": output, "stats": {group: json.loads(table.to_json(orient="records"))
                                                 for group, table in tables.items()}})


if __name__ == "__main__":  # pragma: no cover
    app()
