//! UsdVol rows: scenes/tests/volume_box.vdb (density 1 over a 0.9375-unit
//! cube) as purely absorbing Volumes (stretched to 1.875 x 1.875 across, 0.9375 deep) over the sheet's red ground, seen
//! straight down: through densityScale 2 the ground reads exp(-2) (the grid integrates to 1 along an axis through it).

use super::sheet::{self, near, Lighting, Shot};
use super::{row, Honoured, Row, Warned};
use std::path::Path;
use std::sync::OnceLock;

const COLS: usize = 8;

/// A Volume `V` centred in its cell, its density field the box's grid
/// (its asset's extra lines `asset`), with further usda `more`.
fn volume(asset: &str, more: &str) -> String {
    format!(
        "def Volume \"V\"\n{{\n    double3 xformOp:translate = (-0.9375, -0.9375, 0)\n    \
         float3 xformOp:scale = (2, 2, 1)\n    uniform token[] xformOpOrder = [\"xformOp:translate\", \"xformOp:scale\"]\n    rel field:density = <$CELL/V/density>\n    \
         float primvars:densityScale = 2\n    color3f primvars:albedo = (0, 0, 0)\n    {more}\n    \
         def OpenVDBAsset \"density\"\n    {{\n        asset filePath = @./volume_box.vdb@\n        \
         token fieldName = \"density\"\n        {asset}\n    }}\n}}"
    )
}

fn shot() -> &'static Shot {
    static SHOT: OnceLock<Shot> = OnceLock::new();
    sheet::once(&SHOT, || {
        let cells = vec![
            volume("", ""),
            volume("token fieldClass = \"levelSet\"", ""),
            volume(
                "",
                "rel field:foo = <$CELL/V/foo>\n    def OpenVDBAsset \"foo\"\n    {\n        \
                 asset filePath = @./volume_box.vdb@\n        token fieldName = \"density\"\n    }",
            ),
        ];
        let usda = sheet::sheet(COLS, Lighting::Dome, &cells, "");
        sheet::render(
            "vol",
            &usda,
            (128, &["--res", "64x48"], sheet::RES),
            |dir| {
                let vdb = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/tests/volume_box.vdb");
                std::fs::copy(vdb, dir.join("volume_box.vdb")).unwrap();
            },
        )
    })
}

pub fn rows() -> Vec<Row> {
    vec![
        row("Volume", "field:density", Honoured, "an absorbing box of optical depth 2 (densityScale x the grid's integral 1 across) dims the ground to exp(-2) = 0.135", || {
            near("through the box", shot().mean((1, 7), (1, 7)), [(-2f64).exp(), 0.0, 0.0], 0.15)
        }),
        row("OpenVDBAsset", "filePath, fieldName", Honoured, "the grid the asset names, from the file it names, is the density (the row above)", || {
            near("through the box", shot().mean((1, 7), (1, 7)), [(-2f64).exp(), 0.0, 0.0], 0.15)
        }),
        row("OpenVDBAsset", "fieldClass", Warned, "a levelSet grid is converted as documented or refused with a warning naming the field and fieldClass", || {
            shot().warned(&["/Sheet/C1/V/density", "fieldClass"])
        }),
        row("Volume", "field:NAME (other fields)", Warned, "a field Cirrus does not model is dropped with a warning naming volume and field", || {
            shot().warned(&["/Sheet/C2/V", "field:foo"])
        }),
    ]
}

#[test]
fn rows_hold() {
    super::check_rows(&rows());
}
