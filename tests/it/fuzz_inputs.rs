//! Property tests over malformed inputs, the bounded always-run side of
//! fuzzing (the `cargo fuzz` targets in `fuzz/` run the same checks for
//! longer): mutated scenes make `Scene::load` return `Ok` or `Err`, never
//! panic, and a scene it accepts is safe to view; arbitrary trees make
//! `SparseGrid::build` return `Ok` or `Err`, and a grid it accepts returns
//! every value as given, with trilinear lookups inside the stored range.
//! Seeds are fixed, so every run checks the same cases.

use crate::common;
use std::cell::Cell;
use std::path::{Path, PathBuf};

use cirrus::sampling::Pcg32;
use cirrus::scene::{Scene, BLOB_FILE, MANIFEST_FILE, NO_MATERIAL};
use cirrus::volumes::grid::{GridTransform, SparseGrid, Tile};
use glam::{DAffine3, IVec3, Vec3};
use proptest::prelude::*;
use proptest::sample::Index;
use proptest::test_runner::{Config, RngSeed, TestRunner};
use serde_json::{json, Value};

/// The runner every property here uses: fixed seed, no failure files.
fn runner(cases: u32) -> TestRunner {
    TestRunner::new(Config {
        cases,
        rng_seed: RngSeed::Fixed(0x00f0_2217),
        failure_persistence: None,
        ..Config::default()
    })
}

/// How many cases a property accepted and refused (the runner takes an `Fn`).
#[derive(Default)]
struct Tally {
    ok: Cell<u32>,
    err: Cell<u32>,
}

impl Tally {
    fn note<T, E>(&self, result: &Result<T, E>) {
        let count = if result.is_ok() { &self.ok } else { &self.err };
        count.set(count.get() + 1);
    }
}

// ---- scene loader ----------------------------------------------------------

/// The scene-loader seeds shared with `cargo fuzz`: exported scenes packed as
/// `scene.json`, one NUL byte, `scene.bin` (see fuzz/README.md).
fn seed_scenes() -> Vec<(PathBuf, Value, Vec<u8>)> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("fuzz/seeds/scene_loader");
    let mut seeds: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|entry| {
            let path = entry.unwrap().path();
            let packed = std::fs::read(&path).unwrap();
            let nul = packed.iter().position(|&b| b == 0).unwrap();
            let manifest = serde_json::from_slice(&packed[..nul]).unwrap();
            (path, manifest, packed[nul + 1..].to_vec())
        })
        .collect();
    seeds.sort_by(|a, b| a.0.cmp(&b.0));
    assert!(seeds.len() >= 3, "seeds missing in {}", dir.display());
    seeds
}

/// One change to a valid scene.
#[derive(Clone, Debug)]
enum Mutation {
    /// Replace a JSON leaf (number, string, bool, null) with another value.
    SetLeaf(Index, Value),
    /// Remove a key of a JSON object.
    RemoveKey(Index),
    /// Append a copy of a JSON array's first element (one more mesh, light...).
    DuplicateElement(Index),
    /// Overwrite one 32-bit word of `scene.bin`.
    BlobWord(Index, u32),
    /// Cut `scene.bin` to this fraction of its length.
    TruncateBlob(f64),
    /// Overwrite one byte of the manifest text (mostly not JSON any more).
    TextByte(Index, u8),
}

/// Values that sit on the edges validation must handle.
fn any_json() -> impl Strategy<Value = Value> {
    prop_oneof![
        prop::sample::select(vec![
            json!(0),
            json!(1),
            json!(-1),
            json!(16),
            json!(u32::MAX),
            json!(u32::MAX as u64 + 1),
            json!(u64::MAX),
            json!(i64::MIN),
            json!(1e39),
            json!(-1e39),
            json!(1e300),
            json!(-0.0),
            json!(0.5),
            json!(null),
            json!(true),
            json!(""),
            json!("f32"),
            json!("u32"),
            json!([]),
            json!({}),
            json!([0, 0, 0]),
        ]),
        (0u64..4096).prop_map(|n| json!(n)),
        any::<f64>().prop_map(|x| json!(x)),
        "[a-z]{0,6}".prop_map(|s| json!(s)),
    ]
}

fn any_word() -> impl Strategy<Value = u32> {
    prop_oneof![
        prop::sample::select(vec![
            0,
            1,
            u32::MAX,
            f32::NAN.to_bits(),
            f32::INFINITY.to_bits(),
            f32::NEG_INFINITY.to_bits(),
            f32::MAX.to_bits(),
            NO_MATERIAL - 1,
        ]),
        0u32..64,
        any::<u32>(),
    ]
}

