"""Exports one USD stage at several frames in one process (tests/motion.rs: the still
frames a motion-blurred render is compared with).

Usage: export_frames.py IN.usda OUT_DIR OPEN,CLOSE FRAME... writes OUT_DIR/frame<i> for
the i-th FRAME, exported with the shutter OPEN,CLOSE (frames; 0,0 = still).
"""

import sys
from pathlib import Path

sys.dont_write_bytecode = True
sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "exporter"))

from cirrus_export.export import export  # noqa: E402


def main(argv: list[str]) -> None:
    """Exports every frame given."""
    stage, out_dir, shutter, *frames = argv
    open_, close = (float(v) for v in shutter.split(","))
    for i, frame in enumerate(frames):
        export(Path(stage), Path(out_dir) / f"frame{i}", float(frame), None, (open_, close))


if __name__ == "__main__":
    main(sys.argv[1:])
