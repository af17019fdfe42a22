//! Subdivision surfaces end to end: USD cages through the exporter's
//! `subdivision` record and OpenSubdiv at load (`src/subdivision/`, whose unit
//! tests check the Catmull-Clark rules, limit corners and sharp creases on
//! the cube), the bad inputs of issue 22 (a warning each, never a silent
//! drop) and the production assets' refined triangle counts.

use crate::common;
use std::path::{Path, PathBuf};

use cirrus::geometry::{Geometry, Ray};
use cirrus::scene::{Refinement, Scene};
use glam::{Vec3, Vec3A};

use crate::common::{asset, cirrus_ok, scratch};

/// The unit cube [0,1]^3 as six quads, counter-clockwise from outside.
const CUBE: &str = r#"int[] faceVertexCounts = [4, 4, 4, 4, 4, 4]
        int[] faceVertexIndices = [0, 3, 2, 1, 4, 5, 6, 7, 0, 1, 5, 4, 1, 2, 6, 5, 2, 3, 7, 6, 3, 0, 4, 7]
        point3f[] points = [(0,0,0), (1,0,0), (1,1,0), (0,1,0), (0,0,1), (1,0,1), (1,1,1), (0,1,1)]"#;

/// `body` (prims) as a stage in `dir`, exported; returns the scene folder.
fn export_stage(dir: &Path, body: &str) -> PathBuf {
    common::export_usda(dir, &format!("#usda 1.0\n{body}\n"))
}

fn warnings(scene: &Scene) -> String {
    scene.manifest.warnings.join("\n")
}

/// An unauthored scheme is Catmull-Clark (USD's default): the cube refines
/// to 8 x 4^(L-1) triangles per quad at level L; a mesh's own
/// `primvars:cirrus:subdivisionLevel` wins over the loader's level.
#[test]
fn cages_refine_at_their_level() {
    let dir = scratch("subdivision_levels");
    let out = export_stage(
        &dir,
        &format!(
            "def Mesh \"Cube\"\n{{\n {CUBE}\n}}\ndef Mesh \"Own\"\n{{\n {CUBE}\n int primvars:cirrus:subdivisionLevel = 3\n}}"
        ),
    );
    let scene = Scene::load_with(&out, Refinement::Level(1)).unwrap();
    let counts: Vec<u64> = scene
        .manifest
        .meshes
        .iter()
        .map(|m| m.triangles.count)
        .collect();
    assert_eq!(counts, [48, 6 * 8 * 16]);
    assert_eq!((scene.subdivision.cages, scene.subdivision.refined), (2, 2));
    let cages = Scene::load_with(&out, Refinement::Cages).unwrap();
    assert_eq!(cages.manifest.meshes[0].triangles.count, 12);
    assert!(cages.manifest.meshes[0].normals.is_none());
    assert!(scene.manifest.meshes[0].normals.is_some(), "limit normals");
}

/// Cages OpenSubdiv refuses (Loop over quads; a face with two vertices)
/// render as their polygons with one warning naming the mesh.
#[test]
fn refused_cages_render_as_polygons_with_a_warning() {
    let dir = scratch("subdivision_refused");
    let out = export_stage(
        &dir,
        &format!(
            "def Mesh \"LoopQuads\"\n{{\n {CUBE}\n uniform token subdivisionScheme = \"loop\"\n}}\n\
             def Mesh \"Degenerate\"\n{{\n int[] faceVertexCounts = [3, 2]\n int[] faceVertexIndices = [0, 1, 2, 2, 3]\n \
             point3f[] points = [(0,0,0), (1,0,0), (1,1,0), (0,1,0)]\n}}"
        ),
    );
    let scene = Scene::load(&out).unwrap();
    let s = &scene.subdivision;
    assert_eq!((s.cages, s.refined), (2, 0), "{s:?}");
    for (mesh, name) in scene
        .manifest
        .meshes
        .iter()
        .zip(["/LoopQuads", "/Degenerate"])
    {
        let named: Vec<_> = s.warnings.iter().filter(|w| w.contains(name)).collect();
        assert_eq!(named.len(), 1, "{:?}", s.warnings);
        assert!(named[0].contains("rendered as its polygons"), "{named:?}");
        assert!(mesh.normals.is_none());
    }
    assert_eq!(scene.manifest.meshes[0].triangles.count, 12);
}

