"""MaterialX documents referenced as USD layers, composed as usdMtlx would compose them.

usd-core ships without usdMtlx, USD's file-format plugin for `.mtlx`, so a reference such
as `@King_mat.mtlx@</MaterialX/Materials>` composes to nothing and the bindings into it
are broken. usdMtlx (pxr/usd/usdMtlx/reader.h) translates a document into the namespace
`/MaterialX` (its default prim), with each `surfacematerial` at `/MaterialX/Materials/<name>`;
a reference to a path in that namespace brings what lies below it under the referencing prim.
Here the references are read from the layer specs of the bound path's ancestors, each
document is read once with the MaterialX package (and upgraded to 1.39 by it), and a bound
path is answered with the document's surfacematerial, as `MtlxNode`s (node_graph.Node).
"""

import functools
from pathlib import Path

import MaterialX as mx
from pxr import Sdf, Usd

from .node_graph import Link, Value
from .report import Report

MATERIALS = Sdf.Path("/MaterialX/Materials")
DEFAULT_PRIM = Sdf.Path("/MaterialX")
SUPPORTED_VERSION = (1, 39)


@functools.cache
def standard_library() -> mx.Document:
    """MaterialX's standard data libraries (node definitions and their defaults, the
    standard_surface -> open_pbr translation graph), loaded once, when first needed."""
    library = mx.createDocument()
    mx.loadLibraries(mx.getDefaultDataLibraryFolders(), mx.getDefaultDataSearchPath(), library)
    return library


def as_value(value) -> Value:
    """A MaterialX value (float, int, bool, string, Color3, Vector2, ...) as JSON."""
    if isinstance(value, (bool, str)):
        return value
    if isinstance(value, (int, float)):
        return float(value)
    return [float(v) for v in value]


class MtlxNode:
    """A node (or a node graph's interface) of a MaterialX document, as a node_graph.Node.

    Interface inputs (`interfacename`) are read from `interface`: the enclosing node graph,
    or, for a library graph implementing a node, the node it implements.
    """

    def __init__(self, element: mx.Element, folder: Path, interface=None) -> None:
        self._element, self._folder = element, folder
        parent = element.getParent()
        self._interface = interface if interface is not None else \
            (MtlxNode(parent, folder) if parent.isA(mx.NodeGraph) else None)
        self.path = f"{Path(element.getDocument().getSourceUri() or 'mtlx').name}:{element.getNamePath()}"
        self.category = element.getCategory()
        self.type = element.getType()

    def source(self, name: str) -> Link | Value | None:
        """A connection (nodename, nodegraph + output, interfacename), a value, or None."""
        inp = self._element.getInput(name)
        if inp is None:
            return None
        if inp.getInterfaceName() and self._interface is not None:
            interface = inp.getInterfaceName()
            found = self._interface.source(interface)
            return self._interface.default(interface) if found is None else found
        node = inp.getConnectedNode()
        if node is not None:
            via = inp if inp.getNodeName() else (inp.getConnectedOutput() or inp)
            same_graph = node.getParent() == self._element.getParent()
            return Link(MtlxNode(node, self._folder, self._interface if same_graph else None),
                        via.getOutputString() or "out")
        return as_value(inp.getValue()) if inp.getValue() is not None else None

    def default(self, name: str) -> Value | None:
        """The input's value in the node's definition (the standard libraries')."""
        nodedef = self._element.getNodeDef() if self._element.isA(mx.Node) else None
        inp = nodedef.getActiveInput(name) if nodedef is not None else None
        return as_value(inp.getValue()) if inp is not None and inp.getValue() is not None else None

    def file(self, name: str) -> tuple[str, bool] | None:
        """A filename input with `fileprefix` applied, relative to the document's folder;
        None when unauthored or empty."""
        inp = self._element.getInput(name)
        if inp is None or not inp.getValue():
            return None
        if inp.getInterfaceName() and self._interface is not None:
            return self._interface.file(inp.getInterfaceName())
        path = (self._folder / inp.getResolvedValueString()).resolve()
        return str(path), path.is_file()

    def color_space(self, name: str) -> str:
        """The input's colorspace, else its nearest ancestor's (the document's)."""
        inp = self._element.getInput(name)
        return "" if inp is None else inp.getActiveColorSpace()


