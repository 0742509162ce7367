"""The ``hoopbench`` command line.

Sub-commands: ``scenes``, ``reference``, ``simulate``, ``model``, ``report``, ``figure``.
Bad arguments give a one-line error on stderr and exit status 2. JSON goes to stdout only.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
from collections.abc import Sequence
from typing import Any, NoReturn

from hoopbench.engines.settings import ENGINE_OPTIONS, RunSettings, parse_option_value
from hoopbench.models.catalogue import get_scene, scene_names
from hoopbench.models.scene import DegenerateSceneError, Scene

__all__ = ["main"]

EXIT_USAGE = 2


class UsageError(Exception):
    """Bad command-line input: printed as one line, exit status 2."""


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> NoReturn:
        raise UsageError(message)


# --------------------------------------------------------------------------- scenes
_SCENE_FIELDS = {
    # option -> (Scene field, converter)
    "lam": ("lam", float),
    "eps": ("eps", float),
    "mus": ("mus", float),
    "muk": ("muk", float),
    "g": ("g", float),
    "a": ("a", float),
    "M": ("M", float),
    "t_end": ("t_end", float),
    "xdot0": ("xdot0", float),
}


def _add_scene_options(parser: argparse.ArgumentParser) -> None:
    group = parser.add_argument_group(
        "scene", "a catalogue scene (--scene) and/or explicit parameters overriding it"
    )
    group.add_argument("--scene", help=f"catalogue scene: {', '.join(scene_names())}")
    group.add_argument("--lam", type=float, help="weight's mass fraction, in [0, 1]")
    group.add_argument("--eps", type=float, help="weight's own inertia parameter, >= 0")
    spin = group.add_mutually_exclusive_group()
    spin.add_argument("--chi", type=float, help="spin parameter a*thetadot0^2/g")
    spin.add_argument("--thetadot0", type=float, help="initial spin, rad/s")
    group.add_argument("--theta0-deg", type=float, help="initial angle of the weight, deg")
    group.add_argument("--mus", type=float, help="static friction coefficient")
    group.add_argument("--muk", type=float, help="kinetic friction coefficient (<= mus)")
    group.add_argument("--g", type=float, help="gravity, m/s^2 (default 9.8)")
    group.add_argument("--a", type=float, help="hoop radius, m (default 1)")
    group.add_argument("--M", type=float, help="total mass, kg (default 1)")
    group.add_argument("--t-end", type=float, help="end of the window, s (default 3)")
    group.add_argument("--xdot0", type=float, help="initial hoop-centre velocity, m/s")


def _scene_from_args(args: argparse.Namespace) -> Scene:
    changes: dict[str, Any] = {
        field: getattr(args, option)
        for option, (field, _) in _SCENE_FIELDS.items()
        if getattr(args, option) is not None
    }
    if args.theta0_deg is not None:
        changes["theta0"] = math.radians(args.theta0_deg)
    if args.scene is not None:
        scene = get_scene(args.scene)
        if args.chi is not None:
            changes["thetadot0"] = math.sqrt(args.chi * changes.get("g", scene.g) / scene.a)
        elif args.thetadot0 is not None:
            changes["thetadot0"] = args.thetadot0
        return scene.with_(**changes) if changes else scene
    missing = [name for name in ("lam", "mus") if name not in changes]
    if args.chi is None and args.thetadot0 is None:
        missing.append("chi or thetadot0")
    if missing:
        raise UsageError(
            f"give --scene NAME or the scene parameters; missing: {', '.join(missing)}"
        )
    changes.setdefault("muk", changes["mus"])
    if args.chi is not None:
        return Scene.from_chi(args.chi, **changes)
    return Scene(thetadot0=args.thetadot0, **changes)


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
    phases = payload.get("phases") or []
    if phases:
        lines.append("phases")
        for p in phases:
            sigma = f" sigma={p['sigma']:+d}" if p.get("sigma") else ""
            lines.append(f"  {p['kind']:<7}{p['t_start']:>12.6f} .. {p['t_end']:.6f} s{sigma}")
    return "\n".join(lines)


def _emit(args: argparse.Namespace, payload: dict[str, Any]) -> None:
    if args.json:
        _print_json(payload)
    else:
        print(_summary(payload))


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
    if args.method == "exact":
        from hoopbench.reference.exact import solve_exact

        solution = solve_exact(scene, rtol=args.rtol, atol=args.atol)
        events, trajectory = solution.events, None
        if args.csv:
            trajectory = solution.sample_uniform(args.dt or 1e-3)
    else:
        from hoopbench.reference.seed_euler import solve_seed_euler

        result = solve_seed_euler(scene, dt=args.dt or 0.002, delta=args.delta)
        events = result.events
        trajectory = result.trajectory() if args.csv else None
    payload = {"method": args.method, **events.to_dict(), "scene": scene.to_dict()}
    if trajectory is not None:
        trajectory.write(args.csv)
        payload["trajectory_file"] = str(args.csv)
    _emit(args, payload)
    return 0


def _settings_from_args(args: argparse.Namespace, engine: str) -> RunSettings:
    options: dict[str, Any] = {}
    for item in args.set or []:
        key, sep, value = item.partition("=")
        if not sep or not key:
            raise UsageError(f"--set takes KEY=VALUE, got {item!r}")
        options[key.strip()] = parse_option_value(value)
    settings = RunSettings(
        timestep=args.dt if args.dt is not None else 1e-4,
        mu=args.mu,
        restitution=args.restitution,
        geometry=args.geometry,
        options=options,
    )
    settings.resolve(engine)  # unknown names fail here, before any engine is imported
    return settings


def _cmd_simulate(args: argparse.Namespace) -> int:
    from hoopbench.engines.registry import get_engine

    scene = _scene_from_args(args)
    settings = _settings_from_args(args, args.engine)
    result = get_engine(args.engine).run(scene, settings)
    payload = {**result.to_dict(), "scene": scene.to_dict()}
    if args.csv and result.trajectory is not None:
        result.trajectory.write(args.csv)
        payload["trajectory_file"] = str(args.csv)
    _emit(args, payload)
    return 0 if result.info.status.value in ("ok", "diverged") else 1


def _cmd_model(args: argparse.Namespace) -> int:
    scene = _scene_from_args(args)
    settings = _settings_from_args(args, args.engine)
    options = settings.resolve(args.engine)
    mu = scene.mus if settings.mu is None else settings.mu
    if args.engine == "mujoco":
        from hoopbench.models.mjcf import scene_to_mjcf

        text = scene_to_mjcf(
            scene,
            mu=mu,
            timestep=settings.timestep,
            restitution=settings.restitution,
            geometry=settings.geometry,
            options=options,
        )
    elif args.engine == "pybullet":
        from hoopbench.models.urdf import scene_to_urdf

        text = scene_to_urdf(scene, geometry=settings.geometry, mu=mu)
    else:
        from hoopbench.models.pymunk_space import scene_to_pymunk

        spec = scene_to_pymunk(scene, mu=mu, restitution=settings.restitution)
        text = json.dumps(spec.to_dict(), indent=2)
    sys.stdout.write(text if text.endswith("\n") else text + "\n")
    return 0


def _cmd_settings(args: argparse.Namespace) -> int:
    from dataclasses import asdict

    from hoopbench.engines.detectors import DetectorSettings
    from hoopbench.engines.settings import GEOMETRIES

    engines = [args.engine] if args.engine else list(ENGINE_OPTIONS)
    payload = {
        "common": RunSettings().to_dict(),
        "engines": {
            name: {"geometries": list(GEOMETRIES[name]), "options": dict(ENGINE_OPTIONS[name])}
            for name in engines
        },
        "detectors": asdict(DetectorSettings()),
    }
    if args.json:
        _print_json(payload)
        return 0
    print("common: " + ", ".join(f"{k}={v}" for k, v in payload["common"].items()))
    for name, spec in payload["engines"].items():
        print(f"{name} (geometries: {', '.join(spec['geometries'])})")
        for key, value in spec["options"].items():
            print(f"  {key} = {value}")
    print("detectors: " + ", ".join(f"{k}={v}" for k, v in payload["detectors"].items()))
    return 0


def _cmd_report(args: argparse.Namespace) -> int:
    from hoopbench.reports.suite import run_report

    run_report(out=args.out, quick=args.quick, workers=args.workers)
    return 0


def _cmd_figure(args: argparse.Namespace) -> int:
    from hoopbench.reports.figures import hoop_figure

    scene = _scene_from_args(args)
    path = hoop_figure(scene, args.out, method=args.method)
    print(path)
    return 0


# --------------------------------------------------------------------------- parser
def _parser() -> _Parser:
    parser = _Parser(
        prog="hoopbench",
        description="Cross-validate physics engines on the hopping hoop.",
    )
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)

    p = sub.add_parser("scenes", help="list the scene catalogue")
    p.add_argument("--json", action="store_true")
    p.set_defaults(func=_cmd_scenes)

    p = sub.add_parser("reference", help="solve a scene with the reference solver")
    _add_scene_options(p)
    p.add_argument("--method", choices=("exact", "seed-euler"), default="exact")
    p.add_argument("--dt", type=float, help="seed-euler step (default 0.002 s); CSV sampling")
    p.add_argument("--delta", type=float, default=1e-4, help="seed-euler contact tolerance, m")
    p.add_argument("--rtol", type=float, default=1e-10, help="exact: integrator rtol")
    p.add_argument("--atol", type=float, default=1e-12, help="exact: integrator atol")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.add_argument("--csv", help="write the trajectory (.csv or .parquet)")
    p.set_defaults(func=_cmd_reference)

    def engine_options(p: argparse.ArgumentParser, engines: Sequence[str]) -> None:
        p.add_argument("--engine", required=True, choices=engines)
        p.add_argument("--dt", type=float, help="engine timestep, s (default 1e-4)")
        p.add_argument("--mu", type=float, help="pair friction coefficient (default: mus)")
        p.add_argument("--restitution", type=float, default=0.0)
        p.add_argument("--geometry", default="sphere", help="sphere, cylinder, hull, ring")
        p.add_argument(
            "--set",
            action="append",
            metavar="KEY=VALUE",
            help="engine-specific setting, real engine name (repeatable)",
        )

    p = sub.add_parser("simulate", help="run a scene in an engine and detect its events")
    _add_scene_options(p)
    engine_options(p, tuple(ENGINE_OPTIONS))
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.add_argument("--csv", help="write the trajectory (.csv or .parquet)")
    p.set_defaults(func=_cmd_simulate)

    p = sub.add_parser("model", help="print the engine's native model of a scene")
    _add_scene_options(p)
    engine_options(p, ("mujoco", "pybullet", "pymunk"))
    p.set_defaults(func=_cmd_model)

    p = sub.add_parser("settings", help="print the default contact and detector settings")
    p.add_argument("--engine", choices=tuple(ENGINE_OPTIONS))
    p.add_argument("--json", action="store_true")
    p.set_defaults(func=_cmd_settings)

    p = sub.add_parser("report", help="run the comparison suite and write the report")
    p.add_argument("--out", default="reports/output", help="output folder")
    p.add_argument("--quick", action="store_true", help="a small sweep (for a smoke test)")
    p.add_argument("--workers", type=int, default=2, help="parallel processes")
    p.set_defaults(func=_cmd_report)

    p = sub.add_parser("figure", help="draw a hoop trajectory (weight and hoop positions)")
    _add_scene_options(p)
    p.add_argument("--method", choices=("exact", "seed-euler"), default="exact")
    p.add_argument("--out", default="hoop.png")
    p.set_defaults(func=_cmd_figure)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    try:
        args = _parser().parse_args(argv)
        return args.func(args)
    except BrokenPipeError:
        # The reader went away (`hoopbench ... | head`): stop quietly, as Unix tools do.
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 141
    except (UsageError, ValueError) as exc:
        # ValueError: a scene, setting or engine name that failed validation.
        if isinstance(exc, DegenerateSceneError):
            print(f"hoopbench: degenerate scene: {exc}", file=sys.stderr)
        else:
            print(f"hoopbench: error: {exc}", file=sys.stderr)
        return EXIT_USAGE


if __name__ == "__main__":
    sys.exit(main())
