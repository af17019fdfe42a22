//! The layout rules of `src/` (docs/architecture.md), checked from the
//! sources: no import cycle between top-level modules or between the files
//! of one folder, the lab imported by the command line only, `clap` and
//! `anyhow` only under `src/cli/`, no file over 800 lines and `src/cli/`
//! under 1,000 lines (every line, comments included: the command line
//! parses flags and prints, the library does the work). Imports are read from `use` paths and qualified paths
//! (`crate::lights::...`, `super::...`, and `cirrus::...` in the binary's
//! files), comments excluded.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

const MAX_FILE_LINES: usize = 800;
const MAX_CLI_LINES: usize = 1000;

/// One source file: its path under `src/` split into components without
/// `.rs` (`["integrator", "path"]`, `["film", "mod"]`), and its code with
/// comment lines removed.
struct Source {
    parts: Vec<String>,
    code: String,
    lines: usize,
}

fn sources() -> Vec<Source> {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    collect(&src, &mut files);
    files
        .into_iter()
        .map(|path| {
            let text = std::fs::read_to_string(&path).unwrap();
            let rel = path.strip_prefix(&src).unwrap().with_extension("");
            let code = text
                .lines()
                .filter(|l| !l.trim_start().starts_with("//"))
                .collect::<Vec<_>>()
                .join("\n");
            Source {
                parts: rel
                    .iter()
                    .map(|c| c.to_string_lossy().into_owned())
                    .collect(),
                code,
                lines: text.lines().count(),
            }
        })
        .collect()
}