class MtlxDocuments:
    """Every MaterialX document the stage references, read once, and the materials in them."""

    def __init__(self, stage: Usd.Stage, report: Report) -> None:
        self._stage, self._report = stage, report
        self._documents: dict[str, mx.Document | None] = {}
        self._references = self._scan(stage)

    @staticmethod
    def _scan(stage: Usd.Stage) -> dict[str, list[str]]:
        """.mtlx file -> prim paths (in their layers) referencing it, over every used layer."""
        found: dict[str, list[str]] = {}

        def visit(path: Sdf.Path) -> None:
            spec = layer.GetObjectAtPath(path)
            if not isinstance(spec, Sdf.PrimSpec):
                return
            for item in [*spec.referenceList.GetAddedOrExplicitItems(), *spec.payloadList.GetAddedOrExplicitItems()]:
                if item.assetPath.endswith(".mtlx"):
                    found.setdefault(str(Path(layer.ComputeAbsolutePath(item.assetPath)).resolve()),
                                     []).append(str(path))

        for layer in stage.GetUsedLayers():
            layer.Traverse(Sdf.Path.absoluteRootPath, visit)
        return found

    def warn_unreadable(self) -> None:
        """One warning per referenced document that cannot be used (missing, not XML, a
        MaterialX version other than 1.39 or one the package upgrades to it)."""
        for file in self._references:
            self.document(file)

    def document(self, file: str) -> mx.Document | None:
        """The document at `file` (absolute), read the first time; None when unusable."""
        if file not in self._documents:
            self._documents[file] = self._read(file)
        return self._documents[file]

    def _read(self, file: str) -> mx.Document | None:
        """Reads one document, or warns naming the file and returns None."""
        sites = self._references.get(file, [])
        where = f", referenced at {len(sites)} prims (first {sites[0]})" if sites else ""
        document = mx.createDocument()
        try:
            mx.readFromXmlFile(document, file)
        except mx.ExceptionFileMissing:
            problem = "missing MaterialX document"
        except mx.ExceptionParseError as error:
            problem = f"unreadable MaterialX document ({' '.join(str(error).split())})"
        else:
            if document.getVersionIntegers() == SUPPORTED_VERSION:
                document.setDataLibrary(standard_library())
                return document
            problem = f"MaterialX document of unsupported version {document.getVersionString()}"
        self._report.warn(f"{problem} {file}{where}; the materials bound from it use the grey fallback")
        return None

    def material(self, stage_path: str) -> tuple[MtlxNode | None, str] | None:
        """(the surfacematerial, the document's file) a USD material path names through a .mtlx
        reference on it or an ancestor (usdMtlx's namespace); the node is None when the document
        is unusable or lacks it; None when no .mtlx reference covers the path."""
        path = Sdf.Path(stage_path)
        files = []
        for ancestor in path.GetAncestorsRange():
            prim = self._stage.GetPrimAtPath(ancestor)
            if not prim:
                continue
            for spec in prim.GetPrimStack():
                for item in [*spec.referenceList.GetAddedOrExplicitItems(),
                             *spec.payloadList.GetAddedOrExplicitItems()]:
                    if not item.assetPath.endswith(".mtlx"):
                        continue
                    inner = (item.primPath if not item.primPath.isEmpty else DEFAULT_PRIM)
                    target = path.ReplacePrefix(ancestor, inner)
                    if target.GetParentPath() != MATERIALS:
                        continue
                    file = str(Path(spec.layer.ComputeAbsolutePath(item.assetPath)).resolve())
                    node = self._surface_material(file, target.name)
                    if node is not None:
                        return node, file
                    files.append(file)
        unusable = [file for file in files if self.document(file) is None]
        return (None, (unusable or files)[0]) if files else None

    def _surface_material(self, file: str, name: str) -> MtlxNode | None:
        """The document's surfacematerial `name`, or None."""
        document = self.document(file)
        node = document.getNode(name) if document is not None else None
        if node is None or node.getCategory() != "surfacematerial":
            return None
        return MtlxNode(node, Path(file).parent)
