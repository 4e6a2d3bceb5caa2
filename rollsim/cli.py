"""The ``rollsim`` command line.

Bad input (a scene, an override, a path) prints one line per problem on
stderr and exits with code 2; ``--debug`` shows the traceback instead.
"""

from __future__ import annotations

import argparse
import json
import sys
from typing import Optional, Sequence

from rollsim import __version__
from rollsim.errors import RollsimError

EXIT_OK, EXIT_FAILURE, EXIT_BAD_INPUT = 0, 1, 2


def _add_set_option(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--set",
        dest="overrides",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="override a scene key, e.g. --set camera.exposure_us=50 (repeatable)",
    )


def cmd_scenes(args) -> int:
    """List the bundled scenes with their one-line descriptions."""
    from rollsim.scene import bundled_scene_paths, read_yaml

    for path in bundled_scene_paths():
        data = read_yaml(path)
        print(f"{path.stem:<16} {data.get('description', '')}")
    return EXIT_OK


def cmd_validate(args) -> int:
    """Validate scene files: exit 0 if all are valid, 2 with one line per error otherwise."""
    from rollsim.scene import load_scene

    problems: list[str] = []
    for path in args.files:
        try:
            load_scene(path, args.overrides)
        except RollsimError as exc:
            problems += exc.lines
        else:
            print(f"ok    {path}")
    if problems:
        raise RollsimError(problems)
    return EXIT_OK


def cmd_describe(args) -> int:
    """Print a scene's timing, PHY-SDU, schedule and waveform summary."""
    from rollsim.describe import describe_scene, format_description
    from rollsim.scene import load_scene

    scene = load_scene(args.scene, args.overrides)
    info = describe_scene(scene, emissions=args.emissions)
    print(json.dumps(info, indent=2) if args.json else format_description(info))
    return EXIT_OK


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="rollsim",
        description="Rolling-shutter camera simulator for optical camera communication.",
    )
    parser.add_argument("--version", action="version", version=f"rollsim {__version__}")
    parser.add_argument("--debug", action="store_true", help="show tracebacks for errors")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True

    p = sub.add_parser("scenes", help="list the bundled scenes")
    p.set_defaults(func=cmd_scenes)

    p = sub.add_parser("validate", help="check scene files")
    p.add_argument("files", nargs="+", metavar="FILE", help="scene files or bundled scene names")
    _add_set_option(p)
    p.set_defaults(func=cmd_validate)

    p = sub.add_parser("describe", help="summarise a scene's timing, PHY-SDU, schedule and waveform")
    p.add_argument("scene", metavar="SCENE", help="scene file or bundled scene name")
    _add_set_option(p)
    p.add_argument("--emissions", type=int, default=12, help="emissions of the schedule to list (default 12)")
    p.add_argument("--json", action="store_true", help="print JSON instead of text")
    p.set_defaults(func=cmd_describe)
    return parser


def main(argv: Optional[Sequence[str]] = None) -> int:
    """Entry point of the ``rollsim`` console script."""
    args = build_parser().parse_args(argv)
    try:
        return args.func(args)
    except RollsimError as exc:
        if args.debug:
            raise
        for line in exc.lines:
            print(f"rollsim: error: {line}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except KeyboardInterrupt:
        print("rollsim: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