fn collect(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            collect(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

/// The first-level names after each occurrence of `prefix` in `code`:
/// `prefix::name` gives `name`, `prefix::{a, b::c, d as e}` gives a, b, d.
fn names_after(code: &str, prefix: &str) -> Vec<String> {
    let mut names = Vec::new();
    let mut rest = code;
    while let Some(i) = rest.find(prefix) {
        let before = rest[..i].chars().next_back();
        rest = &rest[i + prefix.len()..];
        if before.is_some_and(|c| c.is_alphanumeric() || c == '_') {
            continue;
        }
        if let Some(group) = rest.strip_prefix('{') {
            let mut depth = 1;
            let mut item = String::new();
            let mut items = Vec::new();
            for c in group.chars() {
                match c {
                    '{' => depth += 1,
                    '}' if depth == 1 => break,
                    '}' => depth -= 1,
                    ',' if depth == 1 => items.push(std::mem::take(&mut item)),
                    _ if depth == 1 => item.push(c),
                    _ => {}
                }
            }
            items.push(item);
            names.extend(items.iter().filter_map(|i| first_ident(i)));
        } else if let Some(name) = first_ident(rest) {
            names.push(name);
        }
    }
    names
}

fn first_ident(s: &str) -> Option<String> {
    let ident: String = s
        .trim_start()
        .chars()
        .take_while(|c| c.is_alphanumeric() || *c == '_')
        .collect();
    (!ident.is_empty()).then_some(ident)
}

/// Whether `graph` has a cycle; the modules on one, if so.
fn cycle(graph: &BTreeMap<String, BTreeSet<String>>) -> Option<Vec<String>> {
    fn visit(
        node: &str,
        graph: &BTreeMap<String, BTreeSet<String>>,
        state: &mut BTreeMap<String, bool>,
        stack: &mut Vec<String>,
    ) -> Option<Vec<String>> {
        match state.get(node) {
            Some(true) => return None,
            Some(false) => {
                let start = stack.iter().position(|n| n == node).unwrap();
                return Some(stack[start..].to_vec());
            }
            None => {}
        }
        state.insert(node.to_string(), false);
        stack.push(node.to_string());
        for next in graph.get(node).into_iter().flatten() {
            if let Some(found) = visit(next, graph, state, stack) {
                return Some(found);
            }
        }
        stack.pop();
        state.insert(node.to_string(), true);
        None
    }
    let mut state = BTreeMap::new();
    graph
        .keys()
        .find_map(|node| visit(node, graph, &mut state, &mut Vec::new()))
}

/// Top-level module -> the top-level modules its files name.
fn top_level_graph(sources: &[Source]) -> BTreeMap<String, BTreeSet<String>> {
    let tops: BTreeSet<String> = sources
        .iter()
        .filter(|s| !matches!(s.parts[..], [ref f] if f == "lib" || f == "main"))
        .map(|s| s.parts[0].clone())
        .collect();
    let mut graph: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for s in sources.iter().filter(|s| tops.contains(&s.parts[0])) {
        let from = &s.parts[0];
        let named = names_after(&s.code, "crate::")
            .into_iter()
            .chain(names_after(&s.code, "cirrus::"));
        for to in named.filter(|n| tops.contains(n) && n != from) {
            graph.entry(from.clone()).or_default().insert(to);
        }
    }
    graph
}

/// Per folder, file -> the files of the same folder it names (through
/// `super::`, the folder's `crate::` path, or items its `mod.rs` re-exports
/// from them). The `mod.rs` itself, the interface that declares and
/// re-exports its files, is not a node.
fn folder_graphs(sources: &[Source]) -> BTreeMap<String, BTreeMap<String, BTreeSet<String>>> {
    let mut graphs = BTreeMap::new();
    let folders: BTreeSet<Vec<String>> = sources
        .iter()
        .filter(|s| s.parts.last().is_some_and(|p| p == "mod"))
        .map(|s| s.parts[..s.parts.len() - 1].to_vec())
        .collect();
    for folder in &folders {
        let depth = folder.len();
        let children: BTreeSet<String> = sources
            .iter()
            .filter(|s| s.parts.len() > depth && s.parts[..depth] == folder[..])
            .map(|s| s.parts[depth].clone())
            .filter(|c| c != "mod")
            .collect();
        let module = sources
            .iter()
            .find(|s| s.parts[..] == [folder.clone(), vec!["mod".into()]].concat())
            .unwrap();
        // Items the folder's mod.rs re-exports, by the file they come from.
        let mut reexported = BTreeMap::new();
        for prefix in ["pub use ", "pub(crate) use "] {
            for line in module.code.split(';') {
                if let Some(i) = line.find(prefix) {
                    let tree = &line[i + prefix.len()..];
                    if let Some(child) = first_ident(tree).filter(|c| children.contains(c)) {
                        let items = names_after(tree, &format!("{child}::"));
                        for item in items {
                            reexported.insert(item, child.clone());
                        }
                    }
                }
            }
        }
        let crate_path = format!("crate::{}::", folder.join("::"));
        let mut graph: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
        for s in sources
            .iter()
            .filter(|s| s.parts.len() > depth && s.parts[..depth] == folder[..])
        {
            let from = &s.parts[depth];
            if from == "mod" {
                continue;
            }
            // A file directly in the folder reaches it as `super::`; one in
            // a subfolder as `super::super::`.
            let nested = s.parts.len() - depth - 1;
            let up = if s.parts.last().is_some_and(|p| p == "mod") {
                nested
            } else {
                nested + 1
            };
            let mut named = names_after(&s.code, &"super::".repeat(up));
            named.extend(names_after(&s.code, &crate_path));
            for name in named {
                let to = if children.contains(&name) {
                    Some(name)
                } else {
                    reexported.get(&name).cloned()
                };
                if let Some(to) = to.filter(|t| t != from) {
                    graph.entry(from.clone()).or_default().insert(to);
                }
            }
        }
        graphs.insert(folder.join("/"), graph);
    }
    graphs
}

#[test]
fn no_cycle_between_top_level_modules() {
    let graph = top_level_graph(&sources());
    assert!(graph.contains_key("integrator") && graph["integrator"].contains("film"));
    if let Some(c) = cycle(&graph) {
        panic!("top-level modules import each other in a circle: {c:?}");
    }
}

#[test]
fn no_cycle_between_the_files_of_a_folder() {
    let graphs = folder_graphs(&sources());
    assert!(graphs["integrator"]["path"].contains("shadow"));
    for (folder, graph) in &graphs {
        if let Some(c) = cycle(graph) {
            panic!("files of src/{folder}/ import each other in a circle: {c:?}");
        }
    }
}

#[test]
fn only_the_command_line_uses_the_lab_clap_and_anyhow() {
    let sources = sources();
    let graph = top_level_graph(&sources);
    let users: Vec<&String> = graph
        .iter()
        .filter(|(from, to)| *from != "cli" && to.contains("lab"))
        .map(|(from, _)| from)
        .collect();
    assert!(users.is_empty(), "the renderer imports the lab: {users:?}");
    for s in sources.iter().filter(|s| s.parts[0] != "cli") {
        for word in ["clap::", "anyhow"] {
            assert!(
                !s.code.contains(word),
                "src/{}.rs uses {word}: it belongs in src/cli/",
                s.parts.join("/")
            );
        }
    }
}

#[test]
fn files_and_the_command_line_stay_small() {
    let sources = sources();
    let long: Vec<String> = sources
        .iter()
        .filter(|s| s.lines > MAX_FILE_LINES)
        .map(|s| format!("src/{}.rs ({} lines)", s.parts.join("/"), s.lines))
        .collect();
    assert!(long.is_empty(), "over {MAX_FILE_LINES} lines: {long:?}");
    let cli: usize = sources
        .iter()
        .filter(|s| s.parts[0] == "cli")
        .map(|s| s.lines)
        .sum();
    assert!(
        (1..MAX_CLI_LINES).contains(&cli),
        "src/cli/ has {cli} lines"
    );
}

#[test]
fn the_import_reader_sees_groups_and_paths() {
    let code = "use super::{read_snapshot, FarmError as E, parts::{Part}};\nlet x = crate::film::Film::new();";
    assert_eq!(
        names_after(code, "super::"),
        ["read_snapshot", "FarmError", "parts"]
    );
    assert_eq!(names_after(code, "crate::"), ["film"]);
    let mut graph = BTreeMap::new();
    graph.insert("a".to_string(), BTreeSet::from(["b".to_string()]));
    assert_eq!(cycle(&graph), None);
    graph.insert("b".to_string(), BTreeSet::from(["a".to_string()]));
    assert!(cycle(&graph).is_some());
}

// The exporter's Python modules (`exporter/cirrus_export/*.py` and
// `exporter/export_usd.py`): no import circle between them either.

/// The package the exporter's modules are in.
const PYTHON_PACKAGE: &str = "cirrus_export";

/// The modules of [`PYTHON_PACKAGE`] that Python `code` imports: `from .x
/// import`, `from . import x`, `from cirrus_export.x import`, `from
/// cirrus_export import x` and `import cirrus_export.x`, indented ones (in a
/// function, under `if TYPE_CHECKING:`) included, comments excluded.
fn python_imports(code: &str) -> BTreeSet<String> {
    let mut statements = Vec::new();
    let mut open: Option<String> = None;
    for line in code.lines() {
        let line = line.split('#').next().unwrap_or_default().trim();
        let statement = match open.take() {
            Some(start) => format!("{start} {line}"),
            None if line.starts_with("from ") || line.starts_with("import ") => line.to_string(),
            None => continue,
        };
        let unclosed = statement.matches('(').count() > statement.matches(')').count();
        if unclosed && statement.contains("import ") {
            open = Some(statement);
        } else {
            statements.push(statement.replace(['(', ')'], " "));
        }
    }
    let mut found = BTreeSet::new();
    for statement in &statements {
        let words: Vec<&str> = statement.split_whitespace().collect();
        let names = |from: &[&str]| {
            let names = from.join(" ");
            names
                .split(',')
                .filter_map(|n| n.split_whitespace().next().map(str::to_string))
                .collect::<Vec<_>>()
        };
        match words.as_slice() {
            ["from", module, "import", rest @ ..] => {
                let inner = match module.strip_prefix(PYTHON_PACKAGE) {
                    Some(inner) => inner.strip_prefix('.').or(inner.is_empty().then_some("")),
                    None => module.strip_prefix('.'),
                };
                match inner {
                    Some("") => found.extend(names(rest)),
                    Some(inner) => found.extend(inner.split('.').next().map(str::to_string)),
                    None => {}
                }
            }
            ["import", rest @ ..] => found.extend(names(rest).iter().filter_map(|n| {
                let inner = n.strip_prefix(PYTHON_PACKAGE)?.strip_prefix('.')?;
                inner.split('.').next().map(str::to_string)
            })),
            _ => {}
        }
    }
    found
}

/// Module -> the exporter's modules it imports, for the exporter in
/// `folder`: the package's modules by name, `export_usd` for the script.
fn python_graph(folder: &Path) -> BTreeMap<String, BTreeSet<String>> {
    let package = folder.join(PYTHON_PACKAGE);
    let mut files: Vec<PathBuf> = std::fs::read_dir(&package)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "py"))
        .collect();
    files.push(folder.join("export_usd.py"));
    let stem = |p: &Path| p.file_stem().unwrap().to_string_lossy().into_owned();
    let modules: BTreeSet<String> = files.iter().map(|p| stem(p)).collect();
    files
        .iter()
        .map(|path| {
            let imports = python_imports(&std::fs::read_to_string(path).unwrap());
            (
                stem(path),
                imports.intersection(&modules).cloned().collect(),
            )
        })
        .collect()
}

