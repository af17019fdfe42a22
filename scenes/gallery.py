"""Renders every shared USD scene into a sample gallery: one PNG per scene and a README.md.

usage: .venv/bin/python scenes/gallery.py [--out DIR] [--res W[xH]] [--spp N]
                                          [--cirrus PATH] [--list FILE]

Each scene of the list (scenes/shared_scenes.txt: an asset path under ../shared/assets,
optionally a frame) is exported with `cirrus export` into a scratch folder, then rendered
with `cirrus render` (beauty only) to DIR/NAME.png. Exporting afresh rather than through
the export cache keeps the gallery honest: a cache hit prints none of the exporter's
warnings, and the cache key ignores edits to sublayers. DIR/README.md gets one row per
scene (thumbnail, scene and frame, export and render seconds, every warning verbatim, or
the error), the command, machine, date and commit. With a width only, each image takes
the aspect of the scene's own render settings, else of its camera aperture.

Exit status: 0 when every scene rendered; 1 naming every scene that failed.
"""
import argparse
import datetime
import json
import os
import re
import shlex
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
ASSETS = REPO.parent / "shared" / "assets"
# How asset paths appear in commands and warnings: as typed from the repository root.
ASSETS_SHOWN = "../shared/assets"


@dataclass
class Scene:
    """One line of the scene list: an asset path under ../shared/assets and its frame."""

    asset: str
    frame: str | None = None

    @property
    def name(self) -> str:
        """A readable file-name slug: the asset path without extension, plus the frame."""
        slug = re.sub(r"[^A-Za-z0-9_-]+", "_", str(Path(self.asset).with_suffix("")).replace("/", "-"))
        return slug + (f"-frame{re.sub(r'[^0-9]+', '_', self.frame)}" if self.frame else "")

    @property
    def label(self) -> str:
        return f"{self.asset} (frame {self.frame})" if self.frame else self.asset


@dataclass
class Result:
    """What happened to one scene: seconds per step, warnings verbatim, and the error if any."""

    scene: Scene
    export_s: float = 0.0
    render_s: float = 0.0
    warnings: list[str] = field(default_factory=list)
    error: str | None = None


def read_scene_list(path: Path) -> list[Scene]:
    """Parses the scene list: `ASSET [FRAME]` per line, `#` starts a comment."""
    scenes = []
    for number, line in enumerate(path.read_text().splitlines(), 1):
        words = line.split("#", 1)[0].split()
        if len(words) > 2:
            sys.exit(f"error: {path}:{number}: expected 'ASSET [FRAME]', got {line.strip()!r}")
        if words:
            scenes.append(Scene(*words))
    return scenes


def parse_res(text: str) -> tuple[int, int | None]:
    """`W` or `WxH` in pixels; a missing height follows each scene's aspect."""
    match = re.fullmatch(r"(\d+)(?:[xX](\d+))?", text)
    if not match or int(match[1]) < 1 or (match[2] is not None and int(match[2]) < 1):
        raise argparse.ArgumentTypeError(f"{text!r}: expected WIDTH or WIDTHxHEIGHT, e.g. 320 or 320x180")
    return int(match[1]), int(match[2]) if match[2] else None


def resolution(scene_dir: Path, width: int) -> str:
    """`WxH` for `width` at the aspect cirrus itself would render: the stage's render
    settings resolution, else the camera's vertical / horizontal aperture."""
    manifest = json.loads((scene_dir / "scene.json").read_text())
    settings = manifest["render"]["resolution"]
    camera = manifest["camera"]
    aspect = settings[1] / settings[0] if settings else camera["vertical_aperture"] / camera["horizontal_aperture"]
    return f"{width}x{max(1, round(width * aspect))}"


def warning_lines(stderr: str) -> list[str]:
    """Warnings from the exporter (`warning:`, usd-core's `Warning:`) and the renderer
    (`[WARN ...]`), with the assets folder written as from the repository root."""
    lines = [line for line in stderr.splitlines() if line.lower().startswith(("warning", "[warn"))]
    return [line.replace(str(ASSETS.resolve()), ASSETS_SHOWN) for line in lines]


def error_line(stderr: str, returncode: int) -> str:
    """The one-line error cirrus printed, else the last line of stderr."""
    lines = [line for line in stderr.splitlines() if line.strip()]
    errors = [line for line in lines if line.startswith("error:")]
    text = errors[-1] if errors else (lines[-1] if lines else f"exited with status {returncode}")
    return text.replace(str(ASSETS.resolve()), ASSETS_SHOWN)


def run_step(command: list[str]) -> tuple[subprocess.CompletedProcess, float]:
    """Runs a cirrus command from the repository root; returns it and its wall seconds."""
    start = time.monotonic()
    done = subprocess.run(command, cwd=REPO, capture_output=True, text=True)
    return done, time.monotonic() - start


