//! `UsdLuxShapingAPI` end to end: the exporter's `shaping` record and its
//! warning for a missing IES file, `cirrus info`'s list of shaped lights,
//! and the renderer's warnings for out-of-range inputs and bad candela (the
//! falloffs themselves are tested against the schema's formulas in
//! `src/lights/shaping.rs`).

use crate::common;

/// A spot with an out-of-range cone angle and softness, a disk light with an
/// IES file holding a NaN and a negative candela, a rect light whose IES
/// file is missing, and a plain sphere: each bad input is warned about once
/// naming the light (and the file), `info` lists the three shaped lights and
/// says which profile is unusable, and the scene still renders.
#[test]
fn shaping_inputs_are_exported_listed_and_checked() {
    let dir = common::scratch("shaping_export");
    std::fs::write(
        dir.join("bad.ies"),
        "IESNA:LM-63-2002\nTILT=NONE\n1 -1 1 3 1 1 2 0 0 0\n1 1 10\n0 45 90\n0\n10 nan -1\n",
    )
    .unwrap();
    let out = common::export_usda(
        &dir,
        r#"#usda 1.0
(
    defaultPrim = "World"
)
def Xform "World"
{
    def SphereLight "Spot" (
        prepend apiSchemas = ["ShapingAPI"]
    )
    {
        float inputs:radius = 0.1
        float inputs:shaping:cone:angle = 200
        float inputs:shaping:cone:softness = -0.5
    }
    def DiskLight "Lamp" (
        prepend apiSchemas = ["ShapingAPI"]
    )
    {
        asset inputs:shaping:ies:file = @bad.ies@
        bool inputs:shaping:ies:normalize = 1
        double3 xformOp:translate = (3, 0, 0)
        uniform token[] xformOpOrder = ["xformOp:translate"]
    }
    def RectLight "Missing"
    {
        asset inputs:shaping:ies:file = @missing.ies@
        double3 xformOp:translate = (-3, 0, 0)
        uniform token[] xformOpOrder = ["xformOp:translate"]
    }
    def SphereLight "Plain"
    {
    }
    def Mesh "Ground"
    {
        int[] faceVertexCounts = [4]
        int[] faceVertexIndices = [0, 1, 2, 3]
        point3f[] points = [(-5, -5, -2), (5, -5, -2), (5, 5, -2), (-5, 5, -2)]
    }
}
"#,
    );
    let manifest: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("scene.json")).unwrap()).unwrap();
    let lights = manifest["lights"].as_array().unwrap();
    let spot = &lights[0]["shaping"];
    assert_eq!(spot["cone_angle_deg"], 200.0);
    assert_eq!(spot["cone_softness"], -0.5);
    assert!(spot["ies_file"].is_null());
    // ShapingAPI applied: the schema's fallbacks; not applied: shapes nothing but the file.
    assert_eq!(lights[1]["shaping"]["cone_angle_deg"], 90.0);
    assert_eq!(lights[1]["shaping"]["ies_normalize"], true);
    assert_eq!(lights[2]["shaping"]["cone_angle_deg"], 180.0);
    assert!(lights[3].get("shaping").is_none());
    let warnings = manifest["warnings"].to_string();
    assert_eq!(warnings.matches("missing.ies").count(), 1, "{warnings}");
    assert!(warnings.contains("/World/Missing"), "{warnings}");

    let info = common::cirrus_ok(&["info".as_ref(), out.as_os_str()]);
    for expected in [
        "shaped       3\n",
        "/World/Spot (sphere): cone 200 deg, softness -0.5",
        "bad.ies (2 bad candela value(s) read as 0), angleScale 0, normalize true",
        "missing.ies UNUSABLE, not shaped by it",
    ] {
        assert!(info.contains(expected), "missing {expected:?} in:\n{info}");
    }

    let render = common::render_tiny(&out, &dir);
    let stderr = String::from_utf8_lossy(&render.stderr);
    assert!(render.status.success(), "{stderr}");
    for expected in [
        "light /World/Spot: inputs:shaping:cone:angle = 200 is out of range [0, 180]; using 180",
        "light /World/Spot: inputs:shaping:cone:softness = -0.5 is out of range [0, 1]; using 0",
        "bad.ies: 2 NaN, infinite, negative or huge (over 1e20) candela value(s) read as 0",
        "light /World/Missing: IES profile",
    ] {
        assert_eq!(
            stderr.matches(expected).count(),
            1,
            "{expected:?} in:\n{stderr}"
        );
    }
}
