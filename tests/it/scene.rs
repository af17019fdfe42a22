//! The scene loader on scenes written by hand here (`scene.json` + `scene.bin`):
//! a valid scene loads with the right counts, every validation rule refuses
//! one corrupted variant with an error naming the file and field, and memory
//! grows with prototypes, not instances.

use crate::common;
use std::path::Path;
use std::process::Command;

use cirrus::geometry::{Geometry, Ray};
use cirrus::sampling::Pcg32;
use cirrus::scene::{Input, Model, Scene, SceneError, Wrap};
use glam::{vec3a, Vec2};
use serde_json::{json, Value};

/// Fixed seed for the random rays (tests/common has none yet).
const SEED: u64 = 0x5eed_c1a5;

const IDENTITY: [f32; 12] = [1., 0., 0., 0., 0., 1., 0., 0., 0., 0., 1., 0.];

/// A scene being written: the manifest as JSON and the blob as bytes.
struct SceneFiles {
    json: Value,
    blob: Vec<u8>,
}

impl SceneFiles {
    /// Appends `data` at the next 16-byte boundary and returns its array reference.
    fn array<T: bytemuck::Pod>(&mut self, scalar: &str, width: usize, data: &[T]) -> Value {
        self.blob.resize(self.blob.len().next_multiple_of(16), 0);
        let offset = self.blob.len();
        let bytes: &[u8] = bytemuck::cast_slice(data);
        self.blob.extend_from_slice(bytes);
        json!({"offset": offset, "count": bytes.len() / (4 * width), "type": scalar, "width": width})
    }

    fn write(&self, dir: &Path) {
        std::fs::write(dir.join("scene.json"), self.json.to_string()).unwrap();
        std::fs::write(dir.join("scene.bin"), &self.blob).unwrap();
    }

    /// Overwrites the `index`-th 32-bit scalar of the array at JSON pointer `array`.
    fn poke(&mut self, array: &str, index: usize, bits: u32) {
        let offset = self.json.pointer(array).unwrap()["offset"]
            .as_u64()
            .unwrap() as usize;
        let at = offset + 4 * index;
        self.blob[at..at + 4].copy_from_slice(&bits.to_le_bytes());
    }
}

/// A unit quad in z = 0 (two triangles sharing the diagonal 0-2), CCW seen from +z.
const QUAD_POINTS: [[f32; 3]; 4] = [[0., 0., 0.], [1., 0., 0.], [1., 1., 0.], [0., 1., 0.]];
const QUAD_TRIANGLES: [[u32; 3]; 2] = [[0, 1, 2], [0, 2, 3]];

