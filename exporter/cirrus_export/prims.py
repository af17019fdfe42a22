"""What the walk asks of a prim in the composed stage: how to traverse it (through instance
proxies), its path inside its USD prototype, the asset (`component`/`assembly` model) it
belongs to, and the constant primvars it inherits. A leaf: it imports no sibling module.
"""

import numpy as np
from pxr import Kind, Usd, UsdGeom

PREDICATE = Usd.TraverseInstanceProxies(Usd.PrimDefaultPredicate)


def prototype_path(prim: Usd.Prim) -> str:
    """The prim's path inside its USD prototype (instance proxies), else its own path."""
    return str(prim.GetPrimInPrototype().GetPath() if prim.IsInstanceProxy() else prim.GetPath())


def is_asset(prim: Usd.Prim) -> bool:
    """Whether the prim is a model of kind `component` or `assembly` (or a kind derived from
    them): what CryptoAsset names, as Arnold's and Karma's asset mattes do."""
    kind = Usd.ModelAPI(prim).GetKind()
    return bool(kind) and (Kind.Registry.IsA(kind, Kind.Tokens.component)
                           or Kind.Registry.IsA(kind, Kind.Tokens.assembly))


def below(prim: Usd.Prim, root: Usd.Prim) -> str:
    """The prim's path below `root` (`/Geom`; '' for the root itself)."""
    return str(prim.GetPath())[len(str(root.GetPath())):]


def asset_within(prim: Usd.Prim, root: Usd.Prim, root_included: bool) -> str | None:
    """The nearest asset at or above `prim` up to `root` (included or not), as its path below
    `root`; None when there is none in that range."""
    while prim and prim.GetPath() != root.GetPath():
        if is_asset(prim):
            return below(prim, root)
        prim = prim.GetParent()
    return "" if root_included and is_asset(root) else None


def asset_above(prim: Usd.Prim) -> str | None:
    """The path of the nearest asset at or above `prim` on the whole stage; None when none."""
    while prim and not prim.IsPseudoRoot():
        if is_asset(prim):
            return str(prim.GetPath())
        prim = prim.GetParent()
    return None


def inherited_primvar(prim: Usd.Prim, name: str, time: Usd.TimeCode) -> np.ndarray | None:
    """The (1, width) value of the nearest constant primvar `name` at or above `prim`, up to
    (not including) the nearest native instance or PointInstancer above it, as
    UsdGeomPrimvarsAPI.FindPrimvarWithInheritance within one copy: above that boundary
    each copy has its own ancestors. None when there is none, or it is not numeric."""
    at = prim
    while at and not at.IsPseudoRoot():
        if at != prim and (at.IsInstance() or at.IsA(UsdGeom.PointInstancer)):
            return None
        primvar = UsdGeom.PrimvarsAPI(at).GetPrimvar(name)
        if primvar and primvar.HasValue() and primvar.GetInterpolation() == UsdGeom.Tokens.constant:
            values = numeric(primvar.ComputeFlattened(time))
            return None if values is None or len(values) == 0 else values[:1]
        at = at.GetParent()
    return None


def numeric(values) -> np.ndarray | None:
    """Primvar values as an (n, width) float64 array (width 1 to 4), or None for strings,
    tokens, matrices and other values no material input can read."""
    if values is None:
        return None
    try:
        array = np.array(values, dtype=np.float64).reshape(len(values), -1)
    except (TypeError, ValueError):
        return None
    return array if 1 <= array.shape[1] <= 4 and np.isfinite(array).all() else None