/// Crease arrays whose lengths disagree are ignored with a warning naming
/// prim and attribute; unsupported or unknown tags are warned about too.
#[test]
fn bad_tags_are_warned_about_by_prim_and_attribute() {
    let dir = scratch("subdivision_bad_tags");
    let out = export_stage(
        &dir,
        &format!(
            "def Mesh \"Creased\"\n{{\n {CUBE}\n int[] creaseIndices = [0, 1, 2]\n int[] creaseLengths = [3]\n \
             float[] creaseSharpnesses = [1, 2, 3]\n}}\n\
             def Mesh \"Tagged\"\n{{\n {CUBE}\n uniform token interpolateBoundary = \"sometimes\"\n \
             normal3f[] normals = [(0,0,1), (0,0,1), (0,0,1), (0,0,1), (0,0,1), (0,0,1), (0,0,1), (0,0,1)] (interpolation = \"vertex\")\n}}"
        ),
    );
    let scene = Scene::load(&out).unwrap();
    let text = warnings(&scene);
    for want in [
        "mesh /Creased: creaseSharpnesses has 3 values for 1 creases (2 edges); creases ignored",
        "mesh /Tagged: interpolateBoundary 'sometimes' is not a USD value",
        "mesh /Tagged: normals are ignored on a subdivision surface",
    ] {
        assert!(text.contains(want), "no '{want}' in {text}");
    }
    assert_eq!(scene.subdivision.refined, 2);
}

/// `--subdiv-level` above the bound is refused before rendering, with the
/// triangle count it would make (8 x 4^8 per quad, 6 quads).
#[test]
fn level_above_the_bound_is_refused_with_the_estimate() {
    let dir = scratch("subdivision_bound");
    let out = export_stage(&dir, &format!("def Mesh \"Cube\"\n{{\n {CUBE}\n}}"));
    let result = std::process::Command::new(env!("CARGO_BIN_EXE_cirrus"))
        .args(["render".as_ref(), out.as_os_str(), "-o".as_ref()])
        .arg(dir.join("x.exr"))
        .args(["--subdiv-level", "9", "--spp", "1", "--res", "4x4"])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&result.stderr);
    assert!(!result.status.success());
    assert!(
        stderr.contains("subdivision level 9 (--subdiv-level) is above the safe bound 8: it would make 3145728 triangles"),
        "{stderr}"
    );
    assert!(!dir.join("x.exr").exists());
}

/// A flat grid of `n` x `n` unit quads, as `Mesh` attributes.
fn grid(n: u32) -> String {
    let points: Vec<String> = (0..=n)
        .flat_map(|y| (0..=n).map(move |x| format!("({x},{y},0)")))
        .collect();
    let quads: Vec<String> = (0..n)
        .flat_map(|y| (0..n).map(move |x| (x, y)))
        .map(|(x, y)| {
            let v = y * (n + 1) + x;
            format!("{}, {}, {}, {}", v, v + 1, v + n + 2, v + n + 1)
        })
        .collect();
    format!(
        "int[] faceVertexCounts = [{}]\n int[] faceVertexIndices = [{}]\n point3f[] points = [{}]",
        vec!["4"; (n * n) as usize].join(", "),
        quads.join(", "),
        points.join(", ")
    )
}