/// A scene of `prototypes` prototypes, each its own copy of the quad mesh,
/// placed by `instances` instances in all (spread over the prototypes in
/// turn, instance i translated by (2i, 0, 0)); one of everything else.
fn scene_files(prototypes: usize, instances: usize) -> SceneFiles {
    let mut f = SceneFiles {
        json: Value::Null,
        blob: Vec::new(),
    };
    let meshes: Vec<Value> = (0..prototypes)
        .map(|i| {
            json!({
                "path": format!("/World/Quad{i}/Mesh"),
                "points": f.array("f32", 3, &QUAD_POINTS),
                "triangles": f.array("u32", 3, &QUAD_TRIANGLES),
                "normals": f.array("f32", 3, &[[0f32, 0., 1.]; 4]),
                "uvs": f.array("f32", 2, &[[0f32, 0.], [1., 0.], [1., 1.], [0., 1.]]),
                "triangle_materials": f.array("u32", 1, &[0u32, u32::MAX]),
                "double_sided": false,
            })
        })
        .collect();
    let protos: Vec<Value> = (0..prototypes)
        .map(|i| {
            json!({"path": format!("/World/Quad{i}"),
                   "meshes": [{"mesh": i, "transform": IDENTITY}],
                   "volumes": if i == 0 { json!([{"volume": 0, "transform": IDENTITY}]) } else { json!([]) }})
        })
        .collect();
    let transforms: Vec<[f32; 12]> = (0..instances)
        .map(|i| {
            let mut m = IDENTITY;
            m[3] = 2.0 * i as f32;
            m
        })
        .collect();
    let proto_of: Vec<u32> = (0..instances).map(|i| (i % prototypes) as u32).collect();
    let source_index: Vec<u32> = (0..instances as u32).collect();
    let instances_json = json!({
        "count": instances,
        "prototype": f.array("u32", 1, &proto_of),
        "transform": f.array("f32", 12, &transforms),
        "source": f.array("u32", 1, &vec![0u32; instances]),
        "source_index": f.array("u32", 1, &source_index),
        "instance_sources": ["/World/Instancer"],
    });
    f.json = json!({
        "format": "cirrus-scene",
        "version": 1,
        "source": {"path": "/abs/in.usda", "mtime": 1700000000.0, "time_code": 1.0},
        "stage": {"meters_per_unit": 0.01, "up_axis": "Y"},
        "bounds": {"min": [0, 0, 0], "max": [2 * instances, 1, 0]},
        "meshes": meshes,
        "prototypes": protos,
        "instances": instances_json,
        "materials": [{
            "path": "/Looks/Red", "fallback": false,
            "diffuse_color": {"texture": 0, "channel": "rgb"},
            "emissive_color": [0, 0, 0], "metallic": 0.0, "roughness": {"texture": 0, "channel": "r"},
            "specular_color": [0, 0, 0], "use_specular_workflow": false, "ior": 1.5,
            "opacity": 1.0, "clearcoat": 0.0, "clearcoat_roughness": 0.01, "normal": null
        }],
        "textures": [{
            "file": "/abs/tex.png", "wrap_s": "repeat", "wrap_t": "mirror",
            "scale": [1, 1, 1, 1], "bias": [0, 0, 0, 0], "fallback": [0, 0, 0, 1],
            "color_space": "sRGB",
            "st_transform": {"translation": [0, 0], "rotation_deg": 0.0, "scale": [1, 1]}
        }],
        "lights": [
            {"type": "distant", "path": "/World/Sun", "transform": IDENTITY, "color": [1, 1, 1],
             "intensity": 3.0, "exposure": 0.0, "normalize": true, "color_temperature": null,
             "angle_deg": 0.53},
            {"type": "dome", "path": "/World/Sky", "transform": IDENTITY, "color": [1, 1, 1],
             "intensity": 1.0, "exposure": 0.0, "normalize": false, "color_temperature": 6500.0,
             "texture": null}
        ],
        "camera": {
            "path": "/World/Cam", "transform": IDENTITY, "projection": "perspective",
            "focal_length": 50.0, "horizontal_aperture": 20.955, "vertical_aperture": 15.2908,
            "horizontal_aperture_offset": 0.0, "vertical_aperture_offset": 0.0,
            "clipping_range": [1, 1000000], "f_stop": 0.0, "focus_distance": 0.0
        },
        "volumes": [{
            "path": "/World/Cloud",
            "fields": {"density": {"file": "/abs/cloud.vdb", "grid": "density", "index": 0}},
            "density_scale": 1.0, "albedo": [1, 1, 1], "anisotropy": 0.0, "heat_scale": 0.0,
            "temperature_offset": 0.0, "temperature_scale": 1.0
        }],
        "render": {"resolution": [640, 480]},
        "warnings": ["/World/Cloud: albedo unauthored, using 1"]
    });
    f
}

fn load_scene(test: &str, files: &SceneFiles) -> Scene {
    Scene::load(&write_scene(test, files)).unwrap()
}

fn write_scene(test: &str, files: &SceneFiles) -> std::path::PathBuf {
    let dir = common::scratch(test);
    files.write(&dir);
    dir
}

#[test]
fn valid_scene_loads_with_its_counts() {
    let dir = write_scene("scene_valid", &scene_files(1, 5));
    for path in [dir.clone(), dir.join("scene.json")] {
        let scene = Scene::load(&path).unwrap();
        let m = &scene.manifest;
        assert_eq!(scene.dir, dir);
        assert_eq!(
            (m.meshes.len(), m.prototypes.len(), m.instances.count),
            (1, 1, 5)
        );
        assert_eq!(
            (m.lights.len(), m.materials.len(), m.textures.len()),
            (2, 1, 1)
        );
        assert_eq!(scene.view(&m.meshes[0].points), &QUAD_POINTS);
        assert_eq!(scene.view(&m.meshes[0].triangles), &QUAD_TRIANGLES);
        assert_eq!(scene.view(&m.instances.transform)[4][3], 8.0);
        assert_eq!(scene.view(&m.instances.source_index), &[0, 1, 2, 3, 4]);
    }
}

