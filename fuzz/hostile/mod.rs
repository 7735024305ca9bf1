//! The hostile-input generator: structured mutations of one valid glTF scene, each with the
//! outcome the specification implies, beside the byte-level fuzz targets (which find crashes in
//! parsers but almost never produce a well-formed file with one bad number).
//!
//! [`base_scene`] is a small valid glTF (a ground and a cube with normals, tangents and UVs, a
//! normal-mapped material, a perspective and an orthographic camera, a point, a spot and a
//! directional light, everything in data URIs). [`cases`] lists mutations of it: every numeric
//! field of cameras, lights, materials, nodes, accessors and buffer views set to 0, negative,
//! tiny, huge, beyond f32 (infinite once read) and fractional; `extras` of every JSON type on
//! every kind of object; EXT_mesh_gpu_instancing on the cube with valid and broken attributes;
//! NaN and infinity in each vertex attribute's binary data. Each case says
//! whether the specification allows the value ([`Expect`]).
//!
//! `tests/hostile_inputs.rs` runs every case through the importer and the renderer with the
//! invariant: no panic; an error names the file; a spec violation is an error or a warning that
//! names the field (never silently accepted); what loads renders a finite frame. Used from there
//! by `#[path]` (no crate of its own: it needs only serde_json and base64).

use base64::Engine as _;
use serde_json::{Value, json};

/// What the specification says of a mutated value.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Expect {
    /// The value is valid glTF: the file must load, and without warnings about it.
    Valid,
    /// The value breaks a MUST (or a SHOULD the renderer cannot honour): the file must be
    /// refused, or load with a warning naming the field.
    Named,
    /// Valid JSON whose values the renderer must survive (NaN in vertex data): it must load or
    /// be refused cleanly, and render finite.
    Survive,
}

/// One mutated file.
#[derive(Debug, Clone)]
pub struct Case {
    /// What was changed, for messages: `cameras/0/perspective/yfov = -1`.
    pub label: String,
    /// Words of which one must appear in the error or a warning when `expect` is `Named`.
    pub names: Vec<&'static str>,
    pub expect: Expect,
    pub json: Value,
}

const GROUND: [[f32; 3]; 4] = [[-5.0, 0.0, -5.0], [5.0, 0.0, -5.0], [5.0, 0.0, 5.0], [-5.0, 0.0, 5.0]];

/// Vertex data of the ground (4 vertices) and a cube (24 vertices), interleaved by attribute:
/// positions, normals, tangents, UVs, then 16-bit indices.
struct Geometry {
    positions: Vec<[f32; 3]>,
    normals: Vec<[f32; 3]>,
    tangents: Vec<[f32; 4]>,
    uvs: Vec<[f32; 2]>,
    indices: Vec<u16>,
}

