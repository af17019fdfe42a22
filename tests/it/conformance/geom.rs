//! UsdGeom rows: gprims, meshes, points, curves, instancers, transforms,
//! visibility, purpose and active, on one dome-lit sheet of 8 x 6 cells (8
//! pixels each, 4 pixels per unit) over a ground emitting pure red: a cell
//! is "covered" where its green exceeds 0.03 (unbound gprims render grey).

use super::sheet::{self, centroid_x, ensure, spans, Lighting, Shot};
use super::{row, Approximated, Choice, Honoured, Row, Warned};
use std::sync::OnceLock;

const COLS: usize = 8;

/// The cells, by index.
fn cells() -> Vec<String> {
    let sphere =
        |r: f64, extra: &str| format!("def Sphere \"S\" {extra}\n{{\n    double radius = {r}\n}}");
    let along_x = |kind: &str, r: f64, h: f64| {
        format!("def {kind} \"G\"\n{{\n    double radius = {r}\n    double height = {h}\n    uniform token axis = \"X\"\n}}")
    };
    let cube_mesh = |scheme: &str| {
        format!(
            "def Mesh \"Box\"\n{{\n    uniform token subdivisionScheme = \"{scheme}\"\n    \
             point3f[] points = [(-0.7,-0.7,-0.7),(0.7,-0.7,-0.7),(0.7,0.7,-0.7),(-0.7,0.7,-0.7),\
             (-0.7,-0.7,0.7),(0.7,-0.7,0.7),(0.7,0.7,0.7),(-0.7,0.7,0.7)]\n    \
             int[] faceVertexCounts = [4, 4, 4, 4, 4, 4]\n    \
             int[] faceVertexIndices = [0,3,2,1, 4,5,6,7, 0,1,5,4, 1,2,6,5, 2,3,7,6, 3,0,4,7]\n}}"
        )
    };
    let instancer = |attrs: &str, proto: &str| {
        format!(
            "def PointInstancer \"PI\"\n{{\n    rel prototypes = [<$CELL/PI/Protos/P>]\n    {attrs}\n    \
             def Scope \"Protos\"\n    {{\n        {proto}\n    }}\n}}"
        )
    };
    let ball = "def Sphere \"P\"\n        {\n            double radius = 0.25\n        }";
    let quad = |extra: &str| sheet::quad("Q", "", extra);
    vec![
        sphere(0.3, ""),
        sphere(0.8, ""),
        "def Cube \"C\"\n{\n    double size = 0.6\n}".into(),
        "def Cube \"C\"\n{\n    double size = 1.5\n}".into(),
        along_x("Cylinder", 0.3, 1.6),
        "def Cylinder \"G\"\n{\n    double radius = 0.7\n    double height = 0.5\n}".into(),
        along_x("Cone", 0.3, 1.6),
        along_x("Capsule", 0.25, 1.0),
        "def Plane \"G\"\n{\n    double width = 1.2\n    double length = 0.4\n}".into(),
        "def Mesh \"T\"\n{\n    point3f[] points = [(-0.8, -0.8, 0), (0.8, -0.8, 0), (-0.8, 0.8, 0)]\n    \
         int[] faceVertexCounts = [3]\n    int[] faceVertexIndices = [0, 1, 2]\n}"
            .into(),
        "def Mesh \"H\"\n{\n    uniform token subdivisionScheme = \"none\"\n    point3f[] points = [(-0.8,-0.8,0),(0,-0.8,0),(0.8,-0.8,0),(-0.8,0.8,0),(0,0.8,0),(0.8,0.8,0)]\n    \
         int[] faceVertexCounts = [4, 4]\n    int[] faceVertexIndices = [0, 1, 4, 3, 1, 2, 5, 4]\n    \
         int[] holeIndices = [1]\n}"
            .into(),
        cube_mesh("catmullClark"),
        cube_mesh("none"),
        "def Mesh \"Q\"\n{\n    point3f[] points = [(-0.8, -0.8, 0), (0.8, -0.8, 0), (0.8, 0.8, 0), (-0.8, 0.8, 0)]\n    \
         int[] faceVertexCounts = [4]\n    int[] faceVertexIndices = [0, 3, 2, 1]\n    uniform bool doubleSided = 0\n}"
            .into(),
        quad("color3f[] primvars:displayColor = [(0.1, 0.1, 0.9)] (interpolation = \"constant\")"),
        quad("color3f[] primvars:displayColor = [(1, 1, 1)] (interpolation = \"constant\")\n\
              float[] primvars:displayOpacity = [0] (interpolation = \"constant\")"),
        "def Sphere \"S\"\n{\n    double radius = 0.6\n    token visibility = \"invisible\"\n}".into(),
        "def Xform \"X\"\n{\n    token visibility = \"invisible\"\n    def Sphere \"S\"\n    {\n        double radius = 0.6\n    }\n}".into(),
        "def Sphere \"S\"\n{\n    double radius = 0.6\n    uniform token purpose = \"guide\"\n}".into(),
        "def Sphere \"S\"\n{\n    double radius = 0.6\n    uniform token purpose = \"proxy\"\n}".into(),
        "def Sphere \"S\"\n{\n    double radius = 0.6\n    uniform token purpose = \"render\"\n}".into(),
        sphere(0.6, "(active = false)"),
        "def Sphere \"S\"\n{\n    double radius = 0.3\n    double3 xformOp:translate = (0.5, 0, 0)\n    \
         uniform token[] xformOpOrder = [\"xformOp:translate\"]\n}"
            .into(),
        "def Sphere \"S\"\n{\n    double radius = 0.3\n    float3 xformOp:scale = (2, 1, 1)\n    \
         uniform token[] xformOpOrder = [\"xformOp:scale\"]\n}"
            .into(),
        "def Cylinder \"G\"\n{\n    double radius = 0.25\n    double height = 1.6\n    uniform token axis = \"X\"\n    \
         float xformOp:rotateZ = 90\n    uniform token[] xformOpOrder = [\"xformOp:rotateZ\"]\n}"
            .into(),
        "def Sphere \"S\"\n{\n    double radius = 0.3\n    \
         matrix4d xformOp:transform = ((1, 0, 0, 0), (0, 1, 0, 0), (0, 0, 1, 0), (-0.5, 0, 0, 1))\n    \
         uniform token[] xformOpOrder = [\"xformOp:transform\"]\n}"
            .into(),
        "def Points \"P\"\n{\n    point3f[] points = [(0, 0, 0)]\n    float[] widths = [1.2]\n}".into(),
        "def Points \"P\"\n{\n    point3f[] points = [(0, 0, 0)]\n    float[] widths = [0.4]\n}".into(),
        "def BasisCurves \"B\"\n{\n    uniform token type = \"linear\"\n    int[] curveVertexCounts = [2]\n    \
         point3f[] points = [(-0.7, 0, 0), (0.7, 0, 0)]\n    float[] widths = [0.4] (interpolation = \"constant\")\n    color3f[] primvars:displayColor = [(1, 1, 1)]\n}"
            .into(),
        "def BasisCurves \"B\"\n{\n    uniform token type = \"cubic\"\n    uniform token basis = \"bezier\"\n    \
         int[] curveVertexCounts = [4]\n    point3f[] points = [(-0.7, -0.5, 0), (-0.7, 0.7, 0), (0.7, 0.7, 0), (0.7, -0.5, 0)]\n    \
         float[] widths = [0.3] (interpolation = \"constant\")\n    color3f[] primvars:displayColor = [(1, 1, 1)]\n}"
            .into(),
        instancer("int[] protoIndices = [0, 0]\n    point3f[] positions = [(-0.5, 0, 0), (0.5, 0, 0)]", ball),
        instancer("int[] protoIndices = [0]\n    point3f[] positions = [(0, 0, 0)]\n    float3[] scales = [(3, 3, 3)]", ball),
        instancer("int[] protoIndices = [0, 0]\n    point3f[] positions = [(-0.5, 0, 0), (0.5, 0, 0)]\n    \
                   int64[] ids = [7, 8]\n    int64[] invisibleIds = [7]", ball),
        instancer("int[] protoIndices = [0]\n    point3f[] positions = [(0, 0, 0)]\n    float3[] scales = [(3, 3, 3)]",
                  "def Sphere \"P\" (active = false)\n        {\n            double radius = 0.25\n        }"),
        "def Xform \"I\" (instanceable = true\n    references = </Protos/Ball>)\n{\n}".into(),
        instancer("int[] protoIndices = [0]\n    point3f[] positions = [(0, 0, 0)]\n    quath[] orientations = [(0.7071068, 0, 0, 0.7071068)]",
                  "def Cylinder \"P\"\n        {\n            double radius = 0.25\n            double height = 1.6\n            uniform token axis = \"X\"\n        }"),
        "def NurbsCurves \"N\"\n{\n    int[] curveVertexCounts = [4]\n    point3f[] points = [(-0.7, -0.5, 0), (-0.7, 0.7, 0), (0.7, 0.7, 0), (0.7, -0.5, 0)]\n    \
         int[] order = [4]\n    double[] knots = [0, 0, 0, 0, 1, 1, 1, 1]\n    float[] widths = [0.3] (interpolation = \"constant\")\n    \
         color3f[] primvars:displayColor = [(1, 1, 1)]\n}"
            .into(),
        "def Cylinder_1 \"G\"\n{\n    double radiusTop = 0.1\n    double radiusBottom = 0.6\n    double height = 1\n}".into(),
        "def Capsule_1 \"G\"\n{\n    double radiusTop = 0.2\n    double radiusBottom = 0.3\n    double height = 1\n    uniform token axis = \"X\"\n}".into(),
        "def HermiteCurves \"H\"\n{\n    int[] curveVertexCounts = [2]\n    point3f[] points = [(-0.5, 0, 0), (0.5, 0, 0)]\n    \
         vector3f[] tangents = [(1, 0, 0), (1, 0, 0)]\n}"
            .into(),
        "def NurbsPatch \"P\"\n{\n    int uVertexCount = 2\n    int vVertexCount = 2\n    int uOrder = 2\n    int vOrder = 2\n    \
         double[] uKnots = [0, 0, 1, 1]\n    double[] vKnots = [0, 0, 1, 1]\n    \
         point3f[] points = [(-0.5, -0.5, 0), (0.5, -0.5, 0), (-0.5, 0.5, 0), (0.5, 0.5, 0)]\n}"
            .into(),
        "def TetMesh \"T\"\n{\n    point3f[] points = [(0, 0, 0), (0.5, 0, 0), (0, 0.5, 0), (0, 0, 0.5)]\n    int4[] tetVertexIndices = [(0, 1, 2, 3)]\n}".into(),
        cubic("bspline", "nonperiodic", ARCH, 0.3),
        cubic("catmullRom", "nonperiodic", ARCH, 0.3),
        cubic("bspline", "periodic", "(-0.6, -0.6, 0), (0.6, -0.6, 0), (0.6, 0.6, 0), (-0.6, 0.6, 0)", 0.2),
    ]
}