/// The production-look records (issue 21) load: an OpenPBR material with
/// primvar, operation and normal-map inputs, a mesh primvar, wrap `constant`;
/// absent fields take their defaults.
#[test]
fn production_look_records_load_with_their_defaults() {
    let mut files = scene_files(1, 1);
    let tint = files.array(
        "f32",
        3,
        &[[1f32, 0., 0.], [0., 1., 0.], [0., 0., 1.], [1., 1., 1.]],
    );
    set(&mut files, "/meshes/0/primvars", json!({"tint": tint}));
    set(&mut files, "/textures/0/wrap_s", json!("constant"));
    let tinted = json!({"op": "multiply", "args": [
        {"primvar": "tint", "channel": "rgb", "fallback": [0.5, 0.5, 0.5]},
        {"texture": 0, "channel": "rgb"}]});
    let open_pbr = json!({
        "path": "/Looks/King", "model": "open_pbr", "shader": "ND_standard_surface_surfaceshader",
        "skipped": ["subsurface rendered as its diffuse fallback"],
        "open_pbr": {"base_color": tinted, "specular_roughness": 0.2, "emission_luminance": 0},
        "geometry_thin_walled": true,
        "geometry_normal": {"texture": 0, "channel": "rgb", "scale": 0.5}
    });
    files.json["materials"]
        .as_array_mut()
        .unwrap()
        .push(open_pbr);
    let dir = write_scene("scene_looks", &files);
    let info = common::cirrus_ok(&["info".as_ref(), dir.as_os_str()]);
    for expected in [
        "materials    2 (1 open_pbr, 1 preview_surface); 0 fell back, 1 skipped a richer look",
        "/Looks/King: subsurface rendered as its diffuse fallback",
    ] {
        assert!(info.contains(expected), "missing {expected:?} in:\n{info}");
    }
    let scene = Scene::load(&dir).unwrap();
    let m = &scene.manifest;
    assert_eq!(m.textures[0].wrap_s, Wrap::Constant);
    assert_eq!(scene.view(&m.meshes[0].primvars["tint"]).len(), 12);
    let (preview, king) = (&m.materials[0], &m.materials[1]);
    assert_eq!(
        (preview.model, preview.shader.as_str()),
        (Model::PreviewSurface, "")
    );
    assert!(preview.skipped.is_empty() && preview.open_pbr.base_color.is_none());
    assert_eq!(king.model, Model::OpenPbr);
    assert_eq!(king.skipped.len(), 1);
    assert_eq!(king.open_pbr.specular_roughness, Some(Input::Constant(0.2)));
    assert!(matches!(&king.open_pbr.base_color, Some(Input::Op(op)) if op.args.len() == 2));
    assert!(king.geometry_thin_walled && king.geometry_coat_normal.is_none());
    assert_eq!(king.geometry_normal.as_ref().map(|n| n.scale), Some(0.5));
    // UsdPreviewSurface's defaults where the record is silent.
    assert_eq!(king.roughness, Input::Constant(0.5));
    assert_eq!(king.diffuse_color, Input::Constant([0.18; 3]));
}

#[test]
fn info_prints_scene_counts() {
    let dir = write_scene("scene_info", &scene_files(2, 6));
    let stdout = common::cirrus_ok(&["info".as_ref(), dir.as_os_str()]);
    for expected in [
        "prototypes   2",
        "instances    6 from 1 source prim(s)",
        "triangles    4 unique, 12 instanced",
        "lights       2 (1 distant, 1 dome)",
        "materials    1 (1 preview_surface); 0 fell back, 0 skipped a richer look",
        "/World/Cloud: density = /abs/cloud.vdb:density[0]",
        "warnings     1",
    ] {
        assert!(
            stdout.contains(expected),
            "missing {expected:?} in:\n{stdout}"
        );
    }
}

/// How a corruption is applied: to the contents before writing, or to the
/// written files.
enum Apply {
    Content(fn(&mut SceneFiles)),
    File(fn(&Path)),
}

/// One corruption of the valid scene and what its error must say.
struct Corruption {
    name: &'static str,
    apply: Apply,
    /// Substrings of the error message: the file and the field path.
    expect: &'static [&'static str],
}

/// Sets the value at JSON pointer `pointer`, adding the last key to its
/// object if absent.
fn set(f: &mut SceneFiles, pointer: &str, value: Value) {
    let (parent, key) = pointer.rsplit_once('/').unwrap();
    match f.json.pointer_mut(parent).unwrap() {
        Value::Object(fields) => {
            fields.insert(key.to_owned(), value);
        }
        array => array[key.parse::<usize>().unwrap()] = value,
    }
}