fn geometry() -> Geometry {
    let mut g = Geometry {
        positions: Vec::new(),
        normals: Vec::new(),
        tangents: Vec::new(),
        uvs: Vec::new(),
        indices: Vec::new(),
    };
    let mut quad = |corners: [[f32; 3]; 4], normal: [f32; 3], tangent: [f32; 3]| {
        // Each mesh's indices count from its own first vertex: the cube's from the 5th.
        let base = (g.positions.len() as u16).saturating_sub(4);
        g.positions.extend(corners);
        g.normals.extend([normal; 4]);
        g.tangents.extend([[tangent[0], tangent[1], tangent[2], 1.0]; 4]);
        g.uvs.extend([[0.0, 1.0], [1.0, 1.0], [1.0, 0.0], [0.0, 0.0]]);
        g.indices.extend([base, base + 2, base + 1, base, base + 3, base + 2]);
    };
    quad(GROUND, [0.0, 1.0, 0.0], [1.0, 0.0, 0.0]);
    let faces: [([f32; 3], [f32; 3], [f32; 3]); 6] = [
        ([1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, -1.0]),
        ([-1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]),
        ([0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]),
        ([0.0, -1.0, 0.0], [0.0, 0.0, -1.0], [1.0, 0.0, 0.0]),
        ([0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [1.0, 0.0, 0.0]),
        ([0.0, 0.0, -1.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]),
    ];
    for (n, up, right) in faces {
        let at = |r: f32, u: f32| {
            [
                0.5 * (n[0] + r * right[0] + u * up[0]),
                0.5 * (n[1] + r * right[1] + u * up[1]) + 0.5,
                0.5 * (n[2] + r * right[2] + u * up[2]),
            ]
        };
        // Counter-clockwise seen from outside: right, then up.
        quad([at(-1.0, -1.0), at(1.0, -1.0), at(1.0, 1.0), at(-1.0, 1.0)], n, right);
    }
    g
}

/// Which vertex attribute a binary mutation overwrites, and with what.
#[derive(Debug, Clone, Copy)]
pub struct BinaryMutation {
    pub attribute: usize,
    pub value: f32,
}

fn buffer(g: &Geometry, mutation: Option<BinaryMutation>) -> (Vec<u8>, [usize; 5]) {
    let mut bytes = Vec::new();
    let mut offsets = [0; 5];
    let floats: [Vec<f32>; 4] = [
        g.positions.iter().flatten().copied().collect(),
        g.normals.iter().flatten().copied().collect(),
        g.tangents.iter().flatten().copied().collect(),
        g.uvs.iter().flatten().copied().collect(),
    ];
    for (i, values) in floats.iter().enumerate() {
        offsets[i] = bytes.len();
        for (k, v) in values.iter().enumerate() {
            // The first vertex of the cube (element 4's components) gets the value.
            let width = values.len() / g.positions.len();
            let hit = mutation.is_some_and(|m| m.attribute == i) && k / width == 4;
            let v = if hit { mutation.expect("hit").value } else { *v };
            bytes.extend_from_slice(&v.to_le_bytes());
        }
    }
    offsets[4] = bytes.len();
    for i in &g.indices {
        bytes.extend_from_slice(&i.to_le_bytes());
    }
    while bytes.len() % 4 != 0 {
        bytes.push(0);
    }
    (bytes, offsets)
}

/// A 2×2 flat normal map, as a PNG data URI.
fn normal_map_uri() -> String {
    // The smallest valid PNG is not worth hand-writing: encode one.
    let mut png = Vec::new();
    let pixels = [128u8, 128, 255, 255].repeat(4);
    image::codecs::png::PngEncoder::new(&mut png)
        .write_image(&pixels, 2, 2, image::ExtendedColorType::Rgba8)
        .expect("encodes");
    format!("data:image/png;base64,{}", base64::engine::general_purpose::STANDARD.encode(png))
}

use image::ImageEncoder as _;

/// The valid scene every case mutates, with an optional mutation of its vertex data.
pub fn base_scene(mutation: Option<BinaryMutation>) -> Value {
    let g = geometry();
    let (bytes, offsets) = buffer(&g, mutation);
    let n = g.positions.len();
    let uri =
        format!("data:application/octet-stream;base64,{}", base64::engine::general_purpose::STANDARD.encode(&bytes));
    let view = |offset: usize, length: usize| json!({"buffer": 0, "byteOffset": offset, "byteLength": length});
    json!({
        "asset": {"version": "2.0", "generator": "penumbra hostile-input generator"},
        "extensionsUsed": ["KHR_lights_punctual", "KHR_materials_emissive_strength"],
        "scene": 0,
        "scenes": [{"nodes": [0, 1, 2, 3, 4, 5, 6]}],
        "nodes": [
            {"name": "ground", "mesh": 0},
            {"name": "cube", "mesh": 1, "translation": [0.0, 0.0, 0.0], "rotation": [0.0, 0.3826834, 0.0, 0.9238795], "scale": [1.0, 1.0, 1.0]},
            {"name": "camera", "camera": 0, "translation": [4.0, 3.0, 6.0], "rotation": [-0.1911, 0.2840, 0.0578, 0.9379]},
            {"name": "ortho", "camera": 1, "translation": [0.0, 2.0, 8.0]},
            {"name": "point", "translation": [1.5, 2.5, 1.0], "extensions": {"KHR_lights_punctual": {"light": 0}}},
            {"name": "spot", "translation": [-2.0, 3.0, 2.0], "rotation": [-0.3826834, 0.0, 0.0, 0.9238795], "extensions": {"KHR_lights_punctual": {"light": 1}}},
            {"name": "sun", "rotation": [-0.5, 0.3, 0.1, 0.8062258], "extensions": {"KHR_lights_punctual": {"light": 2}}}
        ],
        "cameras": [
            {"type": "perspective", "perspective": {"yfov": 0.8, "znear": 0.05, "zfar": 100.0, "aspectRatio": 1.5}},
            {"type": "orthographic", "orthographic": {"xmag": 4.0, "ymag": 3.0, "znear": 0.0, "zfar": 50.0}}
        ],
        "extensions": {"KHR_lights_punctual": {"lights": [
            {"type": "point", "color": [1.0, 0.9, 0.8], "intensity": 40.0, "range": 20.0},
            {"type": "spot", "color": [0.8, 0.9, 1.0], "intensity": 60.0, "range": 30.0, "spot": {"innerConeAngle": 0.3, "outerConeAngle": 0.6}},
            {"type": "directional", "color": [1.0, 1.0, 1.0], "intensity": 2.0}
        ]}},
        "materials": [
            {"name": "ground", "pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.8, 0.8, 1.0], "metallicFactor": 0.0, "roughnessFactor": 0.7}},
            {"name": "cube",
             "pbrMetallicRoughness": {"baseColorFactor": [0.9, 0.5, 0.2, 1.0], "metallicFactor": 0.3, "roughnessFactor": 0.4},
             "normalTexture": {"index": 0, "scale": 1.0},
             "occlusionTexture": {"index": 0, "strength": 0.5},
             "emissiveFactor": [0.1, 0.0, 0.0],
             "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 2.0}},
             "alphaMode": "MASK", "alphaCutoff": 0.5}
        ],
        "textures": [{"source": 0, "sampler": 0}],
        "samplers": [{"magFilter": 9729, "minFilter": 9987}],
        "images": [{"uri": normal_map_uri()}],
        "meshes": [
            {"name": "ground", "primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1, "TANGENT": 2, "TEXCOORD_0": 3}, "indices": 4, "material": 0}]},
            {"name": "cube", "primitives": [{"attributes": {"POSITION": 5, "NORMAL": 6, "TANGENT": 7, "TEXCOORD_0": 8}, "indices": 9, "material": 1}]}
        ],
        "buffers": [{"uri": uri, "byteLength": bytes.len()}],
        "bufferViews": [
            view(offsets[0], n * 12), view(offsets[1], n * 12), view(offsets[2], n * 16), view(offsets[3], n * 8),
            view(offsets[4], g.indices.len() * 2)
        ],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [-5.0, 0.0, -5.0], "max": [5.0, 0.0, 5.0]},
            {"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC3"},
            {"bufferView": 2, "componentType": 5126, "count": 4, "type": "VEC4"},
            {"bufferView": 3, "componentType": 5126, "count": 4, "type": "VEC2"},
            {"bufferView": 4, "componentType": 5123, "count": 6, "type": "SCALAR"},
            {"bufferView": 0, "byteOffset": 48, "componentType": 5126, "count": n - 4, "type": "VEC3", "min": [-0.5, 0.0, -0.5], "max": [0.5, 1.0, 0.5]},
            {"bufferView": 1, "byteOffset": 48, "componentType": 5126, "count": n - 4, "type": "VEC3"},
            {"bufferView": 2, "byteOffset": 64, "componentType": 5126, "count": n - 4, "type": "VEC4"},
            {"bufferView": 3, "byteOffset": 32, "componentType": 5126, "count": n - 4, "type": "VEC2"},
            {"bufferView": 4, "byteOffset": 12, "componentType": 5123, "count": g.indices.len() - 6, "type": "SCALAR"}
        ]
    })
}

/// The values every numeric field is set to. 1e39 is beyond f32: it reads as infinity.
pub const VALUES: [f64; 8] = [0.0, -1.0, -1e-30, 1e-30, 0.5, 1e30, 1e39, -1e39];

/// A numeric field and the values the specification allows in it.
struct Field {
    pointer: &'static str,
    names: &'static [&'static str],
    valid: fn(f64) -> bool,
}