/// The memory preflight refuses refinement that would not fit in
/// `--memory-limit` before refining anything (a 1024-quad grid at
/// `--subdiv-level 8` would make 134 million triangles and take minutes and tens of
/// GiB: the refusal comes from the counts, at once), naming the heaviest
/// meshes with their refined triangle counts and the level that fits.
#[test]
fn refinement_over_the_memory_limit_is_refused_before_refining() {
    let dir = scratch("subdivision_memory");
    let out = export_stage(
        &dir,
        &format!(
            "def Mesh \"Cube\"\n{{\n {CUBE}\n int primvars:cirrus:subdivisionLevel = 8\n}}\ndef Mesh \"Grid\"\n{{\n {}\n}}",
            grid(32)
        ),
    );
    let render = |extra: &[&str]| {
        std::process::Command::new(env!("CARGO_BIN_EXE_cirrus"))
            .args(["render".as_ref(), out.as_os_str(), "-o".as_ref()])
            .arg(dir.join("x.exr"))
            .args(["--spp", "1", "--res", "4x4", "--memory-limit", "300M"])
            .args(extra)
            .output()
            .unwrap()
    };
    let result = render(&["--subdiv-level", "8"]);
    let stderr = String::from_utf8_lossy(&result.stderr);
    assert!(!result.status.success(), "{stderr}");
    for part in [
        "refining the subdivision surfaces needs about",
        "but only 300.0 MiB is available (--memory-limit)",
        // 8 x 4^7 triangles per quad.
        "heaviest: /Grid 134217728 triangles (level 8), /Cube 786432 triangles (its own level 8)",
        "--subdiv-level 3 would fit",
        "with primvars:cirrus:subdivisionLevel lowered to 3 on /Cube",
    ] {
        assert!(stderr.contains(part), "{part:?} not in {stderr}");
    }
    assert!(!dir.join("x.exr").exists());
    // The planned counts are refinement's own, and its array bytes a bound
    // within 1.5x of what refinement stores.
    let cages = Scene::load_with(&out, Refinement::Cages).unwrap();
    let planned = cages.refinement_plan(Refinement::Level(3), None).unwrap();
    let refined = Scene::load_with(&out, Refinement::Level(3)).unwrap();
    let mesh_bytes = |scene: &Scene| scene.array_bytes().meshes;
    let added = mesh_bytes(&refined) - mesh_bytes(&cages);
    let bound: u64 = planned.iter().map(|p| p.bytes).sum();
    assert!(
        bound >= added && bound <= added * 3 / 2,
        "{bound} for {added}"
    );
    for p in &planned {
        let mesh = &refined.manifest.meshes[p.mesh];
        assert_eq!(p.triangles, mesh.triangles.count, "{}", p.path);
    }
}

/// A cage placed many times (a PointInstancer) is refined once and shared.
#[test]
fn instanced_cages_are_refined_once() {
    let dir = scratch("subdivision_instanced");
    let out = export_stage(
        &dir,
        &format!(
            "def PointInstancer \"Many\"\n{{\n point3f[] positions = [(0,0,0), (2,0,0), (4,0,0), (6,0,0)]\n \
             int[] protoIndices = [0, 0, 0, 0]\n rel prototypes = </Many/Protos/Cube>\n \
             def Scope \"Protos\"\n {{\n  def Mesh \"Cube\"\n  {{\n {CUBE}\n  }}\n }}\n}}"
        ),
    );
    let scene = Scene::load(&out).unwrap();
    assert_eq!(scene.manifest.instances.count, 4);
    assert_eq!((scene.subdivision.cages, scene.subdivision.refined), (1, 1));
    assert_eq!(scene.manifest.meshes[0].triangles.count, 6 * 8 * 4);
}

/// Rays straight down -z over a grid covering [lo, hi]^2: the fraction that
/// hit, i.e. the silhouette's area over the grid's.
fn silhouette(geometry: &Geometry, lo: f32, hi: f32, n: usize) -> f64 {
    let mut hits = 0;
    for i in 0..n {
        for j in 0..n {
            let at = |k: usize| lo + (hi - lo) * (k as f32 + 0.5) / n as f32;
            let ray = Ray::new(
                Vec3A::new(at(i), at(j), 10.0),
                Vec3A::NEG_Z,
                0.0,
                f32::INFINITY,
            );
            hits += usize::from(geometry.intersect(&ray, 0.0).is_some());
        }
    }
    hits as f64 / (n * n) as f64
}