/// Four control points of an arch: up the left, across the top at y 0.6,
/// down the right.
const ARCH: &str = "(-0.8, -0.6, 0), (-0.8, 0.6, 0), (0.8, 0.6, 0), (0.8, -0.6, 0)";

/// A white cubic BasisCurves of basis `basis`, wrap `wrap`, one curve
/// through the four control points `points`, constant width `width`.
fn cubic(basis: &str, wrap: &str, points: &str, width: f64) -> String {
    format!(
        "def BasisCurves \"B\"\n{{\n    uniform token type = \"cubic\"\n    uniform token basis = \"{basis}\"\n    \
         uniform token wrap = \"{wrap}\"\n    int[] curveVertexCounts = [4]\n    point3f[] points = [{points}]\n    \
         float[] widths = [{width}] (interpolation = \"constant\")\n    color3f[] primvars:displayColor = [(1, 1, 1)]\n}}"
    )
}

/// Ok when cell `k` (an [`ARCH`] curve) covers nothing below the cell's
/// middle row (the arch's legs are off the curve) and spans `columns`.
fn arch_top(k: usize, columns: std::ops::RangeInclusive<usize>) -> Result<(), String> {
    let c = covered(k);
    let (x, _) = spans(&c);
    let legs = c.iter().any(|p| p.1 >= 4);
    ensure(columns.contains(&x) && !legs, || {
        format!("cell {k}: {x} columns, legs drawn {legs}: {c:?}")
    })
}