fn any_mutation() -> impl Strategy<Value = Mutation> {
    prop_oneof![
        4 => (any::<Index>(), any_json()).prop_map(|(i, v)| Mutation::SetLeaf(i, v)),
        1 => any::<Index>().prop_map(Mutation::RemoveKey),
        1 => any::<Index>().prop_map(Mutation::DuplicateElement),
        3 => (any::<Index>(), any_word()).prop_map(|(i, w)| Mutation::BlobWord(i, w)),
        1 => (0.0..1.0f64).prop_map(Mutation::TruncateBlob),
        1 => (any::<Index>(), any::<u8>()).prop_map(|(i, b)| Mutation::TextByte(i, b)),
    ]
}

/// JSON pointers of every node of `value` for which `keep` holds, depth first.
fn pointers(value: &Value, keep: fn(&Value) -> bool) -> Vec<String> {
    fn walk(v: &Value, at: String, keep: fn(&Value) -> bool, out: &mut Vec<String>) {
        if keep(v) {
            out.push(at.clone());
        }
        match v {
            Value::Object(map) => {
                for (k, child) in map {
                    walk(child, format!("{at}/{k}"), keep, out);
                }
            }
            Value::Array(items) => {
                for (i, child) in items.iter().enumerate() {
                    walk(child, format!("{at}/{i}"), keep, out);
                }
            }
            _ => {}
        }
    }
    let mut out = Vec::new();
    walk(value, String::new(), keep, &mut out);
    out
}

/// Applies `mutations` to a scene and returns the manifest text and blob.
fn mutate(manifest: &Value, blob: &[u8], mutations: &[Mutation]) -> (Vec<u8>, Vec<u8>) {
    let (mut json, mut blob) = (manifest.clone(), blob.to_vec());
    let mut text_edits = Vec::new();
    for m in mutations {
        match m {
            Mutation::SetLeaf(i, v) => {
                let leaves = pointers(&json, |v| !v.is_object() && !v.is_array());
                *json.pointer_mut(i.get::<String>(&leaves)).unwrap() = v.clone();
            }
            Mutation::RemoveKey(i) => {
                // Pointers to the members of objects: all but the root and array elements.
                let members: Vec<String> = pointers(&json, |_| true)
                    .into_iter()
                    .filter(|p| {
                        p.rsplit_once('/')
                            .is_some_and(|(_, k)| k.parse::<usize>().is_err())
                    })
                    .collect();
                let at = i.get(members.as_slice());
                let (parent, key) = at.rsplit_once('/').unwrap();
                json.pointer_mut(parent)
                    .and_then(Value::as_object_mut)
                    .unwrap()
                    .remove(key);
            }
            Mutation::DuplicateElement(i) => {
                let arrays = pointers(&json, |v| v.as_array().is_some_and(|a| !a.is_empty()));
                if !arrays.is_empty() {
                    let items = json.pointer_mut(i.get::<String>(&arrays)).unwrap();
                    let items = items.as_array_mut().unwrap();
                    items.push(items[0].clone());
                }
            }
            Mutation::BlobWord(i, word) if blob.len() >= 4 => {
                let at = 4 * i.index(blob.len() / 4);
                blob[at..at + 4].copy_from_slice(&word.to_le_bytes());
            }
            Mutation::BlobWord(..) => {}
            Mutation::TruncateBlob(f) => blob.truncate((blob.len() as f64 * f) as usize),
            Mutation::TextByte(i, b) => text_edits.push((*i, *b)),
        }
    }
    let mut text = json.to_string().into_bytes();
    for (i, b) in text_edits {
        let at = i.index(text.len());
        text[at] = b;
    }
    (text, blob)
}

/// Loads the scene in `dir`; when accepted, views every array, checks the
/// indices downstream code relies on without re-checking, and builds its BVHs.
fn load_and_view(dir: &Path) -> Result<(), String> {
    let scene = Scene::load(dir).map_err(|e| e.to_string())?;
    let m = &scene.manifest;
    scene.array_bytes();
    for mesh in &m.meshes {
        let points = scene.view(&mesh.points).len();
        let triangles = scene.view(&mesh.triangles);
        assert!(triangles.iter().flatten().all(|&i| (i as usize) < points));
        for per_point in [
            mesh.normals.as_ref().map(|a| scene.view(a).len()),
            mesh.uvs.as_ref().map(|a| scene.view(a).len()),
        ] {
            assert!(per_point.is_none_or(|n| n == points));
        }
        let materials = scene.view(&mesh.triangle_materials);
        assert_eq!(materials.len(), triangles.len());
        assert!(materials
            .iter()
            .all(|&i| i == NO_MATERIAL || (i as usize) < m.materials.len()));
    }
    let n = m.instances.count as usize;
    let prototypes = scene.view(&m.instances.prototype);
    assert_eq!(prototypes.len(), n);
    assert!(prototypes
        .iter()
        .all(|&p| (p as usize) < m.prototypes.len()));
    assert_eq!(scene.view(&m.instances.transform).len(), n);
    assert_eq!(scene.view(&m.instances.source_index).len(), n);
    // What the loader accepts, the BVH builder takes without panicking.
    cirrus::geometry::Geometry::build(&scene, true);
    Ok(())
}

