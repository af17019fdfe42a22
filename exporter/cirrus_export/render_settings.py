"""The render settings that drive a render: --settings, else the stage's renderSettingsPrimPath,
else the only UsdRender.Settings prim; their raster RenderProducts (output name, resolution,
pixel aspect, data window, camera) and each product's RenderVars (sourceName, sourceType,
dataType), recorded as authored. Which RenderVars the renderer can produce is the renderer's
to say (src/output/render_vars.rs): the exporter drops only what is not a raster product.
"""

from pxr import Sdf, Usd, UsdRender

from .report import ExportError, Report


def _settings_prims(stage: Usd.Stage) -> list[str]:
    """Paths of every UsdRender.Settings prim of the stage."""
    return [str(p.GetPath()) for p in stage.Traverse() if p.IsA(UsdRender.Settings)]


def warn_render_passes(stage: Usd.Stage, report: Report) -> None:
    """Warns of each UsdRender.Pass prim: passes (and their renderSource) are not rendered."""
    for prim in stage.Traverse():
        if prim.IsA(UsdRender.Pass):
            report.warn(f"RenderPass {prim.GetPath()} is ignored: render passes are not supported "
                        "(the render settings chosen as usual are rendered)")


def chosen_settings(stage: Usd.Stage, path: str | None, report: Report) -> UsdRender.Settings | None:
    """The settings at `path` (--settings; raises ExportError listing the settings prims when
    it is not one), else at the stage's renderSettingsPrimPath, else the only settings prim;
    several and none named: none, with a warning listing them."""
    if path is not None:
        prim = stage.GetPrimAtPath(path) if Sdf.Path.IsValidPathString(path) else None
        if prim and prim.IsA(UsdRender.Settings):
            return UsdRender.Settings(prim)
        what = "is not a RenderSettings prim" if prim else "is not a prim"
        listed = ", ".join(_settings_prims(stage)) or "none"
        raise ExportError(f"--settings {path} {what} of the stage; its render settings: {listed}")
    named = stage.GetMetadata("renderSettingsPrimPath")
    if named:
        prim = stage.GetPrimAtPath(named) if Sdf.Path.IsValidPathString(named) else None
        if prim and prim.IsA(UsdRender.Settings):
            return UsdRender.Settings(prim)
        report.warn(f"renderSettingsPrimPath {named} is not a RenderSettings prim; ignored")
    found = _settings_prims(stage)
    if len(found) == 1:
        return UsdRender.Settings(stage.GetPrimAtPath(found[0]))
    if found:
        report.warn(f"{len(found)} RenderSettings prims and none chosen (renderSettingsPrimPath or "
                    f"--settings): using none of {', '.join(found)}")
    return None


def _own_or_settings(product: UsdRender.Product, settings: UsdRender.Settings, name: str,
                     time: Usd.TimeCode):
    """A product's attribute when authored there, else the settings' value (UsdRender: a
    product overrides the settings it belongs to)."""
    attr = product.GetPrim().GetAttribute(name)
    source = attr if attr.HasAuthoredValue() else settings.GetPrim().GetAttribute(name)
    return source.Get(time)


def _rendered(settings: UsdRender.Settings, products: list[dict], name: str, time: Usd.TimeCode):
    """A RenderSettingsBase attribute as the render uses it: the first raster product's (whose
    camera is rendered) when authored there, else the settings'."""
    if not products:
        return settings.GetPrim().GetAttribute(name).Get(time)
    product = UsdRender.Product(settings.GetPrim().GetStage().GetPrimAtPath(products[0]["path"]))
    return _own_or_settings(product, settings, name, time)


