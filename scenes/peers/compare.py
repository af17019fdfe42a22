"""Renders one scene with Cirrus and with a peer renderer and checks that they agree.

Usage (project .venv, after `cargo build --release` and scenes/peers/install):
    .venv/bin/python scenes/peers/compare.py SCENE.usda --res 96x64 --spp 64 \
        [--peer mitsuba-scalar|mitsuba-llvm|cycles] [--peer-spp N]

Steps: `cirrus export` the scene, `cirrus render` it (box filter, beauty only,
fixed seed), render the exported folder with the peer through render_peer.py
(Mitsuba 3 by default), then read both EXRs with the OpenEXR package and print
per-channel means, their ratio (Cirrus / peer) and the relMSE of Cirrus against
the peer after 4x4 box downsampling, mean((c - m)^2 / (m^2 + 0.01)) (the metric
of `cirrus bench`).
Exits 1 when any channel's |mean ratio - 1| exceeds --max-ratio-error (2%) or
the relMSE reaches --max-relmse (1e-2), the thresholds of issue 7; 2 when a
step fails.
"""

import argparse
import subprocess
import sys
from pathlib import Path

import numpy as np
import OpenEXR

from render_peer import PEERS

ROOT = Path(__file__).resolve().parents[2]
RENDER_PEER = Path(__file__).resolve().with_name("render_peer.py")


def arguments(argv=None):
    """The command line."""
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("scene", type=Path, help="USD scene")
    p.add_argument("--cirrus", type=Path, default=ROOT / "target/release/cirrus", help="cirrus binary")
    p.add_argument("--res", default="96x64", help="WxH (96x64)")
    p.add_argument("--spp", type=int, default=64, help="Cirrus samples per pixel (64)")
    p.add_argument("--peer", choices=PEERS, default="mitsuba-scalar", help="peer renderer (mitsuba-scalar)")
    p.add_argument("--peer-spp", type=int, help="the peer's samples per pixel (default: --spp)")
    p.add_argument("--seed", type=int, default=1, help="seed of both renders (1)")
    p.add_argument("--max-depth", type=int, default=1024, help="Cirrus --max-depth (1024, its unbiased default)")
    p.add_argument("--threads", type=int, default=2, help="threads for each renderer (2)")
    p.add_argument("--workdir", type=Path, help="output folder (default: out/peers/SCENE_NAME)")
    p.add_argument("--max-ratio-error", type=float, default=0.02, help="largest |mean ratio - 1| (0.02)")
    p.add_argument("--max-relmse", type=float, default=1e-2, help="relMSE must stay below this (1e-2)")
    p.add_argument("--block", type=int, default=4, help="downsampling block size, pixels (4)")
    p.add_argument("--bands", type=int, default=0,
                   help="also compare N equal vertical bands (one object each), printing each mean ratio (0: none)")
    p.add_argument("--max-band-error", type=float, action="append", default=[],
                   help="largest |mean ratio - 1| of any channel in a band: once for all bands, or once per band")
    return p.parse_args(argv)


def run(cmd):
    """Runs a command, echoing it; its output passes through; exits 2 on failure."""
    cmd = [str(c) for c in cmd]
    print("+", " ".join(cmd), flush=True)
    if subprocess.run(cmd, check=False).returncode != 0:
        print(f"error: command failed: {' '.join(cmd)}", file=sys.stderr)
        sys.exit(2)


def read_rgb(path):
    """The R, G, B channels of an EXR as an (H, W, 3) float64 array."""
    with OpenEXR.File(str(path), separate_channels=True) as exr:
        ch = exr.channels()
        return np.stack([ch[c].pixels.astype(np.float64) for c in "RGB"], axis=-1)


