"""The ``hoopbench`` command line.

Sub-commands: ``scenes``, ``reference``, ``simulate``, ``model``, ``settings``, ``compare``,
``map``, ``report``, ``findings``, ``figure``, ``tune``, ``bench``.
Bad arguments give a one-line error on stderr and exit status 2. JSON goes to stdout only.
"""

# ruff: noqa: E402  (the signal handler below is set before the heavy imports)
from __future__ import annotations

import argparse
import json
import os
import re
import signal
import sys
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, NoReturn


def _stopped_while_starting(signum: int, frame: object) -> None:
    """Ctrl-C or SIGTERM while the command's modules load (a second or more): one line, not
    the import machinery's traceback; nothing has run."""
    what = "Ctrl-C" if signum == signal.SIGINT else signal.Signals(signum).name
    os.write(2, f"hoopbench: interrupted ({what}) while starting; nothing ran\n".encode())
    os._exit(128 + signum)


_STARTING_SIGNALS = (signal.SIGINT, signal.SIGTERM)
if __name__ == "__main__" or Path(sys.argv[0]).name == "hoopbench":  # the command, not an import
    for _signal in _STARTING_SIGNALS:
        signal.signal(_signal, _stopped_while_starting)

# isort: split
from hoopbench import __version__
from hoopbench.engines.options import Profile
from hoopbench.engines.registry import engine_class, engine_classes, get_engine
from hoopbench.engines.settings import (
    DEFAULT_BATCH_SIZE,
    DEFAULT_TIMESTEP,
    MAX_STEPS,
    RunSettings,
    parse_option_value,
)
from hoopbench.models.catalogue import get_scene, scene_names
from hoopbench.models.events import Outcome
from hoopbench.models.scene import DegenerateSceneError, Scene
from hoopbench.reference.exact import DEFAULT_ATOL, DEFAULT_RTOL

if TYPE_CHECKING:  # the runner is imported only by the commands that run sweeps
    from hoopbench.reports.sweep.runner import ExecutorBrokenError, RunSummary

__all__ = ["main"]

EXIT_USAGE = 2
EXIT_INTERRUPTED = 130
"""128 + SIGINT, as a shell reports a command stopped by Ctrl-C."""


class UsageError(Exception):
    """Bad command-line input: printed as one line, exit status 2."""


class _Parser(argparse.ArgumentParser):
    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        # argparse reads '-1e-4' or '-3x4' after an option as an unknown option ("expected
        # one argument"): its pattern for a negative number knows neither exponents nor
        # NxM. Here anything starting with '-' and a digit (or '-.' and a digit) is a value,
        # which the option's own check then refuses by name; no option here starts so.
        self._negative_number_matcher = re.compile(r"^-(\.?\d|(nan|inf|infinity)$)", re.I)

    def error(self, message: str) -> NoReturn:
        raise UsageError(message)


# --------------------------------------------------------------------------- scenes
_SCENE_OPTIONS = (
    # hoopbench.reports.api.scene's keywords, each an option here (--theta0-deg, --t-end)
    "lam",
    "eps",
    "chi",
    "thetadot0",
    "theta0_deg",
    "mus",
    "muk",
    "g",
    "a",
    "M",
    "t_end",
    "xdot0",
)

_OPTION_TEXT = {"name": "--scene NAME"}
"""The API's keywords whose option is not --keyword (api.OptionError names them so)."""


def _add_scene_options(parser: argparse.ArgumentParser) -> None:
    group = parser.add_argument_group(
        "scene", "a catalogue scene (--scene) and/or explicit parameters overriding it"
    )
    group.add_argument("--scene", help=f"catalogue scene: {', '.join(scene_names())}")
    group.add_argument("--lam", type=_number, help="weight's mass fraction, in [0, 1]")
    group.add_argument("--eps", type=_number, help="weight's own inertia parameter, >= 0")
    spin = group.add_mutually_exclusive_group()
    spin.add_argument("--chi", type=_number, help="spin parameter a*thetadot0^2/g")
    spin.add_argument("--thetadot0", type=_number, help="initial spin, rad/s")
    group.add_argument("--theta0-deg", type=_number, help="initial angle of the weight, deg")
    group.add_argument("--mus", type=_number, help="static friction coefficient")
    group.add_argument("--muk", type=_number, help="kinetic friction coefficient (<= mus)")
    group.add_argument("--g", type=_number, help="gravity, m/s^2 (default 9.8)")
    group.add_argument("--a", type=_number, help="hoop radius, m (default 1)")
    group.add_argument("--M", type=_number, help="total mass, kg (default 1)")
    group.add_argument("--t-end", type=_number, help="end of the window, s (default 3)")
    group.add_argument("--xdot0", type=_number, help="initial hoop-centre velocity, m/s")


def _scene_from_args(args: argparse.Namespace) -> Scene:
    """The scene: a catalogue scene with explicit parameters over it, or parameters alone
    (hoopbench.reports.api.scene: the spin is set last, from the final a and g)."""
    import hoopbench.reports.api as api

    return api.scene(args.scene, **{key: getattr(args, key) for key in _SCENE_OPTIONS})


def _argument(check_name: str) -> Any:
    """An argparse type: the API's check of that name, its message as argparse shows it
    ('argument --jobs: must be >= 1, got 0')."""

    def convert(text: str) -> Any:
        import hoopbench.reports.api as api

        try:
            return getattr(api, check_name)(text)
        except ValueError as exc:
            raise argparse.ArgumentTypeError(str(exc)) from None

    convert.__name__ = check_name.removeprefix("check_")  # argparse's fallback message
    return convert


_positive_int = _argument("check_positive_int")
_count = _argument("check_count")
_seconds = _argument("check_positive_seconds")
"""A time step, s: finite and > 0 (0 used to fall back on the default without a word)."""
_batch_size = _argument("check_batch_size")
_workers = _argument("check_workers")
"""1 up to the machine's cores: more processes than cores only slow a sweep down."""
_grid = _argument("check_grid")
"""'40x40' -> (40, 40)."""


def _add_batch_size(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--batch-size",
        type=_batch_size,
        default=DEFAULT_BATCH_SIZE,
        metavar="N",
        help="runs per batch for an engine that steps many worlds at once (default "
        f"{DEFAULT_BATCH_SIZE}; 1: every run alone; docs/engines.md, Batches)",
    )