def motion_blur_disabled(settings: UsdRender.Settings | None, products: list[dict], time: Usd.TimeCode,
                         report: Report) -> bool:
    """`disableMotionBlur` (the camera's shutter becomes [0, 0]), or the deprecated
    `instantaneousShutter`, read as it (shutterClose = shutterOpen: no blur either, though at
    shutter:open rather than the frame; warned)."""
    if settings is None:
        return False
    if _rendered(settings, products, "disableMotionBlur", time):
        return True
    if _rendered(settings, products, "instantaneousShutter", time):
        report.warn(f"render settings {settings.GetPath()}: instantaneousShutter (deprecated) is read as "
                    "disableMotionBlur: no motion blur, the frame itself rendered (not the camera's shutter:open)")
        return True
    return False


def depth_of_field_disabled(settings: UsdRender.Settings | None, products: list[dict],
                            time: Usd.TimeCode) -> bool:
    """`disableDepthOfField`: the camera's fStop becomes infinite (a pinhole)."""
    return settings is not None and bool(_rendered(settings, products, "disableDepthOfField", time))


def _camera(prim: Usd.Prim) -> str | None:
    """The first target of a settings or product's `camera` relationship."""
    targets = UsdRender.SettingsBase(prim).GetCameraRel().GetForwardedTargets()
    return str(targets[0]) if targets else None


def _render_var(prim: Usd.Prim, time: Usd.TimeCode) -> dict:
    """One RenderVar as authored."""
    var = UsdRender.Var(prim)
    return {
        "path": str(prim.GetPath()),
        "name": prim.GetName(),
        "source_name": str(var.GetSourceNameAttr().Get(time) or ""),
        "source_type": str(var.GetSourceTypeAttr().Get(time)),
        "data_type": str(var.GetDataTypeAttr().Get(time)),
    }


def primvar_of(source_name: str, source_type: str) -> str | None:
    """The primvar a RenderVar reads, as husk and Karma take them (src/film/aov.rs,
    primvar_of): its sourceName without `primvars:` when sourceType is `primvar` or the name
    starts with `primvars:`; None for other vars."""
    name = source_name.strip()
    if name.startswith("primvars:"):
        return name[len("primvars:"):]
    return name if source_type == "primvar" else None


def requested_primvars(settings: UsdRender.Settings | None, time: Usd.TimeCode,
                       report: Report) -> tuple[str, ...]:
    """The primvars the settings' RenderVars read (sorted): every mesh carrying one exports it,
    whatever its interpolation. (The report prints each warning once, so reading the
    products here and again for the manifest warns once.)"""
    if settings is None:
        return ()
    found = {primvar_of(var["source_name"], var["source_type"])
             for product in render_products(settings, time, report)
             for var in product["vars"]}
    return tuple(sorted(name for name in found if name))


def render_products(settings: UsdRender.Settings, time: Usd.TimeCode, report: Report) -> list[dict]:
    """The settings' raster products in order, each with its RenderVars; other product types,
    products without a productName and targets that are not products or vars are warned about
    and skipped."""
    stage = settings.GetPrim().GetStage()
    products = []
    for target in settings.GetProductsRel().GetForwardedTargets():
        prim = stage.GetPrimAtPath(target)
        if not (prim and prim.IsA(UsdRender.Product)):
            report.warn(f"render settings {settings.GetPath()}: products target {target} is not a "
                        "RenderProduct; skipped")
            continue
        product = UsdRender.Product(prim)
        kind = str(product.GetProductTypeAttr().Get(time))
        name = str(product.GetProductNameAttr().Get(time) or "")
        if kind != "raster":
            report.warn(f"render product {target}: productType {kind!r} is not rendered (only "
                        "'raster' is); skipped")
            continue
        if not name:
            report.warn(f"render product {target}: no productName; skipped")
            continue
        variables = []
        for var_path in product.GetOrderedVarsRel().GetForwardedTargets():
            var = stage.GetPrimAtPath(var_path)
            if var and var.IsA(UsdRender.Var):
                variables.append(_render_var(var, time))
            else:
                report.warn(f"render product {target}: orderedVars target {var_path} is not a "
                            "RenderVar; skipped")
        resolution = _own_or_settings(product, settings, "resolution", time)
        window = _own_or_settings(product, settings, "dataWindowNDC", time)
        _warn_conform_policy(str(target), _own_or_settings(product, settings,
                                                            "aspectRatioConformPolicy", time), report)
        products.append({
            "path": str(target),
            "name": name,
            "resolution": [int(resolution[0]), int(resolution[1])],
            "pixel_aspect_ratio": float(_own_or_settings(product, settings, "pixelAspectRatio", time)),
            "data_window_ndc": [float(v) for v in window],
            "camera": _camera(prim) or _camera(settings.GetPrim()),
            "vars": variables,
        })
    return products