const CORRUPTIONS: &[Corruption] = &[
    Corruption {
        name: "bad version",
        apply: Apply::Content(|f| set(f, "/version", json!(2))),
        expect: &["scene.json", "version 2", "version 1 only"],
    },
    Corruption {
        name: "not a scene",
        apply: Apply::Content(|f| set(f, "/format", json!("gltf"))),
        expect: &["scene.json", "not a Cirrus scene"],
    },
    Corruption {
        name: "missing field",
        apply: Apply::Content(|f| {
            f.json.as_object_mut().unwrap().remove("camera");
        }),
        expect: &["scene.json", "missing field `camera`"],
    },
    Corruption {
        name: "misaligned offset",
        apply: Apply::Content(|f| set(f, "/meshes/0/points/offset", json!(4))),
        expect: &["scene.json: meshes[0].points: offset 4 is not a multiple of 16"],
    },
    Corruption {
        name: "offset past end",
        apply: Apply::Content(|f| {
            let end = f.blob.len().next_multiple_of(16);
            set(f, "/meshes/0/triangles/offset", json!(end))
        }),
        expect: &[
            "scene.json: meshes[0].triangles: 2 elements",
            "past the end of scene.bin",
        ],
    },
    Corruption {
        name: "count overflows",
        apply: Apply::Content(|f| set(f, "/meshes/0/points/count", json!(u64::MAX / 2))),
        expect: &["meshes[0].points:", "past the end of scene.bin"],
    },
    Corruption {
        name: "wrong width",
        apply: Apply::Content(|f| set(f, "/meshes/0/points/width", json!(2))),
        expect: &["scene.json: meshes[0].points: width 2, expected 3"],
    },
    Corruption {
        name: "wrong type",
        apply: Apply::Content(|f| set(f, "/meshes/0/triangles/type", json!("f32"))),
        expect: &["scene.json: meshes[0].triangles: type f32, expected u32"],
    },
    Corruption {
        name: "unknown scalar type",
        apply: Apply::Content(|f| set(f, "/meshes/0/triangles/type", json!("f64"))),
        expect: &[
            "scene.json: meshes[0].triangles.type:",
            "unknown variant `f64`",
        ],
    },
    Corruption {
        name: "triangle index out of range",
        apply: Apply::Content(|f| f.poke("/meshes/0/triangles", 4, 812)),
        expect: &["scene.json: meshes[0].triangles: index 812 >= 4 points"],
    },
    Corruption {
        name: "normals count",
        apply: Apply::Content(|f| set(f, "/meshes/0/normals/count", json!(3))),
        expect: &["scene.json: meshes[0].normals: count 3, expected one per points (4)"],
    },
    Corruption {
        name: "uvs width",
        apply: Apply::Content(|f| set(f, "/meshes/0/uvs/width", json!(3))),
        expect: &["scene.json: meshes[0].uvs: width 3, expected 2"],
    },
    Corruption {
        name: "triangle material out of range",
        apply: Apply::Content(|f| f.poke("/meshes/0/triangle_materials", 0, 7)),
        expect: &["scene.json: meshes[0].triangle_materials: index 7 >= 1 materials"],
    },
    Corruption {
        name: "NaN point",
        apply: Apply::Content(|f| f.poke("/meshes/0/points", 5, f32::NAN.to_bits())),
        expect: &["scene.json: meshes[0].points: value NaN at scalar 5 is not finite"],
    },
    Corruption {
        name: "light intensity beyond f32",
        apply: Apply::Content(|f| set(f, "/lights/0/intensity", json!(1e39))),
        expect: &["scene.json: lights[0].intensity: 1e39 is beyond the single-precision range"],
    },
    Corruption {
        name: "huge point",
        apply: Apply::Content(|f| f.poke("/meshes/0/points", 3, f32::MAX.to_bits())),
        expect: &["meshes[0].points: value 340282350000000000000000000000000000000 at scalar 3 is not finite or beyond ±1e9"],
    },
    Corruption {
        name: "bad prototype mesh index",
        apply: Apply::Content(|f| set(f, "/prototypes/0/meshes/0/mesh", json!(3))),
        expect: &["scene.json: prototypes[0].meshes[0].mesh: index 3 >= 1 meshes"],
    },
    Corruption {
        name: "bad prototype volume index",
        apply: Apply::Content(|f| set(f, "/prototypes/0/volumes/0/volume", json!(1))),
        expect: &["scene.json: prototypes[0].volumes[0].volume: index 1 >= 1 volumes"],
    },
    Corruption {
        name: "density scale neither grey nor RGB",
        apply: Apply::Content(|f| set(f, "/volumes/0/density_scale", json!([1, 2]))),
        expect: &[
            "scene.json: volumes[0].density_scale: expected one number (grey) or three (RGB channels)",
        ],
    },
    Corruption {
        name: "prototype transform too short",
        apply: Apply::Content(|f| set(f, "/prototypes/0/meshes/0/transform", json!([1, 0, 0]))),
        expect: &["scene.json: prototypes[0].meshes[0].transform:"],
    },
    Corruption {
        name: "bad instance prototype index",
        apply: Apply::Content(|f| f.poke("/instances/prototype", 2, 5)),
        expect: &["scene.json: instances.prototype: index 5 >= 1 prototypes"],
    },
    Corruption {
        name: "bad instance source index",
        apply: Apply::Content(|f| f.poke("/instances/source", 1, 1)),
        expect: &["scene.json: instances.source: index 1 >= 1 instance_sources"],
    },
    Corruption {
        name: "instance array count",
        apply: Apply::Content(|f| set(f, "/instances/source_index/count", json!(2))),
        expect: &["scene.json: instances.source_index: count 2, expected one per instances (5)"],
    },
    Corruption {
        name: "NaN instance transform",
        apply: Apply::Content(|f| f.poke("/instances/transform", 12 + 3, f32::NAN.to_bits())),
        expect: &["scene.json: instances.transform: value NaN at scalar 15 is not finite"],
    },
    Corruption {
        name: "infinite light transform",
        apply: Apply::Content(|f| set(f, "/lights/1/transform/0", json!(1e39))),
        expect: &["scene.json: lights[1].transform[0]: 1e39 is beyond the single-precision range"],
    },
    Corruption {
        name: "bad material texture index",
        apply: Apply::Content(|f| set(f, "/materials/0/roughness/texture", json!(9))),
        expect: &["scene.json: materials[0].roughness.texture: index 9 >= 1 textures"],
    },
    Corruption {
        name: "bad channel",
        apply: Apply::Content(|f| {
            set(
                f,
                "/materials/0/normal",
                json!({"texture": 0, "channel": "xyz"}),
            )
        }),
        expect: &[
            "scene.json: materials[0].normal.channel:",
            "unknown variant `xyz`",
        ],
    },
    Corruption {
        name: "bad projection",
        apply: Apply::Content(|f| set(f, "/camera/projection", json!("fisheye"))),
        expect: &[
            "scene.json: camera.projection:",
            "unknown variant `fisheye`",
        ],
    },
    Corruption {
        name: "bad light type",
        apply: Apply::Content(|f| set(f, "/lights/0/type", json!("spot"))),
        expect: &["scene.json: lights[0]:", "unknown variant `spot`"],
    },
    Corruption {
        name: "bad wrap mode",
        apply: Apply::Content(|f| set(f, "/textures/0/wrap_t", json!("tile"))),
        expect: &["scene.json: textures[0].wrap_t:", "unknown variant `tile`"],
    },
    Corruption {
        name: "bad color space",
        apply: Apply::Content(|f| set(f, "/textures/0/color_space", json!("ACEScg"))),
        expect: &[
            "scene.json: textures[0].color_space:",
            "unknown variant `ACEScg`",
        ],
    },
    Corruption {
        name: "bad up axis",
        apply: Apply::Content(|f| set(f, "/stage/up_axis", json!("X"))),
        expect: &["scene.json: stage.up_axis:", "unknown variant `X`"],
    },
    Corruption {
        name: "zero meters per unit",
        apply: Apply::Content(|f| set(f, "/stage/meters_per_unit", json!(0.0))),
        expect: &["scene.json: stage.meters_per_unit: 0 is not a positive number"],
    },
    Corruption {
        name: "truncated scene.bin",
        apply: Apply::Content(|f| f.blob.truncate(f.blob.len() - 20)),
        expect: &[
            "scene.json: instances.source_index:",
            "past the end of scene.bin",
        ],
    },
    Corruption {
        name: "unknown open_pbr input",
        apply: Apply::Content(|f| {
            set(f, "/materials/0/model", json!("open_pbr"));
            set(f, "/materials/0/open_pbr", json!({"base_colr": [1, 0, 0]}));
        }),
        expect: &["scene.json: materials[0].open_pbr", "unknown field `base_colr`"],
    },
    Corruption {
        name: "unknown material model",
        apply: Apply::Content(|f| set(f, "/materials/0/model", json!("standard_surface"))),
        expect: &[
            "scene.json: materials[0].model:",
            "unknown variant `standard_surface`",
        ],
    },
    Corruption {
        name: "colour for a scalar input",
        apply: Apply::Content(|f| {
            set(f, "/materials/0/open_pbr", json!({"base_metalness": [1, 0, 0]}))
        }),
        expect: &["scene.json: materials[0].open_pbr.base_metalness: expected a number, found [1,0,0]"],
    },
    Corruption {
        name: "texture index inside an operation",
        apply: Apply::Content(|f| {
            let input = json!({"op": "multiply", "args": [2, {"texture": 3, "channel": "rgb"}]});
            set(f, "/materials/0/diffuse_color", input)
        }),
        expect: &["scene.json: materials[0].diffuse_color.args[1].texture: index 3 >= 1 textures"],
    },
    Corruption {
        name: "operation with the wrong arity",
        apply: Apply::Content(|f| {
            set(f, "/materials/0/diffuse_color", json!({"op": "mix", "args": [1, 0]}))
        }),
        expect: &["scene.json: materials[0].diffuse_color: args: mix takes 3 arguments, found 2"],
    },
    Corruption {
        name: "unknown operation",
        apply: Apply::Content(|f| {
            let input = json!({"op": "add", "args": [1, {"op": "divide", "args": [1, 2]}]});
            set(f, "/materials/0/roughness", input)
        }),
        expect: &[
            "scene.json: materials[0].roughness: args[1]: op: unknown variant `divide`",
        ],
    },
    Corruption {
        name: "primvar input without a fallback",
        apply: Apply::Content(|f| {
            set(f, "/materials/0/opacity", json!({"primvar": "mask", "channel": "r"}))
        }),
        expect: &["scene.json: materials[0].opacity: missing field `fallback`"],
    },
    Corruption {
        name: "normal map texture index",
        apply: Apply::Content(|f| {
            set(f, "/materials/0/geometry_coat_normal", json!({"texture": 5}))
        }),
        expect: &["scene.json: materials[0].geometry_coat_normal.texture: index 5 >= 1 textures"],
    },
    Corruption {
        name: "primvar width",
        apply: Apply::Content(|f| {
            let tint = f.array("f32", 5, &[0f32; 20]);
            set(f, "/meshes/0/primvars", json!({"tint": tint}))
        }),
        expect: &["scene.json: meshes[0].primvars.tint: width 5, expected 1 to 4"],
    },
    Corruption {
        name: "primvar count",
        apply: Apply::Content(|f| {
            let tint = f.array("f32", 3, &[0f32; 9]);
            set(f, "/meshes/0/primvars", json!({"tint": tint}))
        }),
        expect: &["scene.json: meshes[0].primvars.tint: count 3, expected one per points (4)"],
    },
    Corruption {
        name: "NaN primvar",
        apply: Apply::Content(|f| {
            let mask = f.array("f32", 1, &[0.0, 1.0, f32::NAN, 1.0]);
            set(f, "/meshes/0/primvars", json!({"mask": mask}))
        }),
        expect: &["scene.json: meshes[0].primvars.mask: value NaN at scalar 2 is not finite"],
    },
    Corruption {
        name: "missing scene.bin",
        apply: Apply::File(|dir| std::fs::remove_file(dir.join("scene.bin")).unwrap()),
        expect: &["scene.bin: No such file"],
    },
    Corruption {
        name: "not JSON",
        apply: Apply::File(|dir| std::fs::write(dir.join("scene.json"), "{\"format\": ").unwrap()),
        expect: &["scene.json: not JSON"],
    },
];