def _number(text: str) -> float:
    """A float option as float() reads it (nan and inf too: the option's own check names
    them), but never a number that underflows to 0: '1e-400' is not '0.0'."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
    mantissa = re.split(r"[eE]", text.strip())[0]
    if value == 0 and re.search(r"[1-9]", mantissa):
        raise argparse.ArgumentTypeError(
            f"{text!r} is too small for a float (it would be read as 0)"
        )
    return value


_number.__name__ = "number"  # argparse's fallback message


def _folder(text: str) -> str:
    """A folder to write into: '' would be the current folder, which no one means."""
    if not text.strip():
        raise argparse.ArgumentTypeError(f"must name a folder, got {text!r}")
    return text


def _output_file(path: str, suffixes: Sequence[str], force: bool) -> Path:
    """A file to write: known suffix, existing folder, and no file there unless --force.

    Checked before a run, so that a finished run is never lost to a bad path.
    """
    out = Path(path)
    if out.suffix not in suffixes:
        raise UsageError(f"output file must end in {' or '.join(suffixes)}, got {path!r}")
    if not out.parent.is_dir():
        raise UsageError(f"folder {str(out.parent)!r} of output file {path!r} does not exist")
    if not os.access(out.parent, os.W_OK):
        raise UsageError(f"folder {str(out.parent)!r} of output file {path!r} is not writable")
    if out.is_dir():
        raise UsageError(f"output file {path!r} is a folder: give a file name")
    if out.exists() and not out.is_file():  # a FIFO or a device: writing it never ends
        raise UsageError(f"output file {path!r} exists and is not a regular file")
    if out.exists() and not force:
        raise UsageError(f"output file {path!r} exists; pass --force to overwrite it")
    return out


def _system_error(exc: OSError) -> bool:
    """An error the system reported (disk full, read-only, no permission): not a reader gone
    away (main stops quietly then) nor an errno-less one, as a caller's alarm's TimeoutError."""
    return exc.errno is not None and not isinstance(exc, BrokenPipeError)


def _write_failure(exc: OSError, where: str | Path, kept: str) -> UsageError:
    """A write that failed (disk full, read-only folder, no permission) as one line: the path
    (the file's, else ``where``), the reason, and what is kept."""
    path = exc.filename if exc.filename is not None else where
    return UsageError(f"cannot write {str(path)!r}: {exc.strerror or exc}; {kept}")


def _sweep_kept(out: str, resume: str) -> str:
    """What a sweep stopped by a write error keeps: every row already stored (the runner
    writes each part whole, or not at all), and the command that goes on from them."""
    if (Path(out) / "runs").is_dir():
        return f"the runs stored before are kept in {out}/runs; resume with: {resume}"
    return "nothing was run or stored"


def _write_trajectory(trajectory: Any, path: Path) -> None:
    """Write a run's samples; a full disk or a refused write named with its path (the
    file is written whole or not at all: models/trajectory.py)."""
    try:
        trajectory.write(path)
    except OSError as exc:
        if not _system_error(exc):
            raise
        exc.filename = str(path)  # the temporary file's name means nothing to the user
        kept = "an existing file there is unchanged" if path.exists() else "nothing was written"
        raise _write_failure(exc, path, kept) from None


def _broken_sweep(exc: ExecutorBrokenError, kept: str) -> int:
    """The sweep's machinery failed for good (runner.ExecutorBrokenError): one line, what is
    kept and how to resume; its own exit status."""
    _error(f"stopped: {exc}; {kept}")
    return exc.EXIT_STATUS


def _sweep_failed(exc: BaseException, out: str, resume: str) -> int:
    """A sweep's command stopped by ``exc`` (compare's and map's): a broken executor, a
    refused folder, Ctrl-C outside the runner's handling (between a map's stages), or a
    write the system refused: one line, what is kept and how to resume."""
    from hoopbench.reports.sweep.runner import ExecutorBrokenError, RunnerError

    if isinstance(exc, ExecutorBrokenError):
        return _broken_sweep(exc, _sweep_kept(out, resume))
    if isinstance(exc, RunnerError):
        raise UsageError(str(exc)) from None
    if isinstance(exc, KeyboardInterrupt):
        return _interrupted_sweep(out, resume)
    if isinstance(exc, OSError) and _system_error(exc):
        raise _write_failure(exc, out, _sweep_kept(out, resume)) from None
    raise exc


def _interrupted_sweep(out: str, resume: str) -> int:
    """Ctrl-C outside the runner's handling: one line saying what the folder keeps."""
    _error(f"interrupted (Ctrl-C); {_sweep_kept(out, resume)}")
    return EXIT_INTERRUPTED


# --------------------------------------------------------------------------- output
def _print_json(payload: dict[str, Any]) -> None:
    json.dump(payload, sys.stdout, indent=2, allow_nan=False, default=_json_default)
    sys.stdout.write("\n")


def _json_default(value: Any) -> Any:
    if hasattr(value, "item"):
        return value.item()
    if isinstance(value, tuple):
        return list(value)
    raise TypeError(f"cannot write {type(value).__name__} as JSON")


def _fmt(value: Any, unit: str = "", digits: int = 6) -> str:
    if value is None:
        return "-"
    if isinstance(value, float):
        return f"{value:.{digits}g}{unit}"
    return f"{value}{unit}"


def _summary(payload: dict[str, Any]) -> str:
    lines = []
    scene = payload.get("scene", {})
    if scene:
        lines.append(
            "scene {name}: lam={lam} eps={eps} chi={chi:.6g} theta0={theta0:.6g} rad "
            "mus={mus} muk={muk} g={g} a={a}".format(**{**scene, "name": scene["name"] or "-"})
        )
    if "engine" in payload:
        lines.append(
            f"engine {payload['engine']} {payload.get('engine_version') or ''}: "
            f"status {payload['status']}, mu {payload.get('mu')}, "
            f"{_fmt(payload.get('n_steps'))} steps in {_fmt(payload.get('wall_time_s'), ' s', 3)}"
        )
        if payload.get("status_message"):
            lines.append(f"  {payload['status_message']}")
    if "outcome" not in payload:
        return "\n".join(lines)
    lines += [
        f"outcome        {payload['outcome']}",
        f"slip onset     t = {_fmt(payload['t_slip'], ' s')}, "
        f"theta = {_fmt(payload['theta_slip_deg'], ' deg')}, "
        f"thetadot = {_fmt(payload['thetadot_slip'], ' rad/s')}",
        f"re-stick       t = {_fmt(payload.get('t_restick'), ' s')}",
        f"lift-off       t = {_fmt(payload['t_lift'], ' s')}",
        f"hop height     {_fmt(payload['hop_height'], ' m')}",
        f"impact         t = {_fmt(payload['t_impact'], ' s')}",
    ]
    if "n_steps" in payload and "engine" not in payload:
        lines.append(f"scheme steps   {payload['n_steps']}")
    if payload.get("message"):
        lines.append(f"note           {payload['message']}")
    return "\n".join(lines + _phase_and_judgement_lines(payload))


def _phase_and_judgement_lines(payload: dict[str, Any]) -> list[str]:
    """The phases, the contact reading and the judgement of a payload that has them."""
    lines = []
    phases = payload.get("phases") or []
    if phases:
        lines.append("phases")
        for p in phases:
            sigma = f" sigma={p['sigma']:+d}" if p.get("sigma") else ""
            lines.append(f"  {p['kind']:<7}{p['t_start']:>12.6f} .. {p['t_end']:.6f} s{sigma}")
    if payload.get("reading"):
        lines += _reading_lines(payload["reading"], payload.get("kin") or {})
    if payload.get("judgement"):
        lines += _judgement_lines(payload["judgement"], payload.get("judgement_note"))
    return lines


def _emit(args: argparse.Namespace, payload: dict[str, Any]) -> None:
    if args.json:
        _print_json(payload)
    else:
        from hoopbench.reports.sweep.control_chars import terminal_text

        print(terminal_text(_summary(payload)))  # a plugin's message, a settings file's name


# --------------------------------------------------------------------------- commands
def _cmd_scenes(args: argparse.Namespace) -> int:
    if args.json:
        _print_json(
            {
                name: {**get_scene(name).to_dict(), "why": get_scene(name).why}
                for name in scene_names()
            }
        )
        return 0
    for name in scene_names():
        scene = get_scene(name)
        print(f"{name:<16} {scene.why}")
    return 0


def _cmd_reference(args: argparse.Namespace) -> int:
    scene = _scene_from_args(args)
    csv = None if args.csv is None else _output_file(args.csv, _TRAJECTORY_SUFFIXES, args.force)
    if args.method == "exact":
        from hoopbench.reference.exact import solve_exact

        solution = solve_exact(scene, rtol=args.rtol, atol=args.atol)
        events, trajectory = solution.events, None
        if csv:
            trajectory = solution.sample_uniform(1e-3 if args.dt is None else args.dt)
    else:
        from hoopbench.reference.seed_euler import solve_seed_euler

        result = solve_seed_euler(scene, dt=0.002 if args.dt is None else args.dt, delta=args.delta)
        events = result.events
        trajectory = result.trajectory() if csv else None
    payload = {"method": args.method, **events.to_dict(), "scene": scene.to_dict()}
    if trajectory is not None and csv is not None:
        _write_trajectory(trajectory, csv)
        payload["trajectory_file"] = str(csv)
    _emit(args, payload)
    # An answer the solver could not give (its work budget ran out) is not a success.
    return 1 if events.outcome is Outcome.ERROR else 0


def _settings_from_args(args: argparse.Namespace, engine: str) -> RunSettings:
    options: dict[str, Any] = {}
    for item in args.set or []:
        key, sep, value = item.partition("=")
        if not sep or not key.strip():
            raise UsageError(f"--set takes KEY=VALUE, got {item!r}")
        if key.strip() in options:
            raise UsageError(f"--set {key.strip()} is given twice")
        options[key.strip()] = parse_option_value(value)
    settings = RunSettings(
        timestep=args.dt if args.dt is not None else DEFAULT_TIMESTEP,
        mu=args.mu,
        restitution=args.restitution,
        geometry=args.geometry,
        options=options,
        max_steps=args.max_steps,
        profile=args.profile,
    )
    engine_class(engine).resolve(settings)  # bad names fail before any engine is imported
    return settings


def _say_tier_note(loaded: Any, name: str | None) -> None:
    """A note on stderr when FILE#TIER names a setting within the tier on some scenes only."""
    from hoopbench.reports.compare.settings_file import tier_note

    note = tier_note(loaded, name)
    if note is not None:
        _say(f"note: settings file {loaded.file_name}{note}")


def _settings_from_file(args: argparse.Namespace) -> RunSettings:
    """simulate --settings FILE[#NAME]: a setting of ``hoopbench tune``'s settings file."""
    import hoopbench.reports.api as api

    if args.set or args.dt is not None:
        raise UsageError("--settings gives the timestep and the options: drop --dt and --set")
    from hoopbench.reports.compare.settings_file import load_choice

    chosen = api.setting_from_file(args.engine, args.settings)
    _say_tier_note(*load_choice(args.settings))
    return chosen.run_settings().with_(
        mu=args.mu, restitution=args.restitution, geometry=args.geometry, max_steps=args.max_steps
    )


def _cmd_simulate(args: argparse.Namespace) -> int:
    scene = _scene_from_args(args)
    if args.settings is not None:
        settings = _settings_from_file(args)
        engine_class(args.engine)().check(scene, settings)
    else:
        settings = _settings_from_args(args, args.engine)
    csv = None if args.csv is None else _output_file(args.csv, _TRAJECTORY_SUFFIXES, args.force)
    import hoopbench.reports.api as api

    run = api.run_settings(args.engine, scene, settings)  # judged as hb.run judges
    result = run.result
    payload = {**result.to_dict(), "scene": scene.to_dict()}
    if result.events is not None and result.trajectory is not None and result.info.mu:
        payload = {**_canonical(result, scene, result.info.mu), "scene": scene.to_dict()}
    payload["judgement"] = run.judgement
    if settings.restitution:
        payload["judgement_note"] = _BOUNCE_NOTE
    if csv and result.trajectory is not None:
        _write_trajectory(result.trajectory, csv)
        payload["trajectory_file"] = str(csv)
    _emit(args, payload)
    return 0 if result.info.status.value in ("ok", "diverged") else 1


_BOUNCE_NOTE = (
    "the exact solution has no restitution: this run is judged against a hoop that does not bounce"
)


def _judgement_lines(judged: dict[str, Any], note: str | None) -> list[str]:
    """The verdict, its flags, the exact events and each event's error (api.judgement)."""
    verdict = judged.get("verdict")
    if verdict is None:
        return [f"verdict        none: {judged.get('verdict_reason') or 'no exact answer'}"]
    lines = [f"verdict        {verdict}: {judged.get('verdict_reason') or ''}"]
    if note:
        lines.append(f"  ({note})")
    flags = " ".join(str(x) for x in (judged.get("verdict_flags"), judged.get("event_flags")) if x)
    lines.append(f"flags          {flags or '-'}")
    lines.append(
        f"exact          {judged.get('exact_outcome')}: "
        f"slip onset t = {_fmt(judged.get('exact_t_slip'), ' s')}, "
        f"lift-off t = {_fmt(judged.get('exact_t_lift'), ' s')}, "
        f"hop height {_fmt(judged.get('exact_hop_height'), ' m')}, "
        f"impact t = {_fmt(judged.get('exact_t_impact'), ' s')}; "
        f"phases {judged.get('exact_phases') or '-'}"
    )
    events = judged.get("events") or []
    if events:
        lines.append("errors         run - exact (tight / loose tolerance): within")
    for event in events:
        scale, unit = (100.0, " %") if event["unit"] == "relative" else (1.0, " ms")
        lines.append(
            f"  {event['event']:<15}{scale * event['error']:+.3g}{unit} "
            f"({scale * event['tight']:.3g} / {scale * event['loose']:.3g}{unit}): "
            f"{event['within']}"
        )
    return lines


def _canonical(result: Any, scene: Any, mu: float) -> dict[str, Any]:
    """The run's payload with its events by the canonical reading (engines/judging/
    contact.py) at the top level, as the verdict reads them; the reading's own numbers under
    ``reading``; the kinematic reading (clearance and slip velocity) under ``kin``, the one
    place it is shown, to compare."""
    from dataclasses import asdict

    from hoopbench.engines.judging.columns import Col
    from hoopbench.engines.judging.comparison import scene_exact_columns
    from hoopbench.engines.judging.contact import canonical_events, read_run
    from hoopbench.engines.judging.verdict import number_or_none

    trajectory, kin = result.trajectory, result.events
    # The exact window's end, as the row (hb.run, the suites) reads the same run with.
    window_end = number_or_none(scene_exact_columns(scene, mu).get(Col.EXACT_T_IMPACT))
    reading = read_run(trajectory, scene, mu, window_end=window_end)
    events = canonical_events(trajectory, reading, painleve=kin.outcome is Outcome.PAINLEVE)
    payload = {k: v for k, v in result.to_dict().items() if k not in kin.to_dict()}
    extras = asdict(reading)
    extras = {k: extras[k] for k in _READING_EXTRAS}
    extras["flights"] = len(reading.flights)
    return {**events.to_dict(), **payload, "reading": extras, "kin": kin.to_dict()}


_READING_EXTRAS = (
    "chatter_count",
    "chatter_max_clearance",
    "creep_time",
    "creep_max_speed",
    "cone_stick_time",
    "chattering_time",
    "slip_friction_ratio",
)


def _reading_lines(reading: dict[str, Any], kin: dict[str, Any]) -> list[str]:
    return [
        f"contact        {reading['chatter_count']} of {reading['flights']} flights are "
        f"chatter (largest clearance {_fmt(reading['chatter_max_clearance'], ' m')}); "
        f"creep {_fmt(reading['creep_time'], ' s')} "
        f"(up to {_fmt(reading['creep_max_speed'], ' m/s')}); stick outside the cone "
        f"{_fmt(reading['cone_stick_time'], ' s')}; "
        f"chattering {_fmt(reading['chattering_time'], ' s')}; sliding friction "
        f"{_fmt(reading['slip_friction_ratio'], digits=3)} of mu",
        "to compare, the kinematic reading (clearance and slip velocity; the kin_ columns): "
        f"slip t = {_fmt(kin.get('t_slip'), ' s')}, lift-off t = {_fmt(kin.get('t_lift'), ' s')}, "
        f"hop height {_fmt(kin.get('hop_height'), ' m')}",
    ]


def _cmd_model(args: argparse.Namespace) -> int:
    scene = _scene_from_args(args)
    settings = _settings_from_args(args, args.engine)
    # The same checks as a run: a model file is never written for settings a run refuses.
    text = get_engine(args.engine).model_text(scene, settings)
    sys.stdout.write(text if text.endswith("\n") else text + "\n")
    return 0


def _cmd_export(args: argparse.Namespace) -> int:
    import hoopbench.reports.api as api
    from hoopbench.models.whole_files import write_whole

    scene = _scene_from_args(args)
    out = _output_file(args.out, (".py",), args.force)
    if args.settings is not None:
        settings = _settings_from_file(args)
    else:
        settings = _settings_from_args(args, args.engine)
    if settings.geometry != "sphere" or settings.restitution or settings.mu is not None:
        raise UsageError(
            "export writes the scene's own friction, no restitution and the default geometry: "
            "drop --mu, --restitution and --geometry"
        )
    text = api.export(
        args.engine,
        scene,
        timestep=settings.timestep,
        profile=settings.profile,
        options=dict(settings.options),
        command=sys.argv[1:],
    )
    try:
        write_whole(out, lambda tmp: tmp.write_text(text))  # keeps an existing file's mode
    except OSError as exc:
        if not _system_error(exc):
            raise
        raise _write_failure(exc, out, "nothing was written") from None
    print(out)
    return 0


def _cmd_settings(args: argparse.Namespace) -> int:
    from dataclasses import asdict

    from hoopbench.engines.judging.detectors import DetectorSettings

    classes = engine_classes()
    names = [args.engine] if args.engine else list(classes)
    payload = {
        "common": RunSettings().to_dict(),
        "engines": {name: _engine_declaration(classes[name]) for name in names},
        "detectors": asdict(DetectorSettings()),
    }
    if args.json:
        _print_json(payload)
        return 0
    from hoopbench.reports.sweep.control_chars import terminal_text

    print(terminal_text(_settings_text(payload)))  # a plugin's reasons are its own text
    return 0


def _settings_text(payload: dict[str, Any]) -> str:
    lines = ["common: " + ", ".join(f"{k}={v}" for k, v in payload["common"].items())]
    for name, spec in payload["engines"].items():
        lines.append(f"{name} (geometries: {', '.join(spec['geometries'])})")
        for key, value in spec["options"].items():
            stock = spec["stock"][key]
            lines.append(f"  {key} = {value}" + ("" if stock == value else f"  (stock: {stock})"))
            lines.append(f"      {spec['reasons'][key]}")
            lines.append(f"      search: {spec['search'][key]}")
        if spec["variants"]:
            lines.append("  suite variants: " + ", ".join(v["name"] for v in spec["variants"]))
    lines.append("detectors: " + ", ".join(f"{k}={v}" for k, v in payload["detectors"].items()))
    return "\n".join(lines)


def _search_text(option: Any) -> str:
    """What ``hoopbench tune`` tries for an option, in a few words."""
    if option.space is None:
        return f"not searched: {option.outside_search}"
    if isinstance(option.space, tuple):
        parts = ["default" if s is None else s.describe() for s in option.space]
        return "(" + "; ".join(parts) + ")"
    return str(option.space.describe())


def _engine_declaration(cls: Any) -> dict[str, Any]:
    return {
        "geometries": list(cls.geometries),
        "options": cls.defaults(),
        "stock": cls.defaults(Profile.STOCK),
        "reasons": {option.name: option.reason for option in cls.options},
        "search": {option.name: _search_text(option) for option in cls.options},
        "variants": [
            {"name": v.name, "geometry": v.geometry, "options": dict(v.options)}
            for v in cls.variants
        ],
        "model": cls.model_format,
    }


def _cmd_compare(args: argparse.Namespace) -> int:
    import hoopbench.reports.api as api
    from hoopbench.reports.sweep.cluster import executor_from_args
    from hoopbench.reports.sweep.runner import RunnerError

    resume = _compare_resume_command(args)
    job = api.suite_job(  # the whole suite and every option checked before anything runs
        args.suite,
        run_timeout=args.run_timeout,
        engines=args.engines,
        trajectories=args.trajectories,
        announce=None if args.quiet else _announce_suite,
        settings=args.settings,
        engine_versions=args.engine_version,
    )
    if job.settings is not None and not args.quiet:
        _say_tier_note(*job.settings)
    if args.scheduler and args.trajectories != "none" and not args.quiet:
        print(
            "hoopbench: note: the Dask workers write the trajectories into --out as they see "
            "it: on other machines that needs a shared file system at the same path",
            file=sys.stderr,
        )
    try:
        with executor_from_args(args) as executor:
            summary = api.run_suite(
                job,
                args.out,
                jobs=args.jobs,
                resume=args.resume,
                quiet=args.quiet,
                executor=executor,
                batch_size=args.batch_size,
            )
    except (RunnerError, KeyboardInterrupt, OSError) as exc:
        return _sweep_failed(exc, args.out, resume)
    _say_how_the_sweep_ended(summary, args.out, resume, args.quiet)
    return summary.exit_code


def _compare_resume_command(args: argparse.Namespace) -> str:
    """The command that finishes this sweep, as typed (shell-quoted): the suite's runs as
    chosen (without --engines a resume runs every engine of the suite: the line dropped it),
    their settings file and releases (another or none is refused), their trajectories and
    time limit."""
    import shlex

    words = ["hoopbench", "compare", "--suite", str(args.suite), "--out", str(args.out)]
    if args.engines:
        words += ["--engines", *args.engines]
    if args.settings is not None:
        words += ["--settings", str(args.settings)]
    for text in args.engine_version:
        words += ["--engine-version", text]
    if args.trajectories != "none":
        words += ["--trajectories", args.trajectories]
    if args.run_timeout is not None:
        words += ["--run-timeout", str(args.run_timeout)]
    return shlex.join([*words, "--resume"])


LARGE_SUITE_RUNS = 10_000
"""From this many runs on, checking a suite takes a second or more: say so before."""


def _announce_suite(name: str, runs: int) -> None:
    if runs >= LARGE_SUITE_RUNS:
        _say(f"suite {name}: {runs:,} runs; checking each run's settings first")


def _say_how_the_sweep_ended(summary: RunSummary, out: str, resume: str, quiet: bool) -> None:
    """On stderr: how to resume an interrupted sweep, else (unless quiet) its status counts."""
    if summary.interrupted is not None:
        _say(
            f"interrupted by {summary.interrupted.name}; {summary.total} run(s) "
            f"stored, {summary.unfinished} left. Resume with: {resume}"
        )
    elif not quiet:
        counts = ", ".join(f"{n} {s}" for s, n in sorted(summary.counts.items()) if n)
        _say(f"{counts or 'nothing to run'} -> {out}")


def _cmd_report(args: argparse.Namespace) -> int:
    import hoopbench.reports.api as api
    from hoopbench.reports.sweep.runner import RunnerError

    out = args.out if args.out is not None else args.results[0]
    try:
        path = api.report(args.results, args.out, force=args.force, say=_report_steps())
    except RunnerError as exc:  # another report (or a sweep) is writing into the folder
        raise UsageError(str(exc)) from None
    except KeyboardInterrupt:
        _error(
            f"interrupted (Ctrl-C) while the report was written into {out}: the files "
            "written so far are whole but the report is not; the results are unchanged"
        )
        return EXIT_INTERRUPTED
    except OSError as exc:
        if not _system_error(exc):
            raise
        kept = "the results folders are only read: their runs are unchanged"
        raise _write_failure(exc, out, kept) from None
    print(path)
    return 0


def _report_steps() -> Callable[[str], None] | None:
    """The report's progress: what it is doing, a line a step on stderr with the time since
    it began, as a suite's progress lines; on a terminal, or as make report's last step
    (report-runs --report, which sets started_drawing: its log holds the sweeps' progress
    lines, and its 20-odd seconds of report were silent there); None elsewhere, so that a
    refused input stays the one line a script or a log reads."""
    import time

    from hoopbench.reports.report.drawing_processes import started_drawing
    from hoopbench.reports.sweep.control_chars import terminal_text

    isatty = getattr(sys.stderr, "isatty", None)
    terminal = isatty is not None and isatty()
    if not terminal and started_drawing.get() is None:
        return None
    start = time.monotonic()

    def say(text: str) -> None:
        elapsed = round(time.monotonic() - start)
        when = f"{elapsed // 60}m{elapsed % 60:02d}s" if elapsed >= 60 else f"{elapsed}s"
        print(f"report: {terminal_text(text)}; elapsed {when}", file=sys.stderr, flush=True)

    return say


def _cmd_findings(args: argparse.Namespace) -> int:
    import pandas as pd

    from hoopbench.reports.report.best_settings import best_settings, is_tune_folder
    from hoopbench.reports.report.build import answer_left_out_of, report_frame
    from hoopbench.reports.report.findings import readme_markdown, update_readme

    searches = [folder for folder in args.results if is_tune_folder(folder)]
    results = [folder for folder in args.results if folder not in searches]
    for folder in results:
        if not (Path(folder) / "runs").is_dir():
            raise UsageError(f"--results {folder!r} holds no results (no runs/ folder)")
    if not results:
        raise UsageError("--results names searches only: give a results folder too")
    if args.update and not Path(args.update).is_file():
        update = Path(args.update)
        kind = "is not a regular file (a FIFO, a device)" if update.exists() else "does not exist"
        what = "is a folder" if update.is_dir() else kind
        raise UsageError(f"--update {args.update!r} {what}: give a Markdown file with the markers")
    frame = pd.concat([report_frame(Path(f)) for f in results], ignore_index=True)
    text = readme_markdown(frame, best_settings(searches), answer_left_out_of(results))
    if not args.update:
        print(text)
        return 0
    try:
        print(update_readme(args.update, text))
    except OSError as exc:
        if not _system_error(exc):
            raise
        raise _write_failure(exc, args.update, f"{args.update!r} is unchanged") from None
    return 0


def _cmd_figure(args: argparse.Namespace) -> int:
    from hoopbench.reports.report.figures import hoop_figure

    scene = _scene_from_args(args)
    out = _output_file(args.out, (".png", ".pdf", ".svg"), args.force)
    path = hoop_figure(scene, out, method=args.method)
    print(path)
    return 0


# --------------------------------------------------------------------------- map
def _map_spec(args: argparse.Namespace) -> Any:
    """The map's spec from the options; on --resume, options not given come from the map
    stored in --out (hoopbench.reports.api.map_spec)."""
    import hoopbench.reports.api as api
    from hoopbench.reports.hop_map.spec import Axis

    fixed = {str(a): getattr(args, str(a)) for a in Axis if getattr(args, str(a)) is not None}
    return api.map_spec(
        args.out,
        resume=args.resume,
        x=args.x,
        y=args.y,
        x_range=args.x_range,
        y_range=args.y_range,
        grid=args.grid,
        fixed=fixed,
        t_end=args.t_end,
        engines=args.engines,
        timestep=args.dt,
        profile=args.profile,
        engine_timesteps=_engine_steps(args.engine_dt),
    )


def _engine_steps(pairs: Sequence[tuple[str, float]] | None) -> dict[str, float] | None:
    """--engine-dt's pairs as a mapping; an engine given twice is refused (one would be
    dropped without a word)."""
    if not pairs:
        return None
    steps: dict[str, float] = {}
    for name, step in pairs:
        if name in steps:
            raise UsageError(
                f"--engine-dt gives {name} twice ({steps[name]:g} and {step:g}): give each "
                "engine one step"
            )
        steps[name] = step
    return steps


def _cmd_report_runs(args: argparse.Namespace) -> int:
    """Each step as its own command runs it (folder, resume line, outputs), in one process
    under one plan, overlapping on one pool: their progress lines end with the plan's
    (reports/report_runs.py)."""
    import shlex

    from hoopbench.reports.api import default_jobs
    from hoopbench.reports.report_runs import MAP_STEP, REPORT_SUITES, Step, report_plan

    out = Path(args.out)
    n = len(REPORT_SUITES)
    steps = [
        Step(
            f"suite {k} of {n} ({name})", ("compare", "--suite", name, "--out", str(out / name), *o)
        )
        for k, (name, o) in enumerate(REPORT_SUITES, 1)
    ]
    spec = None
    if args.map.strip():
        argv = ["map", *shlex.split(args.map), "--out", str(out / "map")]
        spec = _map_spec(_parser().parse_args(argv))  # every value checked before any run
        steps.append(Step(f"{MAP_STEP} ({args.map.strip()})", tuple(argv), sweeps=2))
    plan = report_plan(
        [name for name, _ in REPORT_SUITES], spec, default_jobs(), DEFAULT_BATCH_SIZE
    )
    if args.report is None:
        return _run_steps(plan, steps, args.calls)
    from hoopbench.reports.api import results_folders

    results_folders("report", args.report)  # a bad folder refused now, not after the sweeps
    from hoopbench.reports.report.drawing_processes import StartedDrawing, started_drawing

    # The report's drawing processes start beside the map's last runs (drawing_processes).
    started = StartedDrawing(_ready_to_draw)
    token = started_drawing.set(started)
    try:
        code = _run_steps(plan, steps, args.calls, started.start)
        if code:
            return code
        results = [str(out / name) for name, _ in REPORT_SUITES]
        results += [str(out / "map")] if spec is not None else []
        _say_plain(f"make report: the report of the {n} suites"
                   f"{' and the map' if spec is not None else ''} -> {out}")  # fmt: skip
        return main(["report", "--results", *results, *args.report, "--out", str(out)])
    finally:
        started_drawing.reset(token)
        started.close()


def _run_steps(
    plan: Any, steps: Sequence[Any], calls: str | None, queued: Callable[[], object] | None = None
) -> int:
    """report-runs' steps (run_steps), each call's cost written to ``calls`` if given."""
    from hoopbench.reports.report_runs import run_steps

    try:
        return run_steps(plan, steps, main, _say_plain, queued)
    finally:
        if calls is not None:
            _write_calls(plan.finished, Path(calls))


def _ready_to_draw() -> None:
    """In a report's drawing process as it starts: the imports its drawings need."""
    import hoopbench.reports.report.page  # noqa: F401
    from hoopbench.reports.report.plotting import pyplot

    pyplot()


def _write_calls(finished: Sequence[Any], path: Path) -> None:
    """Each finished call a JSON line (report-runs --calls): its kinds, steps, worlds, wall
    seconds and flags, its worker's pid, when it started (s after the first call started),
    the CPU s its worker spent on it and the world-steps its rows say it took (the
    priors' fit reads them: costs.batch_world_steps; None where unknown)."""
    starts = [d.started for d in finished if d.started is not None]
    zero = min(starts, default=0.0)
    lines = [
        json.dumps(
            {
                "kinds": list(d.call.kinds),
                "steps": d.call.steps,
                "worlds": d.call.worlds,
                "seconds": d.seconds,
                "cold": d.cold,
                "first": d.first,
                "new": d.new,
                "worker": d.worker,
                "started": None if d.started is None else d.started - zero,
                "cpu_s": d.cpu_s,
                "world_steps": d.world_steps,
            }
        )
        for d in finished
    ]
    path.write_text("".join(line + "\n" for line in lines))


def _say_plain(text: str) -> None:
    """A line on stderr as it is (its names are ours or the caller's folder, quoted safe)."""
    from hoopbench.reports.sweep.control_chars import say

    say(text)


def _cmd_map(args: argparse.Namespace) -> int:
    import hoopbench.reports.api as api
    from hoopbench.reports.report.drawing_processes import started_drawing
    from hoopbench.reports.report.map_section import write_map_outputs
    from hoopbench.reports.sweep.cluster import executor_from_args
    from hoopbench.reports.sweep.runner import RunnerError

    spec = _map_spec(args)  # every value is checked before anything runs
    resume = f"hoopbench map --out {args.out} --resume"
    try:
        with executor_from_args(args) as executor:
            summary = api.run_hop_map(
                spec,
                args.out,
                jobs=args.jobs,
                executor=executor,
                resume=args.resume,
                quiet=args.quiet,
                batch_size=args.batch_size,
            )
    except (RunnerError, KeyboardInterrupt, OSError) as exc:
        return _sweep_failed(exc, args.out, resume)
    _say_how_the_sweep_ended(summary, args.out, resume, args.quiet)
    if summary.interrupted is not None:
        return summary.exit_code
    if not args.quiet and summary.unfinished:
        _say(
            f"{summary.unfinished} run(s) still to do (a point's reference "
            f"timed out or crashed): hoopbench map --out {args.out} --resume"
        )
    started = started_drawing.get()  # report-runs --report's: the figures side by side
    try:
        paths = write_map_outputs(args.out, None if started is None else started.lent())
    except OSError as exc:
        if not _system_error(exc):
            raise
        kept = f"every run is stored in {args.out}/runs; draw the map again with: {resume}"
        raise _write_failure(exc, args.out, kept) from None
    for path in paths:
        print(path)
    return summary.exit_code


# --------------------------------------------------------------------------- parser
_TRAJECTORY_SUFFIXES = (".csv", ".parquet")


def _engine_options(p: argparse.ArgumentParser, engines: Sequence[str]) -> None:
    geometries = sorted({g for cls in engine_classes().values() for g in cls.geometries})
    p.add_argument("--engine", required=True, choices=engines, help="the engine to run")
    p.add_argument("--dt", type=_number, help=f"engine timestep, s (default {DEFAULT_TIMESTEP:g})")
    p.add_argument("--mu", type=_number, help="pair friction coefficient (default: mus)")
    p.add_argument(
        "--restitution",
        type=_number,
        default=0.0,
        help="coefficient of restitution of the hoop-floor pair, 0 to 1 (default 0, every "
        "suite's; MuJoCo, MJX, MuJoCo Warp, Drake, Box2D and Newton refuse any other "
        "value; the reference, whose window ends at the first impact, ignores it)",
    )
    p.add_argument(
        "--geometry", default="sphere", help=f"contact geometry: {', '.join(geometries)}"
    )
    p.add_argument(
        "--set",
        action="append",
        metavar="KEY=VALUE",
        help="engine-specific setting, real engine name (repeatable; see hoopbench settings)",
    )
    p.add_argument(
        "--profile",
        choices=tuple(str(p) for p in Profile),
        default=str(Profile.TUNED),
        help="option values to start from: hoopbench's tuned defaults or the engine's own",
    )
    p.add_argument(
        "--max-steps",
        type=_positive_int,
        default=MAX_STEPS,
        help=f"refuse a run needing more steps (default {MAX_STEPS:.0e})",
    )


def _engine_step(text: str) -> tuple[str, float]:
    """'mjx=1e-4' -> ('mjx', 1e-4): an engine's own step on a map (the name is checked by
    the map's spec, the step by _number and then the spec)."""
    name, sep, value = text.partition("=")
    if not sep or not name.strip():
        raise argparse.ArgumentTypeError(f"must be ENGINE=DT, got {text!r}")
    return name.strip(), _number(value)


def _add_map_options(p: argparse.ArgumentParser) -> None:
    from hoopbench.reports.hop_map.spec import (
        AXES,
        DEFAULT_ENGINES,
        DEFAULT_GRID,
        ENGINE_TIMESTEPS,
        Axis,
    )

    axes = [str(a) for a in Axis]
    p.add_argument("--x", choices=axes, help="parameter along x (default lam)")
    p.add_argument("--y", choices=axes, help="parameter along y (default chi)")
    p.add_argument(
        "--grid",
        type=_grid,
        metavar="NXxNY",
        help=f"points along x and y (default {DEFAULT_GRID[0]}x{DEFAULT_GRID[1]})",
    )
    p.add_argument("--x-range", nargs=2, type=_number, metavar=("LO", "HI"), help="x's range")
    p.add_argument("--y-range", nargs=2, type=_number, metavar=("LO", "HI"), help="y's range")
    group = p.add_argument_group("fixed values", "the parameters that are not axes")
    for axis, info in AXES.items():
        unit = f" {info.unit}" if info.unit else ""
        group.add_argument(
            f"--{str(axis).replace('_', '-')}",
            dest=str(axis),
            type=_number,
            help=f"(default {info.fixed:g}{unit}; as an axis {info.default_range[0]:g} to "
            f"{info.default_range[1]:g})" + (": mus = muk" if axis is Axis.MU else ""),
        )
    p.add_argument("--t-end", type=_number, help="end of each scene's window, s (default 3)")
    p.add_argument(
        "--engines",
        nargs="*",
        metavar="ENGINE",
        help=f"engines to run at every point (default {' '.join(DEFAULT_ENGINES)}; "
        "none: the exact regimes alone)",
    )
    own = " ".join(f"{name}={dt:g}" for name, dt in ENGINE_TIMESTEPS.items())
    p.add_argument(
        "--dt",
        type=_number,
        help=f"timestep of the engines without their own, s (default {DEFAULT_TIMESTEP:g})",
    )
    p.add_argument(
        "--engine-dt",
        nargs="+",
        type=_engine_step,
        metavar="ENGINE=DT",
        help=f"an engine's own timestep, s (default {own}: the batched engines at the "
        "suites' step, for their cost; docs/map.md)",
    )
    p.add_argument(
        "--profile", choices=[str(x) for x in Profile], help="engine option values (default tuned)"
    )
    p.add_argument(
        "--out", required=True, type=_folder, help="map folder (new or empty, or --resume)"
    )
    p.add_argument("--jobs", type=_workers, help="worker processes (default 2, at most the cores)")
    _add_batch_size(p)
    p.add_argument(
        "--resume",
        action="store_true",
        help="finish the map stored in --out (its settings come from its map.toml)",
    )
    p.add_argument("--quiet", action="store_true", help="no progress output")


METHODS = ("exact", "seed-euler")
METHOD_HELP = (
    "exact: the exact solution (default); seed-euler: the seed document's fixed-step scheme "
    "for the slipping phase (docs/reference.md)"
)
"""The reference's two solvers: `reference` and `figure` offer both."""


def _add_scenes(sub: Any, classes: Mapping[str, Any]) -> None:
    p = sub.add_parser("scenes", help="list the scene catalogue")
    p.add_argument(
        "--json", action="store_true", help="print one JSON object: each scene's parameters"
    )
    p.set_defaults(func=_cmd_scenes)


def _add_reference(sub: Any, classes: Mapping[str, Any]) -> None:
    p = sub.add_parser("reference", help="solve a scene with the reference solver")
    _add_scene_options(p)
    p.add_argument("--method", choices=METHODS, default="exact", help=METHOD_HELP)
    p.add_argument("--dt", type=_seconds, help="seed-euler step (default 0.002 s); CSV sampling")
    p.add_argument("--delta", type=_number, default=1e-4, help="seed-euler contact tolerance, m")
    p.add_argument("--rtol", type=_number, default=DEFAULT_RTOL, help="exact: integrator rtol")
    p.add_argument("--atol", type=_number, default=DEFAULT_ATOL, help="exact: integrator atol")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.add_argument("--csv", help="write the trajectory (.csv or .parquet)")
    p.add_argument("--force", action="store_true", help="overwrite an existing --csv file")
    p.set_defaults(func=_cmd_reference)


def _add_simulate(sub: Any, classes: Mapping[str, Any]) -> None:
    p = sub.add_parser("simulate", help="run a scene in an engine and detect its events")
    _add_scene_options(p)
    _engine_options(p, tuple(classes))
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.add_argument("--csv", help="write the trajectory (.csv or .parquet)")
    p.add_argument("--force", action="store_true", help="overwrite an existing --csv file")
    p.add_argument(
        "--settings",
        metavar="FILE[#NAME]",
        help="a settings file of hoopbench tune: its first setting, the one named NAME, or "
        "the cheapest of a tier (FILE#close, FILE#agrees)",
    )
    p.set_defaults(func=_cmd_simulate)


def _add_export(sub: Any, classes: Mapping[str, Any]) -> None:
    exportable = tuple(name for name, cls in classes.items() if cls.exports())
    p = sub.add_parser(
        "export",
        help="write a standalone script that reproduces one run with the engine's API alone",
    )
    _add_scene_options(p)
    _engine_options(p, exportable)
    p.add_argument(
        "--settings",
        metavar="FILE[#NAME]",
        help="a settings file of hoopbench tune: its first setting, the one named NAME, or "
        "the cheapest of a tier (FILE#close, FILE#agrees)",
    )
    p.add_argument(
        "--out", required=True, help="the script to write (.py); run it as: python FILE out.csv"
    )
    p.add_argument("--force", action="store_true", help="overwrite an existing --out file")
    p.set_defaults(func=_cmd_export)


def _add_model(sub: Any, classes: Mapping[str, Any]) -> None:
    p = sub.add_parser("model", help="print the engine's native model of a scene")
    _add_scene_options(p)
    # Every engine: one without a model file says so in one line (Engine.model_note).
    _engine_options(p, tuple(classes))
    p.set_defaults(func=_cmd_model)


def _add_settings(sub: Any, classes: Mapping[str, Any]) -> None:
    p = sub.add_parser("settings", help="print the default contact and detector settings")
    p.add_argument("--engine", choices=tuple(classes), help="this engine's alone (default: all)")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=_cmd_settings)


