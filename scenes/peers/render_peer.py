"""Renders an exported Cirrus scene with one peer renderer: the entry point of
`cirrus converge --peers` and of compare.py.

Usage (project .venv):
    .venv/bin/python scenes/peers/render_peer.py PEER SCENE_DIR OUT.exr --spp N --seed S \\
        [--threads 2] [--res WxH] [--max-depth 1024] [--no-warmup]
    .venv/bin/python scenes/peers/render_peer.py --available PEER

PEER is one of PEERS: mitsuba-scalar (Mitsuba 3 `scalar_rgb`, to_mitsuba.py),
mitsuba-llvm (`llvm_ad_rgb`, needs Debian's libllvm19), cycles (Blender 5.0
Cycles on the CPU: to_cycles.py run by the `bpy` wheel in .venv-cycles) or
cycles-3.4 (Debian's Blender 3.4, where installed: to_cycles.py run by
`blender -b`); `scenes/peers/install [--cycles]` installs them. Each renders in
its own process, after an untimed warm-up render (LLVM kernel compilation;
Cycles' scene sync and BVH build) unless --no-warmup (for agreement checks,
which need no timing). The last line printed is

    peer=PEER render_seconds=R total_seconds=T [sync_seconds=S]

R is the timed render call alone: no process start, scene conversion or
loading, BVH build or JIT compilation, the same kind of time `cirrus converge`
records for Cirrus (sampling only, the scene loaded and its BVH built). T is
the whole child process, wall clock, warm-up included. S (Cycles, with the
warm-up) is its scene sync: the warm-up render's time less the timed one's
(the same render, which persistent data then finds synced: Cycles stamps the
timed render's synchronization_time 0). `--available PEER`
exits 0 when the peer can run, else 1 with the reason on stderr.
"""

import argparse
import importlib.util
import re
import shutil
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
#: The Python of the `bpy` wheel (Blender 5.0), a venv of its own: bpy 5.0.1
#: requires numpy < 2, the project .venv has numpy 2 (scenes/peers/install).
CYCLES_PYTHON = ROOT / ".venv-cycles/bin/python"
#: Debian's libllvm19 (to_mitsuba.py points drjit at it).
LIBLLVM19 = Path("/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1")
#: The peers, by the name used in `cirrus converge --peers`, CSVs and charts.
PEERS = ("mitsuba-scalar", "mitsuba-llvm", "cycles", "cycles-3.4")


def unavailable(peer):
    """Why `peer` cannot run here (None when it can)."""
    install = "run scenes/peers/install" + (" --cycles" if peer.startswith("cycles") else "")
    if peer == "cycles":
        has_bpy = "import importlib.util, sys; sys.exit(importlib.util.find_spec('bpy') is None)"
        if CYCLES_PYTHON.exists() and subprocess.run([CYCLES_PYTHON, "-c", has_bpy]).returncode == 0:
            return None
        return f"bpy (Blender 5.0) is not importable by {CYCLES_PYTHON} ({install})"
    if peer == "cycles-3.4":
        return None if shutil.which("blender") else "Debian's blender (3.4) is not installed"
    if importlib.util.find_spec("mitsuba") is None:
        return f"mitsuba is not importable by {sys.executable} ({install})"
    if peer == "mitsuba-llvm" and not LIBLLVM19.exists():
        return f"{LIBLLVM19} is missing ({install})"
    return None


def command(args):
    """The child process that renders with the peer."""
    common = ["--spp", args.spp, "--seed", args.seed, "--threads", args.threads,
              "--max-depth", args.max_depth]
    if args.warmup:
        common.append("--warmup")
    if args.res:
        common += ["--res", args.res]
    if args.peer == "cycles":
        return [CYCLES_PYTHON, HERE / "to_cycles.py", args.scene, args.output, *common]
    if args.peer == "cycles-3.4":
        return ["blender", "-b", "--factory-startup", "-t", args.threads, "--python",
                HERE / "to_cycles.py", "--", args.scene, args.output, *common]
    variant = "scalar_rgb" if args.peer == "mitsuba-scalar" else "llvm_ad_rgb"
    return [sys.executable, HERE / "to_mitsuba.py", args.scene, "-o", args.output,
            "--variant", variant, *common]


def arguments(argv=None):
    """The command line."""
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--available", choices=PEERS, help="only check that this peer can run")
    p.add_argument("peer", nargs="?", choices=PEERS)
    p.add_argument("scene", nargs="?", type=Path, help="exported Cirrus scene folder")
    p.add_argument("output", nargs="?", type=Path, help="output EXR")
    p.add_argument("--spp", type=int, default=64, help="samples per pixel (64)")
    p.add_argument("--seed", type=int, default=0, help="sampler seed (0)")
    p.add_argument("--threads", type=int, default=2, help="render threads (2)")
    p.add_argument("--res", help="WxH (default: the scene's)")
    p.add_argument("--max-depth", type=int, default=1024, help="Cirrus' --max-depth (1024, its unbiased default)")
    p.add_argument("--no-warmup", dest="warmup", action="store_false",
                   help="no warm-up (render_seconds then includes compilation, sync and BVH build)")
    args = p.parse_args(argv)
    if args.available is None and args.output is None:
        p.error("PEER SCENE_DIR OUT.exr are required (or --available PEER)")
    return args


def main(argv=None):
    args = arguments(argv)
    reason = unavailable(args.available or args.peer)
    if args.available:
        if reason:
            print(f"{args.available}: {reason}", file=sys.stderr)
        return 1 if reason else 0
    if reason:
        print(f"error: {args.peer}: {reason}", file=sys.stderr)
        return 2
    cmd = [str(c) for c in command(args)]
    start = time.perf_counter()
    result = subprocess.run(cmd, capture_output=True, text=True, check=False)
    total = time.perf_counter() - start
    timed = re.findall(r"^render_seconds=([0-9.eE+-]+)$", result.stdout, re.MULTILINE)
    if result.returncode != 0 or not timed or not args.output.is_file():
        print(f"error: {args.peer} failed: {' '.join(cmd)}\n{result.stdout[-4000:]}\n"
              f"{result.stderr[-4000:]}", file=sys.stderr)
        return 2
    warnings = [line for line in result.stderr.splitlines() if line.startswith("warning: ")]
    for line in warnings:
        print(line, file=sys.stderr)
    sync = re.findall(r"^sync_seconds=([0-9.eE+-]+)$", result.stdout, re.MULTILINE)
    sync = f" sync_seconds={float(sync[-1]):.6f}" if sync else ""
    print(f"peer={args.peer} render_seconds={float(timed[-1]):.6f} total_seconds={total:.6f}{sync}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