#[test]
fn every_corruption_is_refused_naming_the_field() {
    for c in CORRUPTIONS {
        let dir = common::scratch(&format!("scene_corrupt_{}", c.name.replace(' ', "_")));
        let mut files = scene_files(1, 5);
        match c.apply {
            Apply::Content(apply) => {
                apply(&mut files);
                files.write(&dir);
            }
            Apply::File(apply) => {
                files.write(&dir);
                apply(&dir);
            }
        }
        let err: SceneError = match Scene::load(&dir) {
            Ok(_) => panic!("{}: loaded a corrupted scene", c.name),
            Err(e) => e,
        };
        let msg = err.to_string();
        for want in c.expect {
            assert!(
                msg.contains(want),
                "{}: error {msg:?} lacks {want:?}",
                c.name
            );
        }
    }
}

#[test]
fn memory_grows_with_prototypes_not_instances() {
    let load = |test: &str, prototypes, instances| {
        load_scene(test, &scene_files(prototypes, instances)).array_bytes()
    };
    let few = load("scene_mem_few", 1, 10);
    let many = load("scene_mem_many", 1, 1000);
    let copies = load("scene_mem_copies", 100, 100);
    // The mesh is stored once however many instances place it...
    assert_eq!(few.meshes, many.meshes);
    // ...each instance costs 60 bytes: a 3x4 transform and three u32s...
    assert_eq!(few.instances, 10 * 60);
    assert_eq!(many.instances, 1000 * 60);
    // ...and only new prototypes add geometry.
    assert_eq!(copies.meshes, 100 * few.meshes);
}