def _add_compare(sub: Any, classes: Mapping[str, Any]) -> None:
    from hoopbench.reports.compare.suite_file import TrajectoryChoice, shipped_suites
    from hoopbench.reports.sweep.cluster import add_cluster_arguments

    p = sub.add_parser("compare", help="run a suite file: isolated, resumable, stored as Parquet")
    p.add_argument(
        "--suite",
        required=True,
        help=f"suite file (.toml), or a shipped one: {', '.join(shipped_suites())}",
    )
    p.add_argument(
        "--out", required=True, type=_folder, help="results folder (new or empty, or --resume)"
    )
    p.add_argument("--jobs", type=_workers, help="worker processes (default 2, at most the cores)")
    _add_batch_size(p)
    p.add_argument("--resume", action="store_true", help="skip runs already stored")
    p.add_argument(
        "--run-timeout",
        type=_number,
        metavar="SECONDS",
        help="time limit per run (default: 60 s + 0.5 ms per step)",
    )
    p.add_argument("--engines", nargs="+", metavar="ENGINE", help="only these engines of the suite")
    p.add_argument(
        "--engine-version",
        action="append",
        default=[],
        metavar="ENGINE==VERSION",
        help="run ENGINE on this release of its package in place of the installed one "
        "(repeatable; each release installed once into its own cached folder: docs/cli.md)",
    )
    p.add_argument("--quiet", action="store_true", help="no progress output")
    p.add_argument(
        "--trajectories",
        choices=[c.value for c in TrajectoryChoice],
        default="none",
        help="store trajectories: of no run, of the default-settings runs, or of all",
    )
    p.add_argument(
        "--settings",
        metavar="FILE[#NAME]",
        help="a settings file of hoopbench tune: each of its settings runs as a variant "
        "(FILE#NAME: the setting NAME; FILE#close, FILE#agrees: the cheapest of that tier)",
    )
    add_cluster_arguments(p)
    p.set_defaults(func=_cmd_compare)