def _warn_conform_policy(where: str, policy, report: Report) -> None:
    """One warning when `aspectRatioConformPolicy` asks for anything but UsdRender's default,
    the only policy rendered."""
    if str(policy) != "expandAperture":
        report.warn(f"{where}: aspectRatioConformPolicy {str(policy)!r} is not modelled; the "
                    "aperture is expanded to the image's aspect (expandAperture, UsdRender's default)")


def warn_settings_without_products(settings: UsdRender.Settings, time: Usd.TimeCode,
                                   report: Report) -> None:
    """Render settings with no raster product give only their resolution and camera: their own
    pixelAspectRatio, dataWindowNDC and a conform policy other than the default are warned
    about (square pixels, the whole image, expandAperture are rendered)."""
    where = f"render settings {settings.GetPath()} (no raster product)"
    aspect = float(settings.GetPixelAspectRatioAttr().Get(time))
    if aspect != 1.0:
        report.warn(f"{where}: pixelAspectRatio {aspect} is not used; square pixels are rendered "
                    "(give the settings a RenderProduct to render it)")
    window = [float(v) for v in settings.GetDataWindowNDCAttr().Get(time)]
    if window != [0.0, 0.0, 1.0, 1.0]:
        report.warn(f"{where}: dataWindowNDC {window} is not used; the whole image is rendered "
                    "(give the settings a RenderProduct to crop it)")
    _warn_conform_policy(where, settings.GetAspectRatioConformPolicyAttr().Get(time), report)


# UsdGeomImageable's purposes, and UsdRenderSettings.includedPurposes' fallback.
PURPOSES = ("default", "render", "proxy", "guide")
DEFAULT_INCLUDED_PURPOSES = frozenset({"default", "render"})
# UsdShadeMaterialBindingAPI's purposes ("" is allPurpose), and
# UsdRenderSettings.materialBindingPurposes' fallback.
MATERIAL_PURPOSES = ("full", "preview", "")
DEFAULT_MATERIAL_PURPOSES = ("full", "")


def _known_tokens(settings: UsdRender.Settings, attr: Usd.Attribute, known: tuple[str, ...],
                  report: Report) -> list[str]:
    """An uniform token[] attribute of the settings, without the tokens not in `known` (one
    warning naming settings, attribute and those tokens)."""
    tokens = [str(t) for t in attr.Get() or []]
    unknown = [t for t in tokens if t not in known]
    if unknown:
        report.warn(f"render settings {settings.GetPath()}: {attr.GetName()} {unknown} not among "
                    f"{list(known)}; ignored")
    return [t for t in tokens if t in known]


def included_purposes(settings: UsdRender.Settings | None, report: Report) -> frozenset[str]:
    """`includedPurposes`: the UsdGeomImageable purposes rendered (fallback default and render)."""
    if settings is None:
        return DEFAULT_INCLUDED_PURPOSES
    return frozenset(_known_tokens(settings, settings.GetIncludedPurposesAttr(), PURPOSES, report))


def material_binding_purposes(settings: UsdRender.Settings | None, report: Report) -> tuple[str, ...]:
    """`materialBindingPurposes`: the material purposes to resolve bindings for, in order of
    preference ("" is allPurpose; fallback full, then allPurpose)."""
    if settings is None:
        return DEFAULT_MATERIAL_PURPOSES
    return tuple(_known_tokens(settings, settings.GetMaterialBindingPurposesAttr(), MATERIAL_PURPOSES,
                               report))