/// A ray straight down -z onto the point (x, y, 0) from z = 1.
fn down(x: f32, y: f32) -> Ray {
    Ray::new_inf(vec3a(x, y, 1.0), vec3a(0.0, 0.0, -1.0))
}

#[test]
fn ray_hits_the_expected_triangle_of_an_instance() {
    let mut files = scene_files(1, 3);
    // Instance 0 rotated 90 degrees about z: (x, y) -> (-y, x).
    let rotation: [f32; 12] = [0., -1., 0., 0., 1., 0., 0., 0., 0., 0., 1., 0.];
    for (k, value) in rotation.iter().enumerate() {
        files.poke("/instances/transform", k, value.to_bits());
    }
    let geometry = Geometry::build(&load_scene("geometry_instance_hit", &files), true);
    // Local point (0.75, 0.25) of an instance is in triangle 0 = (0, 1, 2), with
    // weights 0.5 on (1, 0) and 0.25 on (1, 1); (0.25, 0.75) is in triangle
    // 1 = (0, 2, 3), with weights 0.25 on (1, 1) and 0.5 on (0, 1).
    let expect = |instance: u32, triangle: u32, barycentrics: Vec2| {
        Some((1.0f32, instance, 0u32, triangle, barycentrics))
    };
    let found = |ray: &Ray| {
        geometry.intersect(ray, 0.0).map(|h| {
            (
                h.t,
                h.instance,
                h.prototype_mesh,
                h.triangle,
                h.barycentrics,
            )
        })
    };
    assert_eq!(found(&down(4.75, 0.25)), expect(2, 0, Vec2::new(0.5, 0.25)));
    assert_eq!(found(&down(2.25, 0.75)), expect(1, 1, Vec2::new(0.25, 0.5)));
    assert_eq!(
        found(&down(-0.25, 0.75)),
        expect(0, 0, Vec2::new(0.5, 0.25))
    );
    // Between instances, and short of the surface.
    assert_eq!(geometry.intersect(&down(3.5, 0.5), 0.0), None);
    let short = Ray::new(vec3a(4.75, 0.25, 1.0), vec3a(0.0, 0.0, -1.0), 0.0, 0.5);
    assert_eq!(geometry.intersect(&short, 0.0), None);
}