def _add_map(sub: Any, classes: Mapping[str, Any]) -> None:
    from hoopbench.reports.sweep.cluster import add_cluster_arguments

    p = sub.add_parser(
        "map", help="the hop map: exact regimes and engine verdicts over a grid of scenes"
    )
    _add_map_options(p)
    add_cluster_arguments(p)
    p.set_defaults(func=_cmd_map)


def _add_report_runs(sub: Any, classes: Mapping[str, Any]) -> None:
    p = sub.add_parser(
        "report-runs",
        help="make report's three suites and hop map in one process, overlapping on one pool "
        "of workers, with one progress line",
    )
    p.add_argument(
        "--out",
        required=True,
        type=_folder,
        help="make report's folder: each suite, and the map, into a folder of it",
    )
    p.add_argument(
        "--map",
        default="",
        metavar="ARGS",
        help="hoopbench map's options, in one string (make report's MAP_ARGS); empty: no map",
    )
    p.add_argument(
        "--calls",
        type=_folder,
        metavar="FILE",
        help="also write each finished call (kinds, steps, worlds, seconds, cold) as a JSON "
        "line: what python -m hoopbench.reports.bench.call_costs fit reads",
    )
    p.add_argument(
        "--report",
        nargs="*",
        metavar="DIR",
        help="then, once every step has succeeded, the report of the suites, the map and these "
        "folders (searches, make bench's) into --out, as hoopbench report --results would write "
        "it; its drawing processes start while the map's last runs end (make report's)",
    )
    p.set_defaults(func=_cmd_report_runs)