def downsample(image, block):
    """Mean over block x block tiles (edges that do not fill a tile are dropped)."""
    h, w = (image.shape[0] // block) * block, (image.shape[1] // block) * block
    tiles = image[:h, :w].reshape(h // block, block, w // block, block, 3)
    return tiles.mean(axis=(1, 3))


def relmse(image, reference):
    """mean((image - reference)^2 / (reference^2 + 0.01)), over pixels and channels."""
    return float(np.mean((image - reference) ** 2 / (reference**2 + 0.01)))


def mean_ratio(cirrus, peer):
    """Per-channel mean of Cirrus over the peer's (1 where both are black, inf where
    only the peer's is)."""
    c_mean, m_mean = cirrus.mean(axis=(0, 1)), peer.mean(axis=(0, 1))
    return c_mean, m_mean, np.divide(c_mean, m_mean, out=np.where(c_mean == 0, 1.0, np.inf),
                                     where=m_mean != 0)


def band_failures(cirrus, peer, bands, limits, peer_name):
    """Prints each vertical band's mean ratio; returns the bands over their limit."""
    failed = []
    edges = np.linspace(0, cirrus.shape[1], bands + 1).round().astype(int)
    for k in range(bands):
        c, m, ratio = mean_ratio(cirrus[:, edges[k]:edges[k + 1]], peer[:, edges[k]:edges[k + 1]])
        worst = float(np.max(np.abs(ratio - 1)))
        limit = limits[k] if len(limits) == bands else (limits[0] if limits else None)
        print(f"  band {k}: mean RGB cirrus {fmt(c)}, {peer_name} {fmt(m)}, ratio {fmt(ratio)}"
              + (f" (limit {limit})" if limit is not None else ""))
        if limit is not None and worst > limit:
            failed.append(f"band {k}: |mean ratio - 1| = {worst:.4f} > {limit}")
    return failed


def fmt(values):
    """Three channel values for the report."""
    return " ".join(f"{x:.5f}" for x in values)


def main(argv=None):
    args = arguments(argv)
    name = args.scene.stem
    work = args.workdir or ROOT / "out/peers" / name
    work.mkdir(parents=True, exist_ok=True)
    exported, cirrus_exr, peer_exr = work / "scene", work / "cirrus.exr", work / f"{args.peer}.exr"
    peer_spp = args.peer_spp or args.spp
    run([args.cirrus, "export", args.scene, "-o", exported])
    run([args.cirrus, "render", exported, "-o", cirrus_exr, "--spp", args.spp, "--res", args.res,
         "--aovs", "beauty", "--filter", "box", "--seed", args.seed,
         "--threads", args.threads, "--max-depth", args.max_depth])
    run([sys.executable, RENDER_PEER, args.peer, exported, peer_exr, "--res", args.res,
         "--spp", peer_spp, "--seed", args.seed, "--threads", args.threads,
         "--max-depth", args.max_depth, "--no-warmup"])
    cirrus, peer = read_rgb(cirrus_exr), read_rgb(peer_exr)
    if cirrus.shape != peer.shape:
        print(f"error: image sizes differ: cirrus {cirrus.shape}, {args.peer} {peer.shape}",
              file=sys.stderr)
        return 2
    # A channel black in both agrees (ratio 1); black in the peer only does not.
    c_mean, m_mean, ratio = mean_ratio(cirrus, peer)
    error = relmse(downsample(cirrus, args.block), downsample(peer, args.block))
    print(f"scene {name}: {args.res}, cirrus {args.spp} spp, {args.peer} {peer_spp} spp")
    print(f"  mean RGB cirrus {fmt(c_mean)}")
    print(f"  mean RGB {args.peer} {fmt(m_mean)}")
    print(f"  ratio cirrus/{args.peer} {fmt(ratio)}")
    print(f"  relMSE ({args.block}x{args.block} blocks) {error:.3e}")
    worst = float(np.max(np.abs(ratio - 1)))
    failed = band_failures(cirrus, peer, args.bands, args.max_band_error, args.peer)
    if worst > args.max_ratio_error:
        failed.append(f"|mean ratio - 1| = {worst:.4f} > {args.max_ratio_error}")
    if not error < args.max_relmse:
        failed.append(f"relMSE {error:.3e} >= {args.max_relmse}")
    if failed:
        print("DISAGREE: " + "; ".join(failed))
        return 1
    print(f"AGREE: |mean ratio - 1| <= {worst:.4f}, relMSE {error:.3e}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