fn shot() -> &'static Shot {
    static SHOT: OnceLock<Shot> = OnceLock::new();
    sheet::once(&SHOT, || {
        let protos = "class Xform \"Protos\"\n{\n    def Xform \"Ball\"\n    {\n        def Sphere \"Geo\"\n        {\n            double radius = 0.5\n        }\n    }\n}";
        sheet::render_sheet(
            "geom",
            &sheet::sheet(COLS, Lighting::Dome, &cells(), protos),
            8,
        )
    })
}

/// The covered pixels of cell `k`.
fn covered(k: usize) -> Vec<(usize, usize)> {
    shot().covered(COLS, k, 1, 0.03)
}

/// Ok when cell `k` covers between `lo` and `hi` pixels.
fn coverage(k: usize, lo: usize, hi: usize) -> Result<(), String> {
    let n = covered(k).len();
    ensure((lo..=hi).contains(&n), || {
        format!("cell {k} covers {n} pixels, expected {lo}..={hi}")
    })
}

/// Ok when cell `k` covers nothing.
fn empty(k: usize) -> Result<(), String> {
    coverage(k, 0, 0)
}

/// Ok when cell `k`'s covered pixels span at least `wide` columns and at
/// most `narrow` rows (`along_x`), or the other way round.
fn elongated(k: usize, along_x: bool, wide: usize, narrow: usize) -> Result<(), String> {
    let (x, y) = spans(&covered(k));
    let (long, short) = if along_x { (x, y) } else { (y, x) };
    ensure(long >= wide && short <= narrow && short > 0, || {
        format!("cell {k} spans {x} columns x {y} rows")
    })
}