def _add_report(sub: Any, classes: Mapping[str, Any]) -> None:
    p = sub.add_parser("report", help="write report.md and figures from stored results")
    p.add_argument(
        "--results",
        required=True,
        nargs="+",
        metavar="DIR",
        help="results folders of hoopbench compare (e.g. the default and stability suites)",
    )
    p.add_argument("--out", type=_folder, help="report folder (default: the first results folder)")
    p.add_argument("--force", action="store_true", help="replace an existing report.md")
    p.set_defaults(func=_cmd_report)


def _add_findings(sub: Any, classes: Mapping[str, Any]) -> None:
    p = sub.add_parser(
        "findings", help="the answer, the scoreboard and the key findings, as Markdown"
    )
    p.add_argument(
        "--results",
        required=True,
        nargs="+",
        metavar="DIR",
        help="results folders, and searches of hoopbench tune whose settings the answer weighs",
    )
    p.add_argument(
        "--update", metavar="README", help="replace the findings block of this Markdown file"
    )
    p.set_defaults(func=_cmd_findings)


def _add_figure(sub: Any, classes: Mapping[str, Any]) -> None:
    p = sub.add_parser("figure", help="draw a hoop trajectory (weight and hoop positions)")
    _add_scene_options(p)
    p.add_argument("--method", choices=METHODS, default="exact", help=METHOD_HELP)
    p.add_argument("--out", default="hoop.png", help="image file (.png, .pdf or .svg)")
    p.add_argument("--force", action="store_true", help="overwrite an existing --out file")
    p.set_defaults(func=_cmd_figure)