#[test]
fn no_cycle_between_the_exporters_python_modules() {
    let graph = python_graph(&Path::new(env!("CARGO_MANIFEST_DIR")).join("exporter"));
    assert!(graph["export_usd"].contains("export") && graph["prototypes"].contains("meshes"));
    if let Some(c) = cycle(&graph) {
        panic!("the exporter's Python modules import each other in a circle: {c:?}");
    }
}

#[test]
fn the_python_import_reader_sees_relative_absolute_and_indented_imports() {
    let code = "from .meshes import read_mesh\nfrom . import report, xforms as x\n\
                from cirrus_export.prims import (PREDICATE,\n    below)\n\
                import cirrus_export.skinning as skin, json\nif TYPE_CHECKING:\n    \
                from .volumes import VolumeTable\n# from .camera import Camera\n\
                from pxr import Usd\nfrom cirrus_export import binfile\n\
                \"\"\"A docstring\nfrom the lights (prose, not from .lights import x).\"\"\"\n";
    let expected = [
        "binfile", "meshes", "prims", "report", "skinning", "volumes", "xforms",
    ];
    assert_eq!(
        python_imports(code),
        BTreeSet::from(expected.map(String::from))
    );
}

// The module map of docs/architecture.md: drawn from the imports above, so
// that it cannot drift from the code.

