//! USD conformance (issue 46): one row per attribute of the schemas the
//! exporter reads, each judged from the pixels of the smallest stage that
//! shows it (or, where we choose not to honour it, from the warning naming
//! prim and attribute). Stages are written in code, many rows sharing one
//! render: a "sheet" of cells side by side seen straight down by an
//! orthographic camera (see `sheet.rs`). `docs/usd-support.md`'s tables are
//! generated from these rows ([`the_support_tables_are_current`]).
//!
//! A row's [`Status`] says what we claim; the suite fails when a row claimed
//! honoured, approximated, warned or a documented choice does not hold. A
//! [`Status::Pending`] row asserts the correct behaviour of something being
//! fixed elsewhere: it runs and prints its result without failing, and the
//! doc says "not yet honoured"; flipping it to `Honoured` is one word.

mod camera;
mod geom;
mod lux;
mod render_settings;
mod shade;
mod sheet;
mod surface;
mod texture;
mod vol;

use std::path::Path;

/// What the row claims, as the generated doc shows it.
#[derive(Clone, Copy, Debug)]
pub enum Status {
    /// Rendered as the schema documents.
    Honoured,
    /// Rendered, but not exactly as the schema documents: how.
    Approximated(&'static str),
    /// Not rendered, with a warning naming prim and attribute.
    Warned,
    /// A case the schema leaves open (or a real-time hint): what we chose.
    Choice(&'static str),
    /// Not honoured yet, fixed on another branch: "issue N: what is wrong".
    /// The check asserts the correct behaviour; its failure is printed.
    #[allow(dead_code, reason = "no row is pending once every fix has landed")]
    Pending(&'static str),
}

use Status::{Approximated, Choice, Honoured, Pending, Warned};

/// One attribute of one schema, and the check that decides it from a render.
pub struct Row {
    /// The schema (or API schema, or shader id).
    pub schema: &'static str,
    /// The attribute, input or relationship.
    pub attribute: &'static str,
    /// What we claim.
    pub status: Status,
    /// What the pixels (or the log) show, for the doc.
    pub note: &'static str,
    /// Ok when the render shows the claim; else what it showed.
    pub check: fn() -> Result<(), String>,
}

/// A row, in the order the tables list its fields.
pub const fn row(
    schema: &'static str,
    attribute: &'static str,
    status: Status,
    note: &'static str,
    check: fn() -> Result<(), String>,
) -> Row {
    Row {
        schema,
        attribute,
        status,
        note,
        check,
    }
}

/// Every family: its title in the doc and its rows.
fn families() -> Vec<(&'static str, Vec<Row>)> {
    vec![
        (
            "UsdGeom: gprims, meshes, points, curves, instancers, visibility, purpose, active",
            geom::rows(),
        ),
        (
            "UsdShade: bindings, purposes, strengths, collections, GeomSubsets",
            shade::rows(),
        ),
        ("UsdPreviewSurface", surface::rows()),
        (
            "UsdUVTexture, UsdTransform2d, primvar readers",
            texture::rows(),
        ),
        ("UsdLux", lux::rows()),
        ("UsdGeomCamera", camera::rows()),
        (
            "UsdRender: settings, products, vars, passes",
            render_settings::rows(),
        ),
        ("UsdVol", vol::rows()),
    ]
}

/// Runs every row, printing one line each; panics listing the rows that
/// claim more than their render shows (pending rows are only printed).
pub fn check_rows(rows: &[Row]) {
    let mut failed = Vec::new();
    for row in rows {
        let name = format!("{} {}", row.schema, row.attribute);
        let result = (row.check)();
        match (row.status, &result) {
            (Pending(why), Ok(())) => {
                eprintln!("conformance: {name}: PENDING ({why}) now holds: flip it to Honoured")
            }
            (Pending(why), Err(e)) => eprintln!("conformance: {name}: pending ({why}): {e}"),
            (_, Ok(())) => eprintln!("conformance: {name}: ok"),
            (_, Err(e)) => {
                eprintln!("conformance: {name}: FAILED: {e}");
                failed.push(format!("{name}: {e}"));
            }
        }
    }
    assert!(
        failed.is_empty(),
        "{} rows fail:\n{}",
        failed.len(),
        failed.join("\n")
    );
}

/// The doc's words for a status, and the note column.
fn status_cells(row: &Row) -> (String, String) {
    match row.status {
        Honoured => ("honoured".into(), row.note.into()),
        Approximated(how) => ("approximated".into(), format!("{}; {how}", row.note)),
        Warned => ("warned".into(), row.note.into()),
        Choice(what) => ("documented choice".into(), format!("{}; {what}", row.note)),
        Pending(why) => {
            let issue = why.split(':').next().unwrap_or(why);
            (format!("not yet honoured ({issue})"), row.note.into())
        }
    }
}

/// The generated tables, between (and including) the markers.
fn support_tables() -> String {
    let mut out = String::from(BEGIN);
    out.push_str(
        "\n\nGenerated from the conformance suite (`tests/it/conformance/`): each row is \
         checked from the pixels of a small stage (or, where warned, from the warning naming \
         prim and attribute) by `cargo test --release --test it conformance::`. Regenerate \
         with `CIRRUS_BLESS=1 cargo test --release --test it \
         conformance::the_support_tables_are_current`.\n",
    );
    for (title, rows) in families() {
        out.push_str(&format!(
            "\n### {title}\n\n| schema | attribute | status | what the suite checks |\n|---|---|---|---|\n"
        ));
        for row in &rows {
            let (status, note) = status_cells(row);
            out.push_str(&format!(
                "| `{}` | `{}` | {status} | {} |\n",
                row.schema,
                row.attribute,
                note.replace('|', "\\|")
            ));
        }
    }
    out.push('\n');
    out.push_str(END);
    out
}

const BEGIN: &str = "<!-- BEGIN generated by tests/it/conformance: do not edit by hand -->";
const END: &str = "<!-- END generated by tests/it/conformance -->";

/// docs/usd-support.md's generated tables match the rows (regenerated and
/// compared, as `house::the_architecture_map` checks its map); with
/// `CIRRUS_BLESS=1` the doc is rewritten instead.
#[test]
fn the_support_tables_are_current() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/usd-support.md");
    let doc = std::fs::read_to_string(&path).unwrap();
    let begin = doc
        .find(BEGIN)
        .expect("docs/usd-support.md has no BEGIN marker");
    let end = doc
        .find(END)
        .expect("docs/usd-support.md has no END marker")
        + END.len();
    let tables = support_tables();
    if doc[begin..end] == tables {
        return;
    }
    if std::env::var_os("CIRRUS_BLESS").is_some() {
        std::fs::write(&path, format!("{}{tables}{}", &doc[..begin], &doc[end..])).unwrap();
        return;
    }
    panic!(
        "{}'s generated tables differ from tests/it/conformance's rows: rerun this test \
         with CIRRUS_BLESS=1 and commit the result",
        path.display()
    );
}

/// Every row names a schema and an attribute once: two rows for one
/// attribute would make the doc contradict itself.
#[test]
fn each_attribute_has_one_row() {
    let mut seen = std::collections::BTreeSet::new();
    for (_, rows) in families() {
        for row in rows {
            assert!(
                seen.insert((row.schema, row.attribute)),
                "two rows for {} {}",
                row.schema,
                row.attribute
            );
        }
    }
}