#[test]
fn rays_through_shared_edges_and_vertices_never_miss() {
    let geometry = Geometry::build(&load_scene("geometry_watertight", &scene_files(1, 1)), true);
    let n = 16;
    let grid = |i: u32| i as f32 / n as f32;
    // Straight down and straight up onto every grid point, the quad's border,
    // corners and shared diagonal included: the projection is exact there.
    for i in 0..=n {
        for j in 0..=n {
            let (x, y) = (grid(i), grid(j));
            assert!(
                geometry.intersect(&down(x, y), 0.0).is_some(),
                "down ({x}, {y})"
            );
            let up = Ray::new_inf(vec3a(x, y, -1.0), vec3a(0.0, 0.0, 1.0));
            assert!(geometry.intersect(&up, 0.0).is_some(), "up ({x}, {y})");
        }
    }
    // Oblique rays aimed at points of the shared diagonal: rounding puts the
    // ray on either side of it, and one of the two triangles must take it.
    let mut rng = Pcg32::new(SEED, 0);
    for _ in 0..20_000 {
        let s = 0.01 + 0.98 * rng.next_f32();
        let target = vec3a(s, s, 0.0);
        let origin = target
            + vec3a(
                4.0 * rng.next_f32() - 2.0,
                4.0 * rng.next_f32() - 2.0,
                0.1 + 2.0 * rng.next_f32(),
            );
        let ray = Ray::new_inf(origin, target - origin);
        let hit = geometry.intersect(&ray, 0.0);
        assert!(hit.is_some(), "ray {origin} -> {target} slipped through");
    }
}

#[test]
fn instances_and_copies_give_identical_hits() {
    let n = 8;
    let instanced = Geometry::build(&load_scene("geometry_instanced", &scene_files(1, n)), true);
    let copies = Geometry::build(&load_scene("geometry_copies", &scene_files(n, n)), true);
    let mut rng = Pcg32::new(SEED, 1);
    let mut uniform = |lo: f32, hi: f32| lo + (hi - lo) * rng.next_f32();
    let mut hits = 0;
    for _ in 0..10_000 {
        let origin = vec3a(uniform(-1.0, 17.0), uniform(-1.0, 2.0), uniform(0.5, 3.0));
        let target = vec3a(uniform(-0.5, 16.0), uniform(-0.5, 1.5), 0.0);
        let ray = Ray::new_inf(origin, target - origin);
        let hit = instanced.intersect(&ray, 0.0);
        assert_eq!(hit, copies.intersect(&ray, 0.0), "ray {origin} -> {target}");
        hits += usize::from(hit.is_some());
    }
    // About a quarter of the targets lie on a quad: the comparison is not vacuous.
    assert!(hits > 1500, "only {hits} hits");
}

/// The exporter end to end through `cirrus export`: the PointInstancer test
/// scene exports, loads, and its instances can be hit.
#[test]
fn exported_point_instancer_loads_and_intersects() {
    needs_shared!();
    let input = common::asset("openusd/testUsdImagingGLPointInstancer/pi_basic.usda");
    let out = common::scratch("scene_export_pi_basic").join("pi_basic");
    common::cirrus_ok(&[
        "export".as_ref(),
        input.as_os_str(),
        "-o".as_ref(),
        out.as_os_str(),
    ]);
    let scene = Scene::load(&out).unwrap();
    let m = &scene.manifest;
    assert_eq!(m.source.path, input.canonicalize().unwrap());
    assert_eq!(m.instances.count, 4);
    assert!(!m.prototypes.is_empty() && !m.meshes.is_empty());
    // A grid of rays down the up axis over the bounds hits the instances.
    let geometry = Geometry::build(&scene, true);
    let (lo, hi) = (m.bounds.min, m.bounds.max);
    let mut hits = 0;
    for i in 0..32 {
        for j in 0..32 {
            let x = lo[0] + (hi[0] - lo[0]) * (i as f32 + 0.5) / 32.0;
            let y = lo[1] + (hi[1] - lo[1]) * (j as f32 + 0.5) / 32.0;
            let ray = Ray::new_inf(vec3a(x, y, hi[2] + 1.0), vec3a(0.0, 0.0, -1.0));
            hits += usize::from(geometry.intersect(&ray, 0.0).is_some());
        }
    }
    assert!(hits > 0, "no ray hit the exported instances");
}