fn write_scene(dir: &Path, manifest: &[u8], blob: &[u8]) {
    std::fs::write(dir.join(MANIFEST_FILE), manifest).unwrap();
    std::fs::write(dir.join(BLOB_FILE), blob).unwrap();
}

#[test]
fn every_seed_scene_loads() {
    let dir = common::scratch("fuzz_inputs_seeds");
    for (path, manifest, blob) in seed_scenes() {
        write_scene(&dir, manifest.to_string().as_bytes(), &blob);
        if let Err(e) = load_and_view(&dir) {
            panic!("seed {} no longer loads: {e}", path.display());
        }
    }
}

#[test]
fn mutated_scenes_load_or_fail_cleanly() {
    let dir = common::scratch("fuzz_inputs_scenes");
    let seeds = seed_scenes();
    let strategy = (any::<Index>(), prop::collection::vec(any_mutation(), 1..4));
    let tally = Tally::default();
    runner(3000)
        .run(&strategy, |(seed, mutations)| {
            let (_, manifest, blob) = seed.get(&seeds);
            let (text, blob) = mutate(manifest, blob, &mutations);
            write_scene(&dir, &text, &blob);
            tally.note(&load_and_view(&dir));
            Ok(())
        })
        .unwrap();
    // Both outcomes occur: the mutations neither always miss nor always break.
    let (accepted, refused) = (tally.ok.get(), tally.err.get());
    assert!(
        accepted > 100 && refused > 1000,
        "{accepted} accepted, {refused} refused"
    );
}

// ---- sparse grid builder ---------------------------------------------------

/// A tree as `SparseGrid::build` takes it.
#[derive(Clone, Debug)]
struct Tree {
    background: f32,
    leaf_origins: Vec<IVec3>,
    leaf_values: Vec<f32>,
    tiles: Vec<Tile>,
}

/// Block coordinates near the origin (neighbours and overlaps are common),
/// or anywhere in the i32 range, its ends included.
fn any_origin(edge: i32) -> impl Strategy<Value = IVec3> {
    let edge_coord = prop::sample::select(vec![
        i32::MIN,
        i32::MIN + 8,
        -(1 << 30),
        1 << 30,
        i32::MAX - 4095,
        i32::MAX - 7,
        i32::MAX,
    ]);
    prop_oneof![
        8 => prop::array::uniform3(-3i32..3).prop_map(move |b| IVec3::from_array(b) * edge),
        1 => prop::array::uniform3(edge_coord).prop_map(IVec3::from_array),
        1 => prop::array::uniform3(any::<i32>()).prop_map(IVec3::from_array),
    ]
}

/// Mostly moderate finite values; sometimes NaN, infinities or extremes.
fn any_value() -> impl Strategy<Value = f32> {
    prop_oneof![
        20 => -100.0f32..100.0,
        1 => prop::sample::select(vec![
            f32::NAN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::MAX,
            -f32::MAX,
            0.0,
        ]),
    ]
}

fn any_tile() -> impl Strategy<Value = Tile> {
    let edge = prop_oneof![
        8 => prop::sample::select(vec![8u32, 128, 4096]),
        1 => any::<u32>(),
    ];
    (edge, any_value(), any::<bool>()).prop_flat_map(|(edge, value, active)| {
        any_origin(edge.clamp(1, 4096) as i32).prop_map(move |origin| Tile {
            origin,
            edge,
            value,
            active,
        })
    })
}

fn any_tree() -> impl Strategy<Value = Tree> {
    let leaf = (
        any_origin(8),
        any::<u64>(),
        prop::collection::vec((0usize..512, any_value()), 0..3),
    );
    (
        any_value(),
        prop::collection::vec(leaf, 0..6),
        prop::collection::vec(any_tile(), 0..4),
    )
        .prop_map(|(background, leaves, tiles)| {
            let mut leaf_values = Vec::new();
            for (_, seed, spikes) in &leaves {
                let mut rng = Pcg32::new(*seed, 1);
                let mut values: Vec<f32> = (0..512).map(|_| 10.0 * rng.next_f32() - 5.0).collect();
                for &(at, v) in spikes {
                    values[at] = v;
                }
                leaf_values.extend(values);
            }
            Tree {
                background,
                leaf_origins: leaves.iter().map(|l| l.0).collect(),
                leaf_values,
                tiles,
            }
        })
}

