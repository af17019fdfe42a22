//! UsdShade rows: material bindings, their strengths and purposes,
//! collection-based bindings and GeomSubsets, on one dome-lit sheet whose
//! quads are bound (directly or not) to a blue or a green Lambert look.

use super::sheet::{self, ensure, Lighting, Rgb, Shot};
use super::{row, Honoured, Row};
use std::sync::OnceLock;

const COLS: usize = 8;

fn cells() -> Vec<String> {
    let stronger = "rel material:binding = </Looks/Blue> (\n    bindMaterialAs = \"strongerThanDescendants\"\n)";
    vec![
        sheet::quad("Q", "/Looks/Blue", ""),
        format!("rel material:binding = </Looks/Blue>\n{}", sheet::quad("Q", "", "")),
        format!("{stronger}\n{}", sheet::quad("Q", "/Looks/Green", "")),
        format!("rel material:binding = </Looks/Blue>\n{}", sheet::quad("Q", "/Looks/Green", "")),
        sheet::quad("Q", "", "rel material:binding:preview = </Looks/Green>\nrel material:binding:full = </Looks/Blue>"),
        sheet::quad("Q", "/Looks/Green", "rel material:binding:full = </Looks/Blue>"),
        sheet::quad("Q", "", "rel material:binding:preview = </Looks/Blue>"),
        format!(
            "def Xform \"Group\" (prepend apiSchemas = [\"MaterialBindingAPI\", \"CollectionAPI:shiny\"])\n{{\n    \
             rel collection:shiny:includes = <$CELL/Group/Q>\n    \
             rel material:binding:collection:shiny = [<$CELL/Group.collection:shiny>, </Looks/Blue>]\n{}\n}}",
            sheet::quad("Q", "", "")
        ),
        "def Mesh \"M\" (prepend apiSchemas = [\"MaterialBindingAPI\"])\n{\n    \
         point3f[] points = [(-0.8,-0.8,0),(0,-0.8,0),(0.8,-0.8,0),(-0.8,0.8,0),(0,0.8,0),(0.8,0.8,0)]\n    \
         int[] faceVertexCounts = [4, 4]\n    int[] faceVertexIndices = [0, 1, 4, 3, 1, 2, 5, 4]\n    \
         rel material:binding = </Looks/Green>\n    \
         def GeomSubset \"Right\" (prepend apiSchemas = [\"MaterialBindingAPI\"])\n    {\n        \
         uniform token elementType = \"face\"\n        uniform token familyName = \"materialBind\"\n        \
         int[] indices = [1]\n        rel material:binding = </Looks/Blue>\n    }\n}"
            .into(),
    ]
}

fn shot() -> &'static Shot {
    static SHOT: OnceLock<Shot> = OnceLock::new();
    sheet::once(&SHOT, || {
        let looks = format!(
            "def Scope \"Looks\"\n{{\n{}\n{}\n}}",
            sheet::material("Looks/Blue", &sheet::lambert((0.05, 0.05, 0.8))),
            sheet::material("Looks/Green", &sheet::lambert((0.05, 0.8, 0.05)))
        );
        sheet::render_sheet(
            "shade",
            &sheet::sheet(COLS, Lighting::Dome, &cells(), &looks),
            8,
        )
    })
}

/// Ok when `c` is the blue look's colour.
fn blue(what: &str, c: Rgb) -> Result<(), String> {
    ensure(c[2] > 0.6 && c[1] < 0.15, || {
        format!("{what}: {c:.3?} is not the blue look")
    })
}

/// Ok when `c` is the green look's colour.
fn green(what: &str, c: Rgb) -> Result<(), String> {
    ensure(c[1] > 0.6 && c[2] < 0.15, || {
        format!("{what}: {c:.3?} is not the green look")
    })
}

fn cell(k: usize) -> Rgb {
    shot().cell(COLS, k)
}

pub fn rows() -> Vec<Row> {
    vec![
        row("MaterialBindingAPI", "material:binding", Honoured, "a quad bound to the blue look renders it", || blue("direct", cell(0))),
        row("MaterialBindingAPI", "material:binding (inherited)", Honoured, "a quad under an Xform bound to the blue look renders it", || blue("inherited", cell(1))),
        row("MaterialBindingAPI", "bindMaterialAs strongerThanDescendants", Honoured, "an ancestor's stronger binding wins over the quad's own", || blue("stronger", cell(2))),
        row("MaterialBindingAPI", "bindMaterialAs weakerThanDescendants", Honoured, "the quad's own binding wins over an ancestor's (the default strength)", || green("weaker", cell(3))),
        row("MaterialBindingAPI", "material:binding:full", Honoured,
            "a final render takes the full binding over the preview one and over the all-purpose one", || {
                blue("full over preview", cell(4)).and(blue("full over all-purpose", cell(5)))
            }),
        row("MaterialBindingAPI", "material:binding:preview", Honoured,
            "a preview-only binding is not used by a final render (the default look instead)", || {
                let c = cell(6);
                ensure(c[2] < 0.3, || format!("{c:.3?}: the preview look"))
            }),
        row("MaterialBindingAPI", "material:binding:collection", Honoured, "a collection-based binding whose collection includes the quad binds it", || blue("collection", cell(7))),
        row("GeomSubset", "elementType, familyName materialBind, indices", Honoured,
            "a face subset's own binding covers its face, the mesh's the rest", || {
                let s = shot();
                green("left face", s.part(COLS, 8, (0.1, 0.4), (0.2, 0.8)))
                    .and(blue("right face (the subset)", s.part(COLS, 8, (0.6, 0.9), (0.2, 0.8))))
            }),
    ]
}

#[test]
fn rows_hold() {
    super::check_rows(&rows());
}