/// `cirrus export` of the stage `text`, written as `name` into the scratch
/// folder `scratch`, to `out` there: the folder and the command's output.
fn export_stage(
    scratch: &str,
    name: &str,
    text: &str,
) -> (std::path::PathBuf, std::process::Output) {
    let dir = common::scratch(scratch);
    let input = dir.join(name);
    std::fs::write(&input, text).unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_cirrus"))
        .arg("export")
        .arg(&input)
        .arg("-o")
        .arg(dir.join("out"))
        .output()
        .unwrap();
    (dir, out)
}

#[test]
fn export_failure_is_one_clear_error() {
    let (dir, out) = export_stage(
        "scene_export_bad",
        "broken.usda",
        "#usda 1.0\n(\n  this is not usda\n",
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(stderr.contains("broken.usda: export failed: "), "{stderr}");
    assert!(!stderr.contains("Traceback"), "{stderr}");
    assert!(!dir.join("out").exists(), "a failed export left its output");
}

/// An export that fails names the input once in its error line (the
/// exporter's message and each warning it repeats used to name it again):
/// a stage whose only content is in a missing layer.
#[test]
fn a_failed_export_names_the_input_once() {
    let (_, out) = export_stage(
        "scene_export_once",
        "hollow.usda",
        "#usda 1.0\ndef Xform \"W\" (\n  references = @gone.usda@\n)\n{\n}\n",
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    let error = stderr.lines().find(|l| l.starts_with("error:")).unwrap();
    assert!(
        error.contains("gone.usda") && error.contains("/W"),
        "{error}"
    );
    assert_eq!(error.matches("hollow.usda").count(), 1, "{error}");
}

/// `cirrus info IN.usda` exports into the cache once and reuses it, leaving
/// no temporary folders behind.
#[test]
fn info_on_usd_exports_once_into_the_cache() {
    needs_shared!();
    let cache = common::scratch("scene_cache");
    let input = common::asset("openusd/testUsdImagingGLPointInstancer/pi_basic.usda");
    let info = || {
        let out = Command::new(env!("CARGO_BIN_EXE_cirrus"))
            .arg("info")
            .arg(&input)
            .env("XDG_CACHE_HOME", &cache)
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        assert!(String::from_utf8_lossy(&out.stdout).contains("instances    4"));
        let entries: Vec<_> = std::fs::read_dir(cache.join("cirrus"))
            .unwrap()
            .map(|e| e.unwrap().path())
            .collect();
        assert_eq!(entries.len(), 1, "{entries:?}");
        let manifest = entries[0].join("scene.json");
        std::fs::metadata(manifest).unwrap().modified().unwrap()
    };
    let first = info();
    assert_eq!(info(), first, "the second run exported again");
}

/// `scenes/make_instancing_stress.py` (the stage of `cirrus bench instances`)
/// is deterministic, and its stage exports to exactly the instances asked for,
/// all of one mesh of about the triangles asked for.
#[test]
fn instancing_stress_stage_is_deterministic_and_exports_every_instance() {
    let dir = common::scratch("scene_instancing_stress");
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/make_instancing_stress.py");
    let stages = ["a.usdc", "b.usdc"].map(|name| {
        let stage = dir.join(name);
        let args = ["--instances", "1000", "--triangles", "2000"];
        common::run_python(
            &common::venv_python(),
            &script,
            &[&[stage.to_str().unwrap()][..], &args].concat(),
        );
        std::fs::read(&stage).unwrap()
    });
    assert!(stages[0] == stages[1], "two runs wrote different stages");

    let out = dir.join("out");
    cirrus::scene::export(&dir.join("a.usdc"), &out, &Default::default()).unwrap();
    let scene = Scene::load(&out).unwrap();
    let m = &scene.manifest;
    assert_eq!(m.instances.count, 1000);
    assert_eq!(m.meshes.len(), 1);
    let triangles = m.meshes[0].triangles.count;
    assert!((2000..2200).contains(&triangles), "{triangles} triangles");
}
