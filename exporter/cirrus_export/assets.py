"""Asset paths made absolute; files inside a .usdz are extracted next to the scene
(and named relative to the scene folder, which the exporter renames into place)."""

import zipfile
from pathlib import Path

from pxr import Sdf, Usd


def _authored_layer_dir(attr: Usd.Attribute, time: Usd.TimeCode) -> Path | None:
    """The folder of the layer holding the strongest opinion on `attr`."""
    stack = attr.GetPropertyStack(time)
    if not stack or stack[0].layer.anonymous:
        return None
    return Path(stack[0].layer.realPath).parent


class AssetResolver:
    """Resolves asset-valued attributes to absolute file paths the renderer can open."""

    def __init__(self, out_dir: Path) -> None:
        self._out_dir = out_dir

    def _unpack(self, resolved: str) -> str:
        """`pkg.usdz[inner/file.png]` extracted to OUT_DIR/usdz/pkg/inner/file.png; returns
        `usdz/pkg/inner/file.png`, relative to OUT_DIR (the loader anchors it there)."""
        package, inner = resolved[:-1].split("[", 1)
        relative = Path("usdz") / Path(package).stem / inner
        target = self._out_dir / relative
        if not target.exists():
            with zipfile.ZipFile(package) as archive:
                archive.extract(inner, target.parents[len(Path(inner).parts) - 1])
        return str(relative)

    def resolve(self, attr: Usd.Attribute, time: Usd.TimeCode) -> tuple[str, bool] | None:
        """(path, exists) of the attribute's asset at `time`, None when unauthored: absolute,
        except a file inside a .usdz (relative to the scene folder).

        A value authored as a quoted string rather than an @asset@ is resolved the same way,
        relative to the layer that authored it.
        """
        value = attr.Get(time) if attr else None
        if value is None:
            return None
        authored = value.path if isinstance(value, Sdf.AssetPath) else str(value)
        resolved = value.resolvedPath if isinstance(value, Sdf.AssetPath) else ""
        if not authored:
            return None
        if resolved.endswith("]") and "[" in resolved:
            return self._unpack(resolved), True
        if resolved:
            return str(Path(resolved).resolve()), True
        base = _authored_layer_dir(attr, time)
        path = Path(authored) if base is None else base / authored
        return str(path.resolve()), path.exists()