/// Ok when the covered pixels of cell `k` centre on column `x` (of 8).
fn centred_at(k: usize, x: f64) -> Result<(), String> {
    let c = centroid_x(&covered(k));
    ensure((c - x).abs() < 0.75, || {
        format!("cell {k} centres on column {c:.2}, expected {x}")
    })
}

/// A catmullClark mesh of two quads side by side, the right one a hole,
/// alone on a sheet: Ok when the left is drawn and the right is not.
fn subdivided_hole() -> Result<(), String> {
    let cell = "def Mesh \"H\"\n{\n    point3f[] points = [(-0.8,-0.8,0),(0,-0.8,0),(0.8,-0.8,0),(-0.8,0.8,0),(0,0.8,0),(0.8,0.8,0)]\n    \
                int[] faceVertexCounts = [4, 4]\n    int[] faceVertexIndices = [0, 1, 4, 3, 1, 2, 5, 4]\n    int[] holeIndices = [1]\n}";
    let usda = sheet::sheet(COLS, Lighting::Dome, &[cell.to_owned()], "");
    let shot = sheet::try_render(
        "geom_subdivided_hole",
        &usda,
        (4, &["--res", "64x48"], sheet::RES),
        |_| {},
    )?;
    left_face_only(&shot.covered(COLS, 0, 1, 0.03))
}

/// Ok when the covered pixels `c` of a cell holding [`subdivided_hole`]'s
/// two quads, the right one a hole, are the left quad's alone.
fn left_face_only(c: &[(usize, usize)]) -> Result<(), String> {
    ensure(
        c.iter().any(|p| p.0 < 3) && !c.iter().any(|p| p.0 > 5),
        || format!("{c:?}"),
    )
}