/// The silhouette of the refined cube at level 4 is within 0.5% of level 6's
/// (the refined surface converges to the limit), and both are far from the
/// cage's (the unit square): the cube really is rounded.
#[test]
fn silhouette_converges_with_the_level() {
    let dir = scratch("subdivision_silhouette");
    let out = export_stage(&dir, &format!("def Mesh \"Cube\"\n{{\n {CUBE}\n}}"));
    let area = |refinement| {
        let scene = Scene::load_with(&out, refinement).unwrap();
        silhouette(&Geometry::build(&scene, false), -0.1, 1.1, 400)
    };
    let (level4, level6) = (area(Refinement::Level(4)), area(Refinement::Level(6)));
    assert!(
        (level4 - level6).abs() / level6 < 0.005,
        "{level4} vs {level6}"
    );
    let cage = area(Refinement::Cages);
    assert!(level6 < 0.9 * cage, "{level6} vs cage {cage}");
}

/// A UV-sphere cage (quads, triangle fans at the poles) refines to a smooth
/// surface: at every hit the shading normal (the limit normal) points along
/// the position from the centre within 2 degrees, tighter than the facets do.
#[test]
fn refined_sphere_shades_smooth() {
    let (rings, segments) = (12, 24);
    let mut points = vec![[0.0, 0.0, 1.0]];
    for r in 1..rings {
        let theta = std::f32::consts::PI * r as f32 / rings as f32;
        for s in 0..segments {
            let phi = std::f32::consts::TAU * s as f32 / segments as f32;
            points.push([
                theta.sin() * phi.cos(),
                theta.sin() * phi.sin(),
                theta.cos(),
            ]);
        }
    }
    points.push([0.0, 0.0, -1.0]);
    let ring = |r: usize, s: usize| 1 + (r - 1) * segments + s % segments;
    let (mut counts, mut indices) = (Vec::new(), Vec::new());
    for s in 0..segments {
        counts.push(3);
        indices.extend([0, ring(1, s), ring(1, s + 1)]);
        counts.push(3);
        indices.extend([points.len() - 1, ring(rings - 1, s + 1), ring(rings - 1, s)]);
    }
    for r in 1..rings - 1 {
        for s in 0..segments {
            counts.push(4);
            indices.extend([
                ring(r, s),
                ring(r + 1, s),
                ring(r + 1, s + 1),
                ring(r, s + 1),
            ]);
        }
    }
    let list = |v: &[usize]| {
        v.iter()
            .map(|x| x.to_string())
            .collect::<Vec<_>>()
            .join(",")
    };
    let pts: Vec<String> = points
        .iter()
        .map(|p| format!("({},{},{})", p[0], p[1], p[2]))
        .collect();
    let dir = scratch("subdivision_sphere");
    let out = export_stage(
        &dir,
        &format!(
            "def Mesh \"Ball\"\n{{\n int[] faceVertexCounts = [{}]\n int[] faceVertexIndices = [{}]\n point3f[] points = [{}]\n}}",
            list(&counts),
            list(&indices),
            pts.join(",")
        ),
    );
    let scene = Scene::load_with(&out, Refinement::Level(2)).unwrap();
    let geometry = Geometry::build(&scene, false);
    let (mut worst_ns, mut worst_ng) = (0.0f32, 0.0f32);
    for i in 0..40 {
        for j in 0..40 {
            let at = |k: usize| -0.9 + 1.8 * (k as f32 + 0.5) / 40.0;
            let ray = Ray::new(
                Vec3A::new(at(i), at(j), 5.0),
                Vec3A::NEG_Z,
                0.0,
                f32::INFINITY,
            );
            let Some(hit) = geometry.intersect(&ray, 0.0) else {
                continue;
            };
            let sp = geometry.surface_point(&hit);
            let radial = sp.p.normalize();
            let angle = |n: Vec3| n.dot(radial).clamp(-1.0, 1.0).acos().to_degrees();
            worst_ns = worst_ns.max(angle(sp.ns));
            worst_ng = worst_ng.max(angle(sp.ng));
        }
    }
    assert!(
        worst_ns < 2.0,
        "shading normal {worst_ns} degrees off radial"
    );
    assert!(
        worst_ns < worst_ng,
        "shading {worst_ns} vs facets {worst_ng}"
    );
}

