"""Renders an exported Cirrus scene folder with Mitsuba 3 into an EXR of the same framing.

Usage (from the project .venv, after scenes/peers/install):
    .venv/bin/python scenes/peers/to_mitsuba.py SCENE_DIR -o OUT.exr --res 128x96 --spp 64

SCENE_DIR is what `cirrus export IN.usda -o SCENE_DIR` writes (exporter/FORMAT.md).
The output is a float RGB EXR of linear Rec.709 radiance, box-filtered (as
`cirrus render --filter box`). Everything converted only approximately is
printed as `warning: ...` lines on stderr; mitsuba_scene.py says what maps to what.

The LLVM variants (llvm_ad_rgb) need Debian's libllvm19 (scenes/peers/install
installs it); drjit's own search would also find Debian 12's LLVM 14/15, with
which Mitsuba 3.9 crashes, so DRJIT_LIBLLVM_PATH is pointed at LLVM 19 unless
already set. With --warmup a 1-spp render (another seed) runs first and is not
timed, so the timed render excludes the LLVM kernels' compilation. The last
line is `render_seconds=S`: the timed mi.render call alone (scene conversion
and loading, which builds the BVH, excluded), for scenes/peers/render_peer.py.
"""

import argparse
import os
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from cirrus_scene import CirrusScene, parse_resolution  # noqa: E402
from mitsuba_scene import Converter  # noqa: E402

#: Debian 12's libllvm19 (the only LLVM there that Mitsuba 3.9's JIT runs on).
LIBLLVM19 = Path("/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1")


def arguments(argv=None):
    """The command line."""
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("scene", type=Path, help="exported Cirrus scene folder")
    p.add_argument("-o", "--output", type=Path, required=True, help="output EXR")
    p.add_argument("--res", type=parse_resolution, help="WxH (default: the scene's, else 640x480)")
    p.add_argument("--spp", type=int, default=64, help="samples per pixel (64)")
    p.add_argument("--seed", type=int, default=0, help="sampler seed (0)")
    p.add_argument("--max-depth", type=int, default=1024,
                   help="Cirrus' --max-depth: scattering events (1024, its unbiased default)")
    p.add_argument("--threads", type=int, default=2, help="render threads (2)")
    p.add_argument("--variant", default="scalar_rgb",
                   help="Mitsuba variant (scalar_rgb; llvm_ad_rgb needs Debian's libllvm19)")
    p.add_argument("--warmup", action="store_true",
                   help="render 1 spp untimed first (compiles the LLVM kernels)")
    p.add_argument("--workdir", type=Path, help="where PLY and .vol files go (default: OUTPUT.mitsuba/)")
    return p.parse_args(argv)


def main(argv=None):
    args = arguments(argv)
    if args.variant.startswith("llvm"):
        use_llvm19()
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
    if args.warmup:
        dr.eval(mi.render(mi_scene, spp=1, seed=args.seed + 1_000_003))
        dr.sync_thread()
    timer = time.perf_counter()
    image = mi.render(mi_scene, spp=args.spp, seed=args.seed)
    dr.eval(image)
    dr.sync_thread()
    render_seconds = time.perf_counter() - timer
    done = time.time()
    args.output.parent.mkdir(parents=True, exist_ok=True)
    mi.Bitmap(image, pixel_format=mi.Bitmap.PixelFormat.RGB).write(str(args.output))
    print(f"mitsuba {mi.__version__} {args.variant}: {width}x{height} {args.spp} spp, "
          f"convert+load {loaded - start:.1f} s, render {done - loaded:.1f} s -> {args.output}")
    print(f"render_seconds={render_seconds:.6f}")


def use_llvm19():
    """Points drjit at Debian's LLVM 19 (unless DRJIT_LIBLLVM_PATH is set); exits when absent."""
    if os.environ.get("DRJIT_LIBLLVM_PATH"):
        return
    if not LIBLLVM19.exists():
        raise SystemExit(f"error: {LIBLLVM19} is missing: run scenes/peers/install (Debian's libllvm19)")
    os.environ["DRJIT_LIBLLVM_PATH"] = str(LIBLLVM19)


if __name__ == "__main__":
    main()