fn f32_finite(v: f64) -> bool {
    (v as f32).is_finite()
}

fn unit(v: f64) -> bool {
    (0.0..=1.0).contains(&v)
}

/// Every numeric field the generator mutates, with the range glTF (and its extensions) allow.
/// Where the renderer cannot honour a value the specification permits (a field of view of π or
/// more, an intensity beyond what f32 shading carries), the range is what it can: those must be
/// named too.
fn fields() -> Vec<Field> {
    vec![
        Field {
            pointer: "/cameras/0/perspective/yfov",
            names: &["yfov"],
            valid: |v| f32_finite(v) && v > 0.0 && v < std::f64::consts::PI,
        },
        Field {
            pointer: "/cameras/0/perspective/znear",
            names: &["znear"],
            valid: |v| f32_finite(v) && v > 0.0 && v < 100.0,
        },
        Field { pointer: "/cameras/0/perspective/zfar", names: &["zfar"], valid: |v| f32_finite(v) && v > 0.05 },
        Field {
            pointer: "/cameras/0/perspective/aspectRatio",
            names: &["aspectRatio", "aspect ratio"],
            valid: |v| f32_finite(v) && v > 0.0,
        },
        Field { pointer: "/cameras/1/orthographic/xmag", names: &["xmag"], valid: |v| f32_finite(v) && v > 0.0 },
        Field { pointer: "/cameras/1/orthographic/ymag", names: &["ymag"], valid: |v| f32_finite(v) && v > 0.0 },
        Field {
            pointer: "/cameras/1/orthographic/znear",
            names: &["znear"],
            valid: |v| f32_finite(v) && (0.0..50.0).contains(&v),
        },
        Field { pointer: "/cameras/1/orthographic/zfar", names: &["zfar"], valid: |v| f32_finite(v) && v > 0.0 },
        Field {
            pointer: "/extensions/KHR_lights_punctual/lights/0/intensity",
            names: &["intensity"],
            valid: |v| (0.0..=1e15).contains(&v),
        },
        // Beyond f32 a range is infinite: the same as no range, which is what it means.
        Field { pointer: "/extensions/KHR_lights_punctual/lights/0/range", names: &["range"], valid: |v| v > 0.0 },
        Field { pointer: "/extensions/KHR_lights_punctual/lights/0/color/1", names: &["color"], valid: unit },
        Field {
            pointer: "/extensions/KHR_lights_punctual/lights/1/spot/innerConeAngle",
            names: &["cone"],
            valid: |v| (0.0..0.6).contains(&v),
        },
        Field {
            pointer: "/extensions/KHR_lights_punctual/lights/1/spot/outerConeAngle",
            names: &["cone"],
            valid: |v| v > 0.3 && v <= std::f64::consts::FRAC_PI_2,
        },
        Field {
            pointer: "/extensions/KHR_lights_punctual/lights/2/intensity",
            names: &["intensity"],
            valid: |v| (0.0..=1e15).contains(&v),
        },
        Field {
            pointer: "/materials/1/pbrMetallicRoughness/baseColorFactor/0",
            names: &["baseColorFactor"],
            valid: unit,
        },
        Field { pointer: "/materials/1/pbrMetallicRoughness/metallicFactor", names: &["metallicFactor"], valid: unit },
        Field {
            pointer: "/materials/1/pbrMetallicRoughness/roughnessFactor",
            names: &["roughnessFactor"],
            valid: unit,
        },
        Field { pointer: "/materials/1/normalTexture/scale", names: &["normalTexture.scale"], valid: f32_finite },
        Field { pointer: "/materials/1/occlusionTexture/strength", names: &["occlusionTexture.strength"], valid: unit },
        Field { pointer: "/materials/1/emissiveFactor/0", names: &["emissiveFactor"], valid: unit },
        Field { pointer: "/materials/1/alphaCutoff", names: &["alphaCutoff"], valid: |v| f32_finite(v) && v >= 0.0 },
        Field {
            pointer: "/materials/1/extensions/KHR_materials_emissive_strength/emissiveStrength",
            names: &["emissiveStrength"],
            valid: |v| f32_finite(v) && v >= 0.0,
        },
        Field { pointer: "/nodes/1/translation/0", names: &["translation", "node 1"], valid: f32_finite },
        Field { pointer: "/nodes/1/scale/1", names: &["scale", "node 1"], valid: f32_finite },
        Field {
            pointer: "/nodes/1/rotation/3",
            names: &["rotation", "node 1"],
            valid: |v| (v - 0.9238795).abs() < 1e-3,
        },
        Field { pointer: "/accessors/5/count", names: &["accessor", "count"], valid: |v| v == 0.5 },
        Field { pointer: "/accessors/5/byteOffset", names: &["accessor", "byteOffset", "offset"], valid: |v| v == 0.0 },
        Field {
            pointer: "/bufferViews/0/byteLength",
            names: &["bufferView", "byteLength", "accessor"],
            valid: |_| false,
        },
        Field {
            pointer: "/bufferViews/0/byteStride",
            names: &["byteStride", "bufferView", "stride"],
            valid: |_| false,
        },
    ]
}