/// The production assets export their cages and `cirrus info` reports the
/// refined triangles: every Teapot and chess-set cage refines.
#[test]
fn production_assets_report_refined_triangles() {
    needs_shared!();
    let dir = scratch("subdivision_assets");
    for (name, rel) in [
        ("teapot", "usd-wg/full_assets/Teapot/Teapot.usd"),
        ("chess", "usd-wg/full_assets/OpenChessSet/chess_set.usda"),
    ] {
        let out = dir.join(name);
        let input = asset(rel);
        cirrus_ok(&[
            "export".as_ref(),
            input.as_os_str(),
            "-o".as_ref(),
            out.as_os_str(),
        ]);
        let info = cirrus_ok(&["info".as_ref(), out.as_os_str()]);
        let line = info
            .lines()
            .find(|l| l.trim_start().starts_with("subdivided"))
            .unwrap();
        // "subdivided   R of C cage(s) refined: T0 cage triangles -> T triangles (S s)"
        let words: Vec<&str> = line.split_whitespace().collect();
        let number = |i: usize| words[i].parse::<u64>().unwrap();
        let (refined, cages) = (number(1), number(3));
        let (cage_triangles, triangles) = (number(6), number(10));
        assert!(cages > 0 && refined == cages, "{name}: {line}");
        assert!(triangles > 4 * cage_triangles, "{name}: {line}");
        let counted = info.lines().find(|l| l.contains("unique")).unwrap();
        assert!(
            counted.contains(&format!("{triangles} unique")),
            "{counted}"
        );
    }
}

/// Instance memory budget, bytes per instance beyond its prototype: what
/// `cirrus bench instances` holds a million instances to (250 MB).
const INSTANCE_BUDGET: u64 = 250;

/// 1000 instances of the refined Teapot asset (a PointInstancer over a
/// reference to it) refine its cages once and cost, in the memory estimate,
/// no more than the instance budget each beyond one Teapot.
#[test]
fn a_thousand_instanced_teapots_fit_the_instance_budget() {
    needs_shared!();
    let teapot = asset("usd-wg/full_assets/Teapot/Teapot.usd");
    let estimate = |count: usize| {
        let dir = scratch(&format!("subdivision_teapots_{count}"));
        let positions: Vec<String> = (0..count)
            .map(|i| format!("({}, 0, {})", 40 * (i % 32), 40 * (i / 32)))
            .collect();
        let out = export_stage(
            &dir,
            &format!(
                "def PointInstancer \"Teapots\"\n{{\n point3f[] positions = [{}]\n \
                 int[] protoIndices = [{}]\n rel prototypes = </Teapots/Protos/Teapot>\n \
                 def Scope \"Protos\"\n {{\n  def Xform \"Teapot\" (references = @{}@) {{}}\n }}\n}}",
                positions.join(", "),
                vec!["0"; count].join(", "),
                teapot.display()
            ),
        );
        let scene = Scene::load(&out).unwrap();
        assert_eq!(scene.manifest.instances.count, count as u64);
        assert!(scene.subdivision.refined > 0, "the Teapot did not refine");
        let one_copy = scene.manifest.meshes.len();
        let memory =
            cirrus::memory::estimate(&scene, glam::UVec2::new(64, 64), &Default::default());
        (memory.unwrap(), scene.subdivision.refined, one_copy)
    };
    let (one, refined_one, meshes_one) = estimate(1);
    let (many, refined_many, meshes_many) = estimate(1000);
    assert_eq!(
        (refined_many, meshes_many),
        (refined_one, meshes_one),
        "1000 instances refined or stored the Teapot more than once"
    );
    let per_instance = (many.scene + many.geometry - one.scene - one.geometry) / 999;
    eprintln!(
        "Teapot x1: scene {} + geometry {} bytes; x1000: {} bytes per added instance",
        one.scene, one.geometry, per_instance
    );
    assert!(
        per_instance <= INSTANCE_BUDGET,
        "{per_instance} bytes per instance, over the {INSTANCE_BUDGET}-byte budget"
    );
}