/// The markers around the module map in docs/architecture.md.
const MAP_BEGIN: &str = "<!-- module map: drawn by tests/it/house.rs from the code's imports -->";
const MAP_END: &str = "<!-- end of module map -->";

/// Each node's floor: 1 for a node that imports nothing, else one above the
/// highest floor it imports (the graph has no cycle: tested above).
fn floors(
    graph: &BTreeMap<String, BTreeSet<String>>,
    nodes: &BTreeSet<String>,
) -> BTreeMap<String, usize> {
    fn floor(
        n: &str,
        g: &BTreeMap<String, BTreeSet<String>>,
        memo: &mut BTreeMap<String, usize>,
    ) -> usize {
        if let Some(&f) = memo.get(n) {
            return f;
        }
        let f = 1 + g
            .get(n)
            .into_iter()
            .flatten()
            .map(|m| floor(m, g, memo))
            .max()
            .unwrap_or(0);
        memo.insert(n.to_string(), f);
        f
    }
    let mut memo = BTreeMap::new();
    nodes
        .iter()
        .map(|n| (n.clone(), floor(n, graph, &mut memo)))
        .collect()
}

/// The arrows of `graph` that no longer path implies (its transitive
/// reduction), the ones worth drawing.
fn direct_arrows(graph: &BTreeMap<String, BTreeSet<String>>) -> Vec<(String, String)> {
    let reaches = |from: &str, to: &str, skip: &str| {
        let mut seen = BTreeSet::new();
        let mut todo: Vec<&str> = graph[from]
            .iter()
            .map(String::as_str)
            .filter(|n| *n != skip)
            .collect();
        while let Some(n) = todo.pop() {
            if n == to {
                return true;
            }
            if seen.insert(n) {
                todo.extend(graph.get(n).into_iter().flatten().map(String::as_str));
            }
        }
        false
    };
    graph
        .iter()
        .flat_map(|(a, tos)| tos.iter().map(move |b| (a.clone(), b.clone())))
        .filter(|(a, b)| !reaches(a, b, b))
        .collect()
}