def _add_tune(sub: Any, classes: Mapping[str, Any]) -> None:
    from hoopbench.reports.sweep.cluster import add_cluster_arguments

    p = sub.add_parser(
        "tune", help="search an engine's settings, error against cost (needs the tune extra)"
    )
    p.add_argument(
        "--engine",
        required=True,
        choices=[n for n in classes if n != "reference"],
        help="the engine whose settings to search",
    )
    p.add_argument("--out", required=True, type=_folder, help="search folder (new, or --resume)")
    p.add_argument(
        "--scenes", nargs="+", metavar="NAME", help="training scenes (default: the catalogue's)"
    )
    p.add_argument("--trials", type=_positive_int, help="trials in all (a resumed search's too)")
    p.add_argument("--timeout", type=_seconds, help="seconds this session may start trials for")
    p.add_argument("--seed", type=int, default=0, help="the sampler's seed (default 0)")
    p.add_argument("--heldout-seed", type=int, help="the held-out scenes' seed")
    p.add_argument(
        "--heldout-per-regime",
        type=_count,
        default=1,
        help="held-out random scenes of each regime (default 1)",
    )
    p.add_argument(
        "--heldout-neighbours",
        type=_count,
        default=1,
        metavar="N",
        help="held-out neighbours of each training scene: its parameters moved at random, its "
        "events kept (default 1)",
    )
    p.add_argument("--jobs", type=_workers, help="worker processes (default 2, at most the cores)")
    _add_batch_size(p)
    p.add_argument("--run-timeout", type=_seconds, help="time limit per run, s")
    p.add_argument("--resume", action="store_true", help="go on with the search in --out")
    p.add_argument("--quiet", action="store_true", help="no progress output")
    add_cluster_arguments(p)
    p.set_defaults(func=_cmd_tune)


