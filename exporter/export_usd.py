#!/usr/bin/env python3
"""Exports a USD stage to a Cirrus scene folder (scene.json + scene.bin, see FORMAT.md).

Usage: python exporter/export_usd.py IN.usd[a|c|z] -o OUT_DIR [--frame F] [--camera PRIM_PATH]
       [--shutter OPEN,CLOSE] [--settings PRIM_PATH]

Exit codes: 0 exported (warnings, if any, on stderr and in the manifest);
2 unusable input (missing file, parse error, nothing to export), one `error:` line;
1 an internal exporter error (a bug), also one `error:` line.
"""

import argparse
import sys
from pathlib import Path

sys.dont_write_bytecode = True  # keep __pycache__ out of the source tree
sys.path.insert(0, str(Path(__file__).resolve().parent))

from cirrus_export.export import export  # noqa: E402
from cirrus_export.report import ExportError  # noqa: E402

EXIT_INTERNAL_ERROR = 1
EXIT_UNUSABLE_INPUT = 2


def parse_args(argv: list[str]) -> argparse.Namespace:
    """The command line."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("input", type=Path, help="USD file (.usd, .usda, .usdc, .usdz)")
    parser.add_argument("-o", "--out", type=Path, required=True, help="output scene folder")
    parser.add_argument("--frame", type=float, default=None,
                        help="time code (default: the stage's startTimeCode, else the default time)")
    parser.add_argument("--camera", default=None,
                        help="camera prim path (default: the render settings' camera, else the first)")
    parser.add_argument("--shutter", type=shutter_interval, default=None,
                        help="OPEN,CLOSE in frames relative to --frame (default: the camera's)")
    parser.add_argument("--settings", default=None,
                        help="UsdRender.Settings prim path (default: the stage's renderSettingsPrimPath, "
                             "else the only one)")
    return parser.parse_args(argv)


def shutter_interval(text: str) -> tuple[float, float]:
    """`OPEN,CLOSE` as two floats."""
    try:
        open_, close = (float(v) for v in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r}: expected OPEN,CLOSE in frames") from None
    return open_, close


def main(argv: list[str]) -> int:
    """Runs the export; an unusable input is one clear line on stderr, never a traceback."""
    args = parse_args(argv)
    try:
        warnings = export(args.input, args.out, args.frame, args.camera, args.shutter, args.settings)
    except ExportError as error:
        print(f"error: {error}", file=sys.stderr)
        return EXIT_UNUSABLE_INPUT
    except Exception as error:  # a bug of ours: still one line, never a traceback
        print(f"error: {args.input}: internal exporter error: {type(error).__name__}: {error}",
              file=sys.stderr)
        return EXIT_INTERNAL_ERROR
    print(f"exported {args.input} -> {args.out} ({len(warnings)} warnings)")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
