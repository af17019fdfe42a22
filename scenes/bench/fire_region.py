"""relMSE of fire light sampling on and off over the region the fire lights (issue 19's canyon target).

usage: .venv/bin/python scenes/bench/fire_region.py DIR

DIR holds `ref.exr` (a long render of the scene, light sampling on), `unlit.exr` (the same
frame with the fire's heat off, e.g. scenes/bench/canyon_fire_unlit.usda), and for seeds
1, 2, ... `on-<seed>.exr` / `off-<seed>.exr` with their render logs `on-<seed>.log` /
`off-<seed>.log` (the "N spp in S s" line `cirrus render` prints). The light the fire adds
to a pixel is ref - unlit (channel means); the fire-lit region is where that is more than
half of the reference, and, as a second region, the same without the pixels where the
flame seen directly (the `emission` AOV, which both methods estimate by tracking alone) is
more than half. relMSE per pixel is (x - ref)^2 / (ref^2 + 0.01) on the channel mean, as in
src/lab/metrics.rs, averaged over a region; medians over seeds. Equal time multiplies the
equal-spp ratio by the median time per render, off over on. Prints two markdown tables: the
ratios per region, and, in the fire-lit region, the relMSE of every AOV the renders hold
(each against the reference's same AOV, over the beauty's denominator).
"""
import re
import sys
from pathlib import Path

import numpy as np
import OpenEXR


def layers(path: Path) -> dict:
    """Every layer of an EXR as an (h, w) channel mean."""
    channels = OpenEXR.File(str(path)).parts[0].channels
    return {name: np.asarray(c.pixels, dtype=np.float64)[..., :3].mean(-1) for name, c in channels.items()}


def seconds(log: Path) -> float:
    """The render time a `cirrus render` log reports."""
    found = re.search(r"spp in ([0-9.]+) s", log.read_text())
    if not found:
        raise SystemExit(f"{log}: no 'spp in S s' line")
    return float(found.group(1))


def main() -> None:
    folder = Path(sys.argv[1])
    ref, unlit = layers(folder / "ref.exr"), layers(folder / "unlit.exr")
    beauty = ref["RGBA"]
    fire_share = np.clip((beauty - unlit["RGBA"]) / np.maximum(beauty, 1e-6), 0.0, 1.0)
    lit = fire_share > 0.5
    regions = {
        "whole frame": np.ones_like(lit),
        "fire-lit (the fire > 50% of the light)": lit,
        "fire-lit, the flame seen directly left out": lit & ~(ref["emission"] > 0.5 * beauty),
    }
    seeds = sorted(int(p.stem.split("-")[1]) for p in folder.glob("on-*.exr"))
    renders = {m: [layers(folder / f"{m}-{s}.exr") for s in seeds] for m in ("on", "off")}
    time = {m: float(np.median([seconds(folder / f"{m}-{s}.log") for s in seeds])) for m in ("on", "off")}
    def error(img: dict, region: np.ndarray, layer: str = "RGBA") -> float:
        return float(((img[layer] - ref[layer]) ** 2 / (beauty**2 + 0.01))[region].mean())

    print(f"{len(seeds)} seeds; median seconds per render: on {time['on']:.2f}, off {time['off']:.2f} "
          f"(on costs {time['on'] / time['off']:.2f}x)\n")
    print("| region | share of the frame | relMSE on | relMSE off | off / on, equal spp | off / on, equal time |")
    print("|---|---:|---:|---:|---:|---:|")
    for name, region in regions.items():
        on, off = (float(np.median([error(i, region) for i in renders[m]])) for m in ("on", "off"))
        ratio = off / on
        print(f"| {name} | {100 * region.mean():.0f}% | {on:.3e} | {off:.3e} | {ratio:.2f}x | "
              f"{ratio * time['off'] / time['on']:.2f}x |")
    names = [n for n in ref if n != "RGBA"]
    print("\n| in the fire-lit region | beauty | " + " | ".join(names) + " |")
    print("|---|---:|" + "---:|" * len(names))
    for m in ("on", "off"):
        cells = [float(np.median([error(i, lit, n) for i in renders[m]])) for n in ["RGBA", *names]]
        print(f"| light sampling {m} | " + " | ".join(f"{c:.2e}" for c in cells) + " |")


if __name__ == "__main__":
    main()