def _cmd_tune(args: argparse.Namespace) -> int:
    import hoopbench.reports.api as api
    from hoopbench.reports.sweep.cluster import executor_from_args
    from hoopbench.reports.sweep.runner import ExecutorBrokenError, RunnerError
    from hoopbench.reports.tune.search import TuneUnavailableError

    job = api.tune_job(
        args.engine,
        scenes=args.scenes,
        trials=args.trials,
        timeout=args.timeout,
        seed=args.seed,
        heldout_seed=args.heldout_seed,
        heldout_per_regime=args.heldout_per_regime,
        heldout_neighbours=args.heldout_neighbours,
        run_timeout=args.run_timeout,
    )
    try:
        with executor_from_args(args) as executor:
            result, front = api.run_tune(
                job,
                args.out,
                resume=args.resume,
                jobs=args.jobs,
                quiet=args.quiet,
                executor=executor,
                batch_size=args.batch_size,
            )
    except ExecutorBrokenError as exc:
        resume = _tune_resume_command(args)
        return _broken_sweep(exc, f"every finished trial is kept; resume with: {resume}")
    except (RunnerError, TuneUnavailableError) as exc:
        raise UsageError(str(exc)) from None
    if result.interrupted or front is None:
        _say(
            f"interrupted; every finished trial is kept. Resume with: {_tune_resume_command(args)}"
        )
        return EXIT_INTERRUPTED
    columns = ["setting", "kind", "timestep", "train_error", "heldout_error"]
    columns += ["train_cost_us_per_s", "overfitted"]
    print(
        f"costs: {result.cost_clock.label} time of the stepping, us per simulated s (the wall "
        "time's beside them in front.csv)"
    )
    print(front[columns].to_string(index=False, float_format=lambda v: f"{v:.4g}"))
    _say(f"settings -> {Path(args.out) / 'settings.toml'}")
    return 0