/// One map: a Mermaid drawing of the arrows no longer path implies, floors
/// top down, and a table of every import.
fn map_section(
    title: &str,
    graph: &BTreeMap<String, BTreeSet<String>>,
    nodes: &[String],
) -> String {
    let floor = floors(graph, &nodes.iter().cloned().collect());
    let mut order: Vec<&String> = nodes.iter().collect();
    order.sort_by_key(|n| (std::cmp::Reverse(floor[*n]), *n));
    let mut out = format!("### {title}\n\n```mermaid\nflowchart TD\n");
    for (a, b) in direct_arrows(graph) {
        out += &format!("  {a} --> {b}\n");
    }
    let alone = |n: &&&String| !graph.contains_key(**n) && !graph.values().any(|t| t.contains(**n));
    for n in order.iter().filter(alone) {
        out += &format!("  {n}\n");
    }
    out += "```\n\n| floor | module | imports |\n|---|---|---|\n";
    for n in order {
        let imports: Vec<String> = graph
            .get(n)
            .into_iter()
            .flatten()
            .map(|m| format!("`{m}`"))
            .collect();
        out += &format!("| {} | `{n}` | {} |\n", floor[n], imports.join(", "));
    }
    out
}

/// The module map as docs/architecture.md should hold it: `src/`'s top-level
/// modules and the exporter's Python modules (structure only: no sizes, so
/// that only a change of imports redraws it).
fn module_map() -> String {
    let sources = sources();
    let rust: Vec<String> = sources
        .iter()
        .filter(|s| !matches!(s.parts[..], [ref f] if f == "lib" || f == "main"))
        .map(|s| s.parts[0].clone())
        .collect::<BTreeSet<_>>()
        .into_iter()
        .collect();
    let exporter = Path::new(env!("CARGO_MANIFEST_DIR")).join("exporter");
    let python_modules = python_graph(&exporter);
    let python: Vec<String> = python_modules
        .keys()
        .filter(|n| *n != "__init__")
        .cloned()
        .collect();
    format!(
        "{MAP_BEGIN}\n\n{}\n{}\n{MAP_END}",
        map_section(
            "`src/`: top-level modules (a module imports only modules on lower floors)",
            &top_level_graph(&sources),
            &rust
        ),
        map_section("`exporter/`: the Python modules", &python_modules, &python),
    )
}

#[test]
fn the_architecture_map_is_drawn_from_the_code() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/architecture.md");
    let doc = std::fs::read_to_string(&path).unwrap();
    let (Some(begin), Some(end)) = (doc.find(MAP_BEGIN), doc.find(MAP_END)) else {
        panic!(
            "{}: no module map between {MAP_BEGIN:?} and {MAP_END:?}",
            path.display()
        );
    };
    let drawn = &doc[begin..end + MAP_END.len()];
    let map = module_map();
    if drawn == map {
        return;
    }
    if std::env::var_os("CIRRUS_BLESS").is_some() {
        std::fs::write(&path, doc.replace(drawn, &map)).unwrap();
        return;
    }
    panic!(
        "{}'s module map differs from the code's imports: rerun this test with \
         CIRRUS_BLESS=1 to redraw it, and commit the result",
        path.display()
    );
}

#[test]
fn the_map_draws_only_arrows_no_longer_path_implies() {
    let graph = BTreeMap::from([
        (
            "cli".to_string(),
            BTreeSet::from(["job".to_string(), "film".to_string()]),
        ),
        ("job".to_string(), BTreeSet::from(["film".to_string()])),
    ]);
    let arrows = direct_arrows(&graph);
    assert_eq!(
        arrows,
        [("cli".into(), "job".into()), ("job".into(), "film".into())]
    );
    let nodes = BTreeSet::from(["cli", "job", "film"].map(String::from));
    let floor = floors(&graph, &nodes);
    assert_eq!((floor["cli"], floor["job"], floor["film"]), (3, 2, 1));
}