fn identity() -> GridTransform {
    GridTransform::new(DAffine3::IDENTITY).unwrap()
}

/// Same value, NaN equal to NaN.
fn same(a: f32, b: f32) -> bool {
    a == b || (a.is_nan() && b.is_nan())
}

/// Checks an accepted grid against the tree it was built from.
fn check_grid(tree: &Tree, grid: &SparseGrid, points: &[Vec3]) {
    let voxels =
        |origin: IVec3| (0..512).map(move |n| origin + IVec3::new(n / 64, n / 8 % 8, n % 8));
    let stats = grid.stats();
    let lo = stats.min_value.min(tree.background);
    let hi = stats.max_value.max(tree.background);
    // Finite values (background included) whose differences are finite: every
    // lerp is then a convex combination.
    let bounded =
        stats.non_finite_count == 0 && tree.background.is_finite() && (hi - lo).is_finite();
    for (leaf, &origin) in tree.leaf_origins.iter().enumerate() {
        for (ijk, &v) in voxels(origin).zip(&tree.leaf_values[leaf * 512..]) {
            assert!(
                same(grid.value(ijk), v),
                "voxel {ijk}: {} vs {v}",
                grid.value(ijk)
            );
            if bounded && ijk.abs().max_element() < 1 << 24 {
                // At an index point the trilinear lookup is that voxel's value.
                assert_eq!(
                    grid.trilinear_index(ijk.as_vec3()),
                    v,
                    "trilinear at voxel {ijk}"
                );
            }
        }
    }
    for t in &tree.tiles {
        let far = t.origin + IVec3::splat(t.edge as i32 - 1);
        assert!(
            same(grid.value(t.origin), t.value) && same(grid.value(far), t.value),
            "{t:?}"
        );
    }
    let tolerance = 1e-5 * lo.abs().max(hi.abs());
    let mut accessor = grid.accessor();
    for &p in points {
        let v = grid.trilinear_index(p);
        assert!(same(accessor.trilinear_index(p), v), "accessor at {p}");
        if bounded {
            assert!(
                v.is_finite() && v >= lo - tolerance && v <= hi + tolerance,
                "{v} at {p} outside [{lo}, {hi}]"
            );
        }
    }
}

/// Points around the tree's data (and a few anywhere), in index space.
fn lookup_points(tree: &Tree, rng: &mut Pcg32) -> Vec<Vec3> {
    let anchors: Vec<IVec3> = tree
        .leaf_origins
        .iter()
        .chain(tree.tiles.iter().map(|t| &t.origin))
        .copied()
        .collect();
    let mut points = vec![
        Vec3::splat(1e30),
        Vec3::splat(-1e30),
        Vec3::splat(f32::MAX),
        Vec3::new(2.147e9, 0.0, -2.147e9),
    ];
    for _ in 0..200 {
        let anchor = anchors
            .get(rng.next_u32() as usize % anchors.len().max(1))
            .copied()
            .unwrap_or_default();
        let offset = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 20.0 - 6.0;
        points.push(anchor.as_vec3() + offset);
    }
    points
}

#[test]
fn arbitrary_trees_build_or_fail_cleanly() {
    let tally = Tally::default();
    runner(2000)
        .run(&(any_tree(), any::<u64>()), |(tree, points_seed)| {
            let grid = SparseGrid::build(
                tree.background,
                &tree.leaf_origins,
                tree.leaf_values.clone(),
                &tree.tiles,
                identity(),
            );
            if let Ok(grid) = &grid {
                let mut rng = Pcg32::new(points_seed, 2);
                check_grid(&tree, grid, &lookup_points(&tree, &mut rng));
            }
            tally.note(&grid);
            Ok(())
        })
        .unwrap();
    let (built, refused) = (tally.ok.get(), tally.err.get());
    assert!(
        built > 500 && refused > 200,
        "{built} built, {refused} refused"
    );
}

/// Found here first: an invertible matrix with a NaN translation was
/// accepted (regression unit test in `src/volumes/grid.rs`).
#[test]
fn accepted_transforms_are_finite_both_ways() {
    let entry = prop_oneof![
        4 => -4.0f64..4.0,
        1 => prop::sample::select(vec![
            0.0,
            f64::NAN,
            f64::INFINITY,
            1e300,
            -1e300,
            1e-300,
            f64::MAX,
        ]),
    ];
    runner(2000)
        .run(&prop::array::uniform12(entry), |m| {
            if let Some(t) = GridTransform::new(DAffine3::from_cols_array(&m)) {
                prop_assert!(
                    t.world_from_index.is_finite() && t.index_from_world.is_finite(),
                    "{m:?} -> {t:?}"
                );
            }
            Ok(())
        })
        .unwrap();
}