_TUNE_RESUMED_OPTIONS = (
    "scenes",
    "trials",
    "timeout",
    "seed",
    "heldout_seed",
    "heldout_per_regime",
    "heldout_neighbours",
    "run_timeout",
)
"""The options a resumed search is given again: the search's own (a resume with others is
refused: search.check_resumable) and its budget as it was given."""


def _tune_resume_command(args: argparse.Namespace) -> str:
    """The command that resumes this search, as typed: every option given, quoted for a
    shell (the old line dropped --scenes and the held-out options and said --trials N)."""
    import shlex

    words = ["hoopbench", "tune", "--engine", args.engine, "--out", str(args.out)]
    for name in _TUNE_RESUMED_OPTIONS:
        value = getattr(args, name)
        if value is not None:
            values = value if isinstance(value, list) else [value]
            words += [f"--{name.replace('_', '-')}", *map(str, values)]
    return shlex.join([*words, "--resume"])


def _add_bench(sub: Any, classes: Mapping[str, Any]) -> None:
    from hoopbench.reports.bench.command import PARTS, BenchPlan

    plain = BenchPlan()
    p = sub.add_parser(
        "bench", help="measure adapters' overhead and batch costs (make bench; no test)"
    )
    p.add_argument("--parts", nargs="+", choices=PARTS, default=list(PARTS),
                   help="what to measure (default: all, in this order)")  # fmt: skip
    p.add_argument("--engines", nargs="+", metavar="ENGINE", help="only these engines")
    p.add_argument("--sizes", type=_positive_int, nargs="+", metavar="N",
                   default=list(plain.sizes), help="worlds per batch (batch, batched)")  # fmt: skip
    p.add_argument("--steps", type=_positive_int, metavar="N",
                   help="steps per world (default 1000 for batch, 100 for batched)")  # fmt: skip
    p.add_argument("--repeat", type=_positive_int, default=plain.repeat, metavar="N",
                   help="best of N (overhead, batch)")  # fmt: skip
    p.add_argument("--grid", type=_grid, default="x".join(map(str, plain.grid)),
                   help="the hop map's grid (map)")  # fmt: skip
    p.add_argument("--jobs", type=_workers, default=plain.jobs, help="the hop map's workers")
    p.add_argument("--scene", default=plain.scene, help="the overhead part's scene")
    p.add_argument("--dt", type=_seconds, default=plain.dt, help="the overhead part's timestep, s")
    p.add_argument("--out", type=_folder, help="folder for batch_cost.csv (batched), the report's")
    p.add_argument("--force", action="store_true", help="replace an existing batch_cost.csv")
    p.set_defaults(func=_cmd_bench)


def _cmd_bench(args: argparse.Namespace) -> int:
    from hoopbench.reports.bench.command import BenchPlan, check_plan, run_bench

    plan = BenchPlan(
        parts=tuple(dict.fromkeys(args.parts)),
        engines=None if args.engines is None else tuple(args.engines),
        sizes=tuple(args.sizes),
        steps=args.steps,
        repeat=args.repeat,
        grid=args.grid,
        jobs=args.jobs,
        scene=args.scene,
        dt=args.dt,
        out=None if args.out is None else Path(args.out),
        force=args.force,
    )
    try:
        check_plan(plan)
    except ValueError as exc:
        raise UsageError(str(exc)) from None
    run_bench(plan)
    return 0


def _parser() -> _Parser:
    parser = _Parser(
        prog="hoopbench",
        description="Cross-validate physics engines on the hopping hoop.",
    )
    parser.add_argument("--version", action="version", version=f"hoopbench {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)
    classes = engine_classes()

    for add in (
        _add_scenes,
        _add_reference,
        _add_simulate,
        _add_export,
        _add_model,
        _add_settings,
        _add_compare,
        _add_map,
        _add_report_runs,
        _add_report,
        _add_findings,
        _add_figure,
        _add_tune,
        _add_bench,
    ):
        add(sub, classes)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    if signal.getsignal(signal.SIGINT) is _stopped_while_starting:  # loaded: main says it
        signal.signal(signal.SIGINT, signal.default_int_handler)
        signal.signal(signal.SIGTERM, signal.SIG_DFL)
    try:
        args = _parser().parse_args(argv)
        code = args.func(args)
        sys.stdout.flush()  # inside the try: a reader gone away fails here, not at exit
        return code
    except KeyboardInterrupt:
        # Ctrl-C outside a sweep's own handling (checking a suite, reaching a scheduler):
        # nothing has run yet, so there is nothing to resume either.
        print("hoopbench: interrupted (Ctrl-C) before anything ran", file=sys.stderr)
        return EXIT_INTERRUPTED
    except BrokenPipeError:
        # The reader went away (`hoopbench ... | head`): stop quietly, as Unix tools do.
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 141
    except OSError as exc:
        if not _system_error(exc):
            raise
        # A write or read the system refused (disk full, read-only folder, no permission)
        # outside the commands that say what they keep: the path and the reason.
        where = f"{str(exc.filename)!r}: " if exc.filename is not None else ""
        _error(f"error: {where}{exc.strerror or exc}")
        return EXIT_USAGE
    except (UsageError, ValueError) as exc:
        # ValueError: a scene, setting or engine name that failed validation.
        if isinstance(exc, DegenerateSceneError):
            _error(f"degenerate scene: {_message(exc)}")
        else:
            _error(f"error: {_message(exc)}")
        return EXIT_USAGE


_QUOTED_SHOWN = 200
"""Characters of a quoted value an error line shows whole (a long path among them); a longer
one (a pasted file, a runaway shell expansion) is shown by its start, its end and its length,
so that the line stays readable."""

_QUOTED = re.compile(r"(?<!\w)('[^'\n]*'|\"[^\"\n]*\")(?!\w)")
"""A quoted value as repr writes it; a quote after a letter is prose (the engine's)."""


def _short_quote(match: re.Match[str]) -> str:
    quote, value = match.group(0)[0], match.group(0)[1:-1]
    if len(value) <= _QUOTED_SHOWN:
        return match.group(0)
    return f"{quote}{value[:100]}...{value[-40:]}{quote} ({len(value):,} characters)"


def _error(text: str) -> None:
    """One line on stderr; whatever it quotes from files or names shown, never obeyed, and a
    quoted value of more than _QUOTED_SHOWN characters shortened."""
    _say(_QUOTED.sub(_short_quote, text))


def _say(text: str) -> None:
    """A line of ours on stderr, ``hoopbench: `` first; whatever it quotes from files, names
    or arguments shown, never obeyed (control_chars.say)."""
    from hoopbench.reports.sweep.control_chars import say

    say(f"hoopbench: {text}")


def _message(exc: Exception) -> str:
    """The error's line; an API option's name spelled as this command's option."""
    api = sys.modules.get("hoopbench.reports.api")  # not loaded: the error is not the API's
    if api is None or not isinstance(exc, api.OptionError):
        # One line, whatever the library put in the message (a parser's caret diagram).
        return " ".join(line.strip() for line in str(exc).splitlines() if line.strip())
    return exc.spelled(_OPTION_TEXT.get(exc.option, "--" + exc.option.replace("_", "-")))


if __name__ == "__main__":
    sys.exit(main())
