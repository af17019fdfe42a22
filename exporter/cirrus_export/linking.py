"""Light and shadow linking: UsdLuxLightAPI's `collection:lightLink` and `collection:shadowLink`.

Each collection is resolved by usd-core itself (`Usd.CollectionAPI.ComputeMembershipQuery`
on the composed stage: includeRoot, includes, excludes, expansionRule, included
collections). Every placed part (mesh, points, curves, volume of every instance) gets a
link set: the placed parts that the same linked lights light and whose shadows the same
shadow-linked lights cast share one. Set 0 is that of a path no collection names (lit by
the lights whose includeRoot is on). A light's record lists the sets it lights
(`light_link`) and the sets that cast its shadow (`shadow_link`); both are absent when its
collection holds everything, as by default, and then nothing is written at all
(exporter/FORMAT.md, "Linking").

A part is looked up by its path on the stage: a native instance's parts by their instance
proxy paths (`/World/tree_3/Geom`), so a collection may name single instances; a
PointInstancer's copies are not prims, so they follow the path of the prototype part they
copy (a collection cannot tell them apart).
"""

from pxr import Sdf, Usd, UsdLux

from .report import Report

# A path inside no authored prim: what a part no collection names gets.
UNNAMED = Sdf.Path("/__cirrus_unnamed__")


def holds_everything(collection: Usd.CollectionAPI) -> bool:
    """Whether the collection includes every path: includeRoot with nothing excluded."""
    query = collection.ComputeMembershipQuery()
    if not query.UsesPathExpansionRuleMap():
        return False
    rules = query.GetAsPathExpansionRuleMap()
    return set(rules) == {Sdf.Path.absoluteRootPath} and \
        rules[Sdf.Path.absoluteRootPath] != Usd.Tokens.exclude


def _warn_missing_targets(stage: Usd.Stage, light: str, collection: Usd.CollectionAPI, report: Report) -> None:
    """One warning per include or exclude target that names no prim (or no collection)."""
    name = collection.GetName()
    for rel in (collection.GetIncludesRel(), collection.GetExcludesRel()):
        for target in rel.GetTargets():
            prim = stage.GetPrimAtPath(target.GetPrimPath())
            missing = not prim or (target.IsPropertyPath() and not Usd.CollectionAPI.GetCollection(
                stage, target))
            if missing:
                report.warn(f"light {light}: collection:{name}:{rel.GetName().split(':')[-1]} names "
                            f"{target}, which is not on the stage; ignored (the rest of the collection "
                            f"is honoured)")


def collections(light: UsdLux.LightAPI) -> list[tuple[str, Usd.CollectionAPI]]:
    """(manifest key, collection) of the light's lightLink and shadowLink."""
    return [("light_link", light.GetLightLinkCollectionAPI()),
            ("shadow_link", light.GetShadowLinkCollectionAPI())]


def warn_unlinked(light: UsdLux.LightAPI, what: str, report: Report) -> None:
    """Warns, naming prim and collection, when a light Cirrus does not link yet (a mesh or
    volume light, `what`) authors a lightLink or shadowLink that does not hold everything:
    it lights every part and every part casts its shadow."""
    for _, collection in collections(light):
        if not holds_everything(collection):
            report.approximated("light", f"{what} {light.GetPath()}: collection:{collection.GetName()} "
                                         f"is not supported on {what}s; it lights every part and every part "
                                         f"casts its shadow")


def linked_queries(stage: Usd.Stage, records: list[dict], report: Report) -> list[tuple[int, str, object]]:
    """(light record index, manifest key, membership query) for every light whose lightLink or
    shadowLink collection does not hold everything."""
    queries = []
    for i, record in enumerate(records):
        light = UsdLux.LightAPI(stage.GetPrimAtPath(record["path"]))
        for key, collection in collections(light):
            _warn_missing_targets(stage, record["path"], collection, report)
            if not holds_everything(collection):
                queries.append((i, key, collection.ComputeMembershipQuery()))
    return queries


def part_paths(sink, prototypes: list[dict], tables: dict[str, list[dict]]) -> list[tuple[int, int, list[str]]]:
    """(first instance, count, paths) per placed leaf: the stage path of each part of its
    prototype, in `Hit` order (meshes, points, curves), then its volumes."""
    runs, first = [], 0
    for _, leaf in sink.placed:
        proto = prototypes[leaf.prototype]
        paths = []
        for field in ("meshes", "points", "curves", "volumes"):
            key = {"meshes": "mesh", "volumes": "volume"}.get(field, field)
            for part in proto[field]:
                own = tables[field][part[key]]["path"]
                if leaf.root.indexed or "name" not in part:
                    paths.append(own)
                else:
                    paths.append(leaf.root.head + leaf.root.tail + part["name"])
        runs.append((first, len(leaf.index), paths, len(proto["volumes"])))
        first += len(leaf.index)
    return runs


def add_linking(stage: Usd.Stage, records: list[dict], sink, prototypes: list[dict],
                tables: dict[str, list[dict]], report: Report) -> list[dict] | None:
    """Adds `light_link`/`shadow_link` to the light records with a linking collection and
    returns the instances' `links` runs; None (and nothing added) when no light links."""
    queries = linked_queries(stage, records, report)
    if not queries:
        return None
    sets: dict[tuple[bool, ...], int] = {}

    def set_of(path: str) -> int:
        signature = tuple(query.IsPathIncluded(Sdf.Path(path)) for _, _, query in queries)
        return sets.setdefault(signature, len(sets))

    set_of(str(UNNAMED))
    runs = []
    for first, count, paths, volumes in part_paths(sink, prototypes, tables):
        ids = [set_of(path) for path in paths]
        if any(ids):
            split = len(ids) - volumes
            runs.append({"first": first, "count": count, "parts": ids[:split], "volumes": ids[split:]})
    for k, (i, key, _) in enumerate(queries):
        records[i][key] = sorted(s for signature, s in sets.items() if signature[k])
    return runs