def render_scene(scene: Scene, args: argparse.Namespace, work: Path) -> Result:
    """Exports then renders one scene to DIR/NAME.png (its EXR removed)."""
    result = Result(scene)
    exported = work / scene.name
    frame = ["--frame", scene.frame] if scene.frame else []
    asset = f"{ASSETS_SHOWN}/{scene.asset}"
    done, result.export_s = run_step([args.cirrus, "export", asset, "-o", str(exported), *frame])
    result.warnings += warning_lines(done.stderr)
    if done.returncode != 0:
        result.error = error_line(done.stderr, done.returncode)
        return result
    width, height = args.res
    res = f"{width}x{height}" if height else resolution(exported, width)
    exr = args.out / f"{scene.name}.exr"
    render = [args.cirrus, "render", str(exported), "-o", str(exr), "--res", res, "--spp", str(args.spp)]
    done, result.render_s = run_step([*render, "--aovs", "beauty"])
    result.warnings += warning_lines(done.stderr)
    exr.unlink(missing_ok=True)
    if done.returncode != 0:
        result.error = error_line(done.stderr, done.returncode)
    return result


def machine() -> str:
    """CPU model name and the cores this process may use."""
    cpuinfo = Path("/proc/cpuinfo").read_text() if Path("/proc/cpuinfo").exists() else ""
    models = [line.split(":", 1)[1].strip() for line in cpuinfo.splitlines() if line.startswith("model name")]
    model = models[0] if models else "unknown CPU"
    return f"{model}, {len(os.sched_getaffinity(0))} cores"


def commit() -> str:
    """The checkout's short commit, marked when the working tree has changes."""
    def git(*words: str) -> str:
        return subprocess.run(["git", *words], cwd=REPO, capture_output=True, text=True).stdout.strip()

    head = git("rev-parse", "--short", "HEAD") or "unknown"
    return head + (" (with uncommitted changes)" if git("status", "--porcelain", "--untracked-files=no") else "")


def cell(text: str) -> str:
    """Text safe inside a Markdown table cell, as inline code."""
    return "`" + text.replace("|", "\\|").replace("`", "'") + "`"


def readme(results: list[Result], args: argparse.Namespace, command: str) -> str:
    """The gallery page: settings and provenance, then one row per scene."""
    failed = sum(r.error is not None for r in results)
    width, height = args.res
    size = f"{width}x{height}" if height else f"{width} px wide at each scene's aspect"
    lines = [
        "# Sample gallery",
        "",
        f"Every shared USD scene of `{args.list_shown}`, exported and rendered by `scenes/gallery.py` "
        f"({size}, {args.spp} spp, beauty only): {len(results)} scenes, {failed} failed, "
        f"{sum(len(r.warnings) for r in results)} warnings.",
        "",
        f"- command: `{command}`",
        f"- machine: {machine()}",
        f"- date: {datetime.datetime.now(datetime.timezone.utc).strftime('%Y-%m-%d %H:%M UTC')}",
        f"- commit: {commit()}",
        "",
        "| image | scene | export, render (s) | warnings or error |",
        "|---|---|---|---|",
    ]
    for r in results:
        image = f"![{r.scene.name}]({r.scene.name}.png)" if r.error is None else "**failed**"
        notes = ([f"**error:** {cell(r.error)}"] if r.error else []) + [cell(w) for w in r.warnings]
        times = f"{r.export_s:.1f}, {r.render_s:.1f}"
        lines.append(f"| {image} | {cell(r.scene.label)} | {times} | {'<br>'.join(notes) or 'none'} |")
    return "\n".join(lines) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=REPO / "docs" / "gallery", help="gallery folder")
    parser.add_argument("--res", type=parse_res, default=(320, None), help="W or WxH pixels (default 320 wide)")
    parser.add_argument("--spp", type=int, default=16, help="samples per pixel (default 16)")
    parser.add_argument("--cirrus", default=str(REPO / "target" / "release" / "cirrus"), help="the cirrus binary")
    parser.add_argument("--list", type=Path, default=REPO / "scenes" / "shared_scenes.txt", help="scene list")
    args = parser.parse_args()
    args.out = args.out.resolve()
    list_path = args.list.resolve()
    args.list_shown = list_path.relative_to(REPO) if list_path.is_relative_to(REPO) else list_path
    command = shlex.join([".venv/bin/python", "scenes/gallery.py", *sys.argv[1:]])
    scenes = read_scene_list(args.list)
    args.out.mkdir(parents=True, exist_ok=True)

    results = []
    with tempfile.TemporaryDirectory(prefix="cirrus-gallery-") as work:
        for scene in scenes:
            (args.out / f"{scene.name}.png").unlink(missing_ok=True)
            result = render_scene(scene, args, Path(work))
            status = f"FAILED: {result.error}" if result.error else f"{len(result.warnings)} warning(s)"
            print(f"{scene.label}: {result.export_s:.1f} s + {result.render_s:.1f} s, {status}", flush=True)
            results.append(result)
    (args.out / "README.md").write_text(readme(results, args, command))

    failures = [r.scene.label for r in results if r.error]
    if failures:
        sys.exit(f"error: {len(failures)} scene(s) failed: " + ", ".join(failures))


if __name__ == "__main__":
    main()