/// Sets the value at a JSON pointer, adding the last member if the object lacks it.
fn set(json: &mut Value, pointer: &str, value: Value) {
    let (parent, key) = pointer.rsplit_once('/').expect("a pointer");
    match json.pointer_mut(parent).unwrap_or_else(|| panic!("{parent} exists")) {
        Value::Object(o) => {
            o.insert(key.to_owned(), value);
        }
        Value::Array(a) => a[key.parse::<usize>().expect("an index")] = value,
        other => panic!("{parent} is {other}"),
    }
}

/// Every case, in a fixed order: numeric fields × [`VALUES`], `extras` of every type on every
/// kind of object, and non-finite vertex data.
pub fn cases() -> Vec<Case> {
    let base = base_scene(None);
    let mut out = Vec::new();
    for field in fields() {
        for value in VALUES {
            let mut json = base.clone();
            // Counts and offsets are integers in the schema: a fractional or negative one is
            // a type error, and 0.5 stands for "a valid integer" (the original value).
            let integer = field.pointer.ends_with("count") || field.pointer.contains("byte");
            let new = if integer {
                if value == 0.5 {
                    continue;
                }
                if value.fract() == 0.0 && value.abs() < 1e15 { json!(value as i64) } else { json!(value) }
            } else {
                json!(value)
            };
            set(&mut json, field.pointer, new);
            let expect = if (field.valid)(value) { Expect::Valid } else { Expect::Named };
            out.push(Case {
                label: format!("{} = {value:e}", field.pointer),
                names: field.names.to_vec(),
                expect,
                json,
            });
        }
    }
    let extras: [(&str, Value); 7] = [
        ("null", Value::Null),
        ("bool", json!(true)),
        ("number", json!(-3.5)),
        ("string", json!("text")),
        ("array", json!([1, "two", [3]])),
        ("object", json!({"a": {"b": [null, 1.5]}})),
        ("huge number", json!(1e300)),
    ];
    let holders = [
        "",
        "/nodes/0",
        "/meshes/0",
        "/meshes/0/primitives/0",
        "/materials/1",
        "/cameras/0",
        "/scenes/0",
        "/accessors/0",
        "/asset",
        "/textures/0",
        "/extensions/KHR_lights_punctual/lights/0",
    ];
    for holder in holders {
        for (kind, value) in &extras {
            let mut json = base.clone();
            json.pointer_mut(holder)
                .and_then(Value::as_object_mut)
                .expect("an object")
                .insert("extras".into(), value.clone());
            out.push(Case {
                label: format!("{holder}/extras = {kind}"),
                names: Vec::new(),
                expect: Expect::Valid,
                json,
            });
        }
    }
    // EXT_mesh_gpu_instancing on the cube, its attributes taken from the scene's own accessors:
    // 0 (VEC3 × 4, the ground's positions), 1 (VEC3 × 4, normals), 2 (VEC4 × 4, tangents: w = ±1,
    // so not unit quaternions), 6 (VEC3 × 24).
    let instancing: [(&str, Value, Expect, &[&'static str]); 7] = [
        ("translations", json!({"TRANSLATION": 0}), Expect::Valid, &[]),
        ("translations and scales", json!({"TRANSLATION": 0, "SCALE": 1}), Expect::Valid, &[]),
        ("no accessor 99", json!({"TRANSLATION": 99}), Expect::Named, &["TRANSLATION"]),
        ("counts 4 and 24", json!({"TRANSLATION": 0, "SCALE": 6}), Expect::Named, &["count"]),
        ("a VEC3 rotation", json!({"ROTATION": 0}), Expect::Named, &["ROTATION"]),
        ("non-unit rotations", json!({"ROTATION": 2}), Expect::Named, &["rotation"]),
        ("no attributes", json!({}), Expect::Named, &["attributes"]),
    ];
    for (what, attributes, expect, names) in instancing {
        let mut json = base.clone();
        json["extensionsUsed"].as_array_mut().expect("a list").push(json!("EXT_mesh_gpu_instancing"));
        let ext = if attributes.as_object().is_some_and(|o| o.is_empty()) {
            json!({})
        } else {
            json!({"attributes": attributes})
        };
        set(&mut json, "/nodes/1/extensions", json!({"EXT_mesh_gpu_instancing": ext}));
        out.push(Case { label: format!("cube instanced: {what}"), names: names.to_vec(), expect, json });
    }
    for (attribute, name) in ["POSITION", "NORMAL", "TANGENT", "TEXCOORD_0"].iter().enumerate() {
        for value in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY, 0.0] {
            let json = base_scene(Some(BinaryMutation { attribute, value }));
            // A zero normal or tangent is as broken as a NaN one; zero positions and UVs are fine.
            let expect =
                if value == 0.0 && (attribute == 0 || attribute == 3) { Expect::Valid } else { Expect::Survive };
            out.push(Case {
                label: format!("{name} of one vertex = {value}"),
                names: vec!["replaced", "non-finite"],
                expect,
                json,
            });
        }
    }
    out
}
