"""Renders an exported Cirrus scene folder with Mitsuba 3 into an EXR of the same framing.

Usage (from the project .venv, after scenes/peers/install):
    .venv/bin/python scenes/peers/to_mitsuba.py SCENE_DIR -o OUT.exr --res 128x96 --spp 64

SCENE_DIR is what `cirrus export IN.usda -o SCENE_DIR` writes (scenes/FORMAT.md).
The output is a float RGB EXR of linear Rec.709 radiance, box-filtered (as
`cirrus render --filter box`). Everything converted only approximately is
printed as `warning: ...` lines on stderr; mitsuba_scene.py says what maps to what.
"""

import argparse
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from cirrus_scene import CirrusScene  # noqa: E402
from mitsuba_scene import Converter  # noqa: E402


def parse_resolution(text):
    """'WxH' as (W, H), both positive."""
    w, _, h = text.partition("x")
    if not (w.isdigit() and h.isdigit() and int(w) > 0 and int(h) > 0):
        raise argparse.ArgumentTypeError(f"resolution {text!r} is not WxH")
    return int(w), int(h)


def arguments(argv=None):
    """The command line."""
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("scene", type=Path, help="exported Cirrus scene folder")
    p.add_argument("-o", "--output", type=Path, required=True, help="output EXR")
    p.add_argument("--res", type=parse_resolution, help="WxH (default: the scene's, else 640x480)")
    p.add_argument("--spp", type=int, default=64, help="samples per pixel (64)")
    p.add_argument("--seed", type=int, default=0, help="sampler seed (0)")
    p.add_argument("--max-depth", type=int, default=16,
                   help="Cirrus' --max-depth: scattering events (16)")
    p.add_argument("--threads", type=int, default=2, help="render threads (2)")
    p.add_argument("--variant", default="scalar_rgb",
                   help="Mitsuba variant (scalar_rgb; llvm_ad_rgb needs a recent libLLVM)")
    p.add_argument("--workdir", type=Path, help="where PLY and .vol files go (default: OUTPUT.mitsuba/)")
    return p.parse_args(argv)


def main(argv=None):
    args = arguments(argv)
    import drjit as dr
    import mitsuba as mi

    mi.set_variant(args.variant)
    dr.set_thread_count(args.threads)
    scene = CirrusScene(args.scene)
    width, height = args.res or tuple(scene.manifest["render"]["resolution"] or (640, 480))
    workdir = args.workdir or args.output.with_suffix(".mitsuba")
    converter = Converter(scene, width, height, args.max_depth, workdir, mi)
    start = time.time()
    scene_dict = converter.build()
    for w in converter.warnings:
        print(f"warning: {w}", file=sys.stderr)
    mi_scene = mi.load_dict(scene_dict)
    loaded = time.time()
    image = mi.render(mi_scene, spp=args.spp, seed=args.seed)
    done = time.time()
    args.output.parent.mkdir(parents=True, exist_ok=True)
    mi.Bitmap(image, pixel_format=mi.Bitmap.PixelFormat.RGB).write(str(args.output))
    print(f"mitsuba {mi.__version__} {args.variant}: {width}x{height} {args.spp} spp, "
          f"convert+load {loaded - start:.1f} s, render {done - loaded:.1f} s -> {args.output}")


if __name__ == "__main__":
    main()