pub fn rows() -> Vec<Row> {
    vec![
        row("Sphere", "radius", Honoured, "radius 0.3 and 0.8 cover 2.8 and 32 pixels' areas", || {
            coverage(0, 1, 8).and(coverage(1, 24, 44))
        }),
        row("Cube", "size", Honoured, "size 0.6 and 1.5 cover 6 and 36 pixels' areas", || {
            coverage(2, 1, 12).and(coverage(3, 30, 49))
        }),
        row("Cylinder", "radius", Honoured, "a Z-axis cylinder of radius 0.7 covers a 25-pixel disk", || coverage(5, 18, 36)),
        row("Cylinder", "height, axis", Honoured, "an X-axis cylinder 1.6 long, 0.6 wide lies along the image's rows", || elongated(4, true, 6, 4)),
        row("Cone", "radius, height, axis", Honoured, "an X-axis cone 1.6 long lies along the rows", || elongated(6, true, 6, 4)),
        row("Capsule", "radius, height, axis", Honoured, "an X-axis capsule 1.5 long with its caps lies along the rows", || elongated(7, true, 5, 4)),
        row("Plane", "width, length, axis", Honoured, "a 1.2 x 0.4 plane is drawn, along the rows", || elongated(8, true, 4, 3)),
        row("Mesh", "points, faceVertexCounts, faceVertexIndices", Honoured, "a triangle covers the lower-left half of its cell", || {
            let c = covered(9);
            let lower_left = c.iter().filter(|p| p.0 < 4 && p.1 >= 4).count();
            let upper_right = c.iter().filter(|p| p.0 >= 5 && p.1 < 3).count();
            ensure((12..=30).contains(&c.len()) && lower_left >= 12 && upper_right == 0, || {
                format!("{} covered, {lower_left} lower left, {upper_right} upper right", c.len())
            })
        }),
        row("Mesh", "holeIndices", Honoured, "the hole face (the right of two quads, subdivisionScheme none) is not drawn", || {
            left_face_only(&covered(10))
        }),
        row("Mesh", "holeIndices (subdivided)", Honoured, "the hole face of a subdivided mesh is not drawn", subdivided_hole),
        row("Mesh", "subdivisionScheme", Honoured, "a catmullClark cube is rounder (covers less) than the same cube with none", || {
            let (smooth, flat) = (covered(11).len(), covered(12).len());
            ensure(flat >= 30 && (smooth as f64) < 0.85 * flat as f64, || format!("{smooth} vs {flat} pixels"))
        }),
        row("Mesh", "orientation", Honoured,
            "a leftHanded mesh light wound clockwise seen from above (the UsdLux rows' fourth stage) faces up: the camera sees its radiance 10 (rightHanded it would face the ground, its back unseen)", || {
                let c = super::lux::left_handed_panel();
                ensure(c[1] > 9.0, || format!("{c:.3?}"))
            }),
        row("Gprim", "doubleSided", Choice("we draw the back faces of single-sided gprims, as path tracers do (a closed mesh never shows them; an open one is not cut away)"),
            "a single-sided quad facing away from the camera is drawn", || coverage(13, 30, 64)),
        row("Gprim", "primvars:displayColor", Honoured, "an unbound quad of displayColor (0.1, 0.1, 0.9) renders blue", || {
            let c = shot().cell(COLS, 14);
            ensure(c[2] > 0.5 && c[0] < 0.2 && c[1] < 0.2, || format!("{c:.3?}"))
        }),
        row("Gprim", "primvars:displayOpacity", Approximated("read as the opacity of Hydra's fallback UsdPreviewSurface (ior 1.5): below 1 a smooth refracting interface, not a see-through presence"),
            "an unbound white single-sided quad of displayOpacity 0 shows the ground at (1 - F0) / ior^2 = 0.427, the dome reflected at 0.04", || {
                sheet::near("displayOpacity 0", shot().cell(COLS, 15), [0.467, 0.04, 0.04], 0.06)
            }),
        row("Imageable", "visibility", Honoured, "an invisible sphere, and a sphere under an invisible Xform, are not drawn", || {
            empty(16).and(empty(17))
        }),
        row("Imageable", "purpose", Honoured, "guide and proxy spheres are not drawn, a render one is (a final render's purposes: default and render)", || {
            empty(18).and(empty(19)).and(coverage(20, 10, 40))
        }),
        row("Prim", "active", Honoured, "an inactive sphere is not drawn", || empty(21)),
        row("Xformable", "xformOp:translate", Honoured, "a sphere translated by 0.5 centres 2 pixels right", || centred_at(22, 6.0)),
        row("Xformable", "xformOp:scale", Honoured, "a sphere scaled (2, 1, 1) is twice as wide as tall", || elongated(23, true, 4, 3)),
        row("Xformable", "xformOp:rotateZ (rotateX/Y/XYZ...)", Honoured, "an X-axis cylinder turned 90 degrees about Z lies along the columns", || elongated(24, false, 6, 4)),
        row("Xformable", "xformOp:transform", Honoured, "a sphere moved by a matrix -0.5 in x centres 2 pixels left", || centred_at(25, 2.0)),
        row("Points", "points, widths", Honoured, "widths are diameters: 1.2 covers 18 pixels' area, 0.4 two", || {
            coverage(26, 10, 30).and(coverage(27, 1, 6))
        }),
        row("BasisCurves", "type linear, curveVertexCounts, widths", Honoured, "a linear curve 1.4 long, 0.4 wide lies along the rows", || elongated(28, true, 5, 3)),
        row("BasisCurves", "basis bezier", Honoured, "a cubic bezier arc passes its apex (y 0.4), not its off-curve control point", || {
            let c = covered(29);
            let apex = c.iter().any(|p| (3..=4).contains(&p.0) && p.1 == 2);
            let control = c.contains(&(1, 1));
            ensure(apex && !control, || format!("apex {apex}, control point {control}: {c:?}"))
        }),
        row("BasisCurves", "basis bspline", Honoured,
            "over an arch's four control points, one nonperiodic segment from (P0 + 4 P1 + P2) / 6 to (P1 + 4 P2 + P3) / 6: a short stroke over the top (x -0.53..0.53), no legs", || arch_top(42, 4..=6)),
        row("BasisCurves", "basis catmullRom", Honoured,
            "over an arch's four control points, one nonperiodic segment from P1 to P2: across the whole top (x -0.8..0.8), no legs", || arch_top(43, 7..=8)),
        row("BasisCurves", "wrap periodic", Honoured,
            "a periodic bspline over a square's corners closes into a loop around the cell's middle (four segments), the middle empty", || {
                let c = covered(44);
                let sides = [c.iter().any(|p| p.0 <= 2), c.iter().any(|p| p.0 >= 5), c.iter().any(|p| p.1 <= 2), c.iter().any(|p| p.1 >= 5)];
                let middle = c.iter().any(|p| (3..=4).contains(&p.0) && (3..=4).contains(&p.1));
                ensure(sides.iter().all(|&s| s) && !middle, || format!("left, right, top, bottom {sides:?}, middle {middle}: {c:?}"))
            }),
        row("PointInstancer", "prototypes, protoIndices, positions", Honoured, "two instances at x -0.5 and 0.5, nothing between", || {
            let c = covered(30);
            let (left, right, mid) = (c.iter().any(|p| p.0 <= 2), c.iter().any(|p| p.0 >= 5), c.iter().any(|p| (3..=4).contains(&p.0)));
            ensure(left && right && !mid, || format!("{c:?}"))
        }),
        row("PointInstancer", "scales", Honoured, "an instance scaled 3 covers a 28-pixel disk", || coverage(31, 16, 44)),
        row("PointInstancer", "ids, invisibleIds", Honoured, "of two instances, the one whose id is invisible is not drawn", || {
            let c = covered(32);
            ensure(!c.is_empty() && c.iter().all(|p| p.0 >= 4), || format!("{c:?}"))
        }),
        row("PointInstancer", "prototypes (inactive)", Honoured, "an instance of an inactive prototype is not drawn", || empty(33)),
        row("PointInstancer", "orientations", Honoured, "an X-axis cylinder prototype turned 90 degrees about Z lies along the columns", || elongated(35, false, 6, 4)),
        row("NurbsCurves", "points, order, knots", Approximated("drawn as the control polygon (a linear curve)"),
            "drawn, with a warning naming the prim", || {
                shot().warned(&["/Sheet/C36/N", "control polygon"]).and(coverage(36, 4, 64))
            }),
        row("Cylinder_1", "radiusTop, radiusBottom", Honoured,
            "a Z-axis cone frustum of radii 0.1 and 0.6 seen from above covers its bottom's 18-pixel disk", || coverage(37, 12, 30)),
        row("Capsule_1", "radiusTop, radiusBottom", Honoured,
            "an X-axis capsule of radii 0.2 and 0.3 and height 1 lies along the rows", || elongated(38, true, 5, 4)),
        row("HermiteCurves, NurbsPatch, TetMesh", "(the prim)", Warned, "not rendered: a warning names each prim", || {
            let s = shot();
            s.warned(&["/Sheet/C39/H", "not rendered"])
                .and(s.warned(&["/Sheet/C40/P", "not rendered"]))
                .and(s.warned(&["/Sheet/C41/T", "not rendered"]))
        }),
        row("Prim", "instanceable", Honoured, "a native instance of a referenced ball is drawn (each prototype stored once)", || coverage(34, 8, 24)),
    ]
}

#[test]
fn rows_hold() {
    super::check_rows(&rows());
}
