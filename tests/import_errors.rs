//! Every kind of bad glTF input gives a typed error naming the file and the problem, never a
//! panic, and leaves the world exactly as it was.

use std::path::{Path, PathBuf};

use penumbra::engine::import::{GltfScene, ImportError, ImportErrorKind, ImportOptions, Limit, load_scene};
use penumbra::prelude::*;

mod common;
use common::{asset, scratch_dir};

/// A valid one-triangle glTF whose buffer lives in `triangle.bin` beside it.
fn triangle_json(buffer_uri: &str, extra_root: &str) -> String {
    format!(
        r#"{{
  "asset": {{"version": "2.0"}},
  {extra_root}
  "scene": 0,
  "scenes": [{{"nodes": [0]}}],
  "nodes": [{{"mesh": 0}}],
  "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0}}}}]}}],
  "buffers": [{{"uri": "{buffer_uri}", "byteLength": 36}}],
  "bufferViews": [{{"buffer": 0, "byteOffset": 0, "byteLength": 36}}],
  "accessors": [{{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                  "min": [0,0,0], "max": [1,1,0]}}]
}}"#
    )
}

fn triangle_bin() -> Vec<u8> {
    [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0].iter().flat_map(|f| f.to_le_bytes()).collect()
}

fn write_scene(name: &str, json: &str, with_bin: bool) -> PathBuf {
    let dir = scratch_dir(name);
    if with_bin {
        std::fs::write(dir.join("triangle.bin"), triangle_bin()).unwrap();
    }
    let path = dir.join("scene.gltf");
    std::fs::write(&path, json).unwrap();
    path
}

/// Loads into a fresh world and checks that a failure leaves no entity or asset behind.
fn load_expecting_error(path: &Path) -> penumbra::engine::import::ImportError {
    load_expecting_error_with(path, &ImportOptions::default())
}

fn load_expecting_error_with(path: &Path, options: &ImportOptions) -> penumbra::engine::import::ImportError {
    let mut app = App::new();
    app.add_plugins(CorePlugin);
    let before = app.world.entities().count_spawned();
    let err = load_scene(&mut app.world, path, options).expect_err("load must fail");
    assert_eq!(app.world.entities().count_spawned(), before, "a failed load left entities behind");
    assert!(app.world.resource::<Assets<Mesh>>().is_empty(), "a failed load left meshes behind");
    let msg = err.to_string();
    assert!(msg.starts_with(&path.display().to_string()), "error must name the file: {msg}");
    err
}

#[test]
fn the_valid_fixture_loads() {
    let path = write_scene("valid", &triangle_json("triangle.bin", ""), true);
    let mut app = App::new();
    app.add_plugins(CorePlugin);
    load_scene(&mut app.world, &path, &ImportOptions::default()).expect("fixture is valid");
    assert_eq!(app.world.resource::<Assets<Mesh>>().len(), 1);
}

#[test]
fn truncated_glb_is_malformed() {
    let bytes = std::fs::read(asset("BoxTextured/BoxTextured.glb")).unwrap();
    let path = scratch_dir("truncated").join("box.glb");
    std::fs::write(&path, &bytes[..bytes.len() / 2]).unwrap();
    let err = load_expecting_error(&path);
    assert!(matches!(err.kind, ImportErrorKind::Malformed(_)), "{err}");
    assert!(err.to_string().contains("truncated"), "{err}");
}

#[test]
fn bad_json_is_malformed() {
    let path = write_scene("badjson", r#"{"asset": {"version": "2.0"}, "nodes": [ {"mesh": 0 }"#, false);
    let err = load_expecting_error(&path);
    assert!(matches!(err.kind, ImportErrorKind::Malformed(_)), "{err}");
}

#[test]
fn missing_buffer_file_names_the_buffer() {
    let path = write_scene("missingbuf", &triangle_json("nowhere.bin", ""), false);
    let err = load_expecting_error(&path);
    assert!(matches!(err.kind, ImportErrorKind::Buffer { index: 0, .. }), "{err}");
    assert!(err.to_string().contains("nowhere.bin"), "{err}");
}

#[test]
fn missing_image_names_the_image() {
    let json = triangle_json("triangle.bin", "").replacen(
        "\"scene\": 0,",
        r#""scene": 0,
  "images": [{"uri": "missing.png"}], "textures": [{"source": 0}],
  "materials": [{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}],"#,
        1,
    );
    let json = json.replace(r#""attributes": {"POSITION": 0}}"#, r#""attributes": {"POSITION": 0}, "material": 0}"#);
    let path = write_scene("missingimg", &json, true);
    let err = load_expecting_error(&path);
    assert!(matches!(err.kind, ImportErrorKind::Image { index: 0, .. }), "{err}");
    assert!(err.to_string().contains("missing.png"), "{err}");
}

#[test]
fn accessor_past_the_buffer_end_is_refused() {
    let json = triangle_json("triangle.bin", "").replace("\"count\": 3", "\"count\": 300");
    let path = write_scene("accrange", &json, true);
    let err = load_expecting_error(&path);
    assert!(matches!(err.kind, ImportErrorKind::Accessor { index: 0, .. }), "{err}");
}

#[test]
fn buffer_view_past_the_buffer_end_is_refused() {
    let json = triangle_json("triangle.bin", "")
        .replace("\"byteOffset\": 0, \"byteLength\": 36", "\"byteOffset\": 24, \"byteLength\": 36");
    let path = write_scene("viewrange", &json, true);
    let err = load_expecting_error(&path);
    assert!(matches!(err.kind, ImportErrorKind::Accessor { .. }), "{err}");
}

#[test]
fn unsupported_required_extension_is_named() {
    let json =
        triangle_json("triangle.bin", r#""extensionsUsed": ["EXT_made_up"], "extensionsRequired": ["EXT_made_up"],"#);
    let path = write_scene("reqext", &json, true);
    let err = load_expecting_error(&path);
    assert!(matches!(&err.kind, ImportErrorKind::UnsupportedExtension { name } if name == "EXT_made_up"), "{err}");
    assert!(err.to_string().contains("EXT_made_up"), "{err}");
}

#[test]
fn uri_outside_the_scene_folder_is_refused() {
    for uri in ["../triangle.bin", "/etc/passwd", "sub/../../triangle.bin"] {
        let path = write_scene("outside", &triangle_json(uri, ""), true);
        let err = load_expecting_error(&path);
        assert!(matches!(&err.kind, ImportErrorKind::UriOutsideFolder { .. }), "{uri}: {err}");
    }
}

#[cfg(unix)]
#[test]
fn symlink_out_of_the_scene_folder_is_refused() {
    let outside = scratch_dir("symlink-target");
    std::fs::write(outside.join("secret.bin"), triangle_bin()).unwrap();
    let path = write_scene("symlink", &triangle_json("link.bin", ""), false);
    let link = path.parent().unwrap().join("link.bin");
    let _ = std::fs::remove_file(&link);
    std::os::unix::fs::symlink(outside.join("secret.bin"), &link).unwrap();
    let err = load_expecting_error(&path);
    assert!(matches!(&err.kind, ImportErrorKind::UriOutsideFolder { .. }), "{err}");
    // ... unless the user allows it.
    let mut world = App::new().world;
    let opts = ImportOptions { allow_outside_folder: true, ..Default::default() };
    load_scene(&mut world, &path, &opts).expect("allowed by the flag");
}

#[test]
fn unsupported_uri_scheme_is_refused() {
    let path = write_scene("scheme", &triangle_json("https://example.com/triangle.bin", ""), false);
    let err = load_expecting_error(&path);
    assert!(err.to_string().contains("scheme"), "{err}");
}

#[test]
fn buffer_shorter_than_its_byte_length_is_refused() {
    let json = triangle_json("triangle.bin", "")
        .replace("\"byteLength\": 36}],\n  \"bufferViews", "\"byteLength\": 360}],\n  \"bufferViews");
    let path = write_scene("shortbuf", &json, true);
    let err = load_expecting_error(&path);
    assert!(matches!(err.kind, ImportErrorKind::Buffer { .. }), "{err}");
}

#[test]
fn node_cycles_and_shared_children_are_refused() {
    let json = triangle_json("triangle.bin", "")
        .replace(r#""nodes": [{"mesh": 0}]"#, r#""nodes": [{"mesh": 0}, {"children": [2]}, {"children": [1]}]"#);
    let path = write_scene("cycle", &json, true);
    let err = load_expecting_error(&path);
    assert!(matches!(err.kind, ImportErrorKind::Hierarchy(_)), "{err}");
    let json = triangle_json("triangle.bin", "")
        .replace(r#""nodes": [{"mesh": 0}]"#, r#""nodes": [{"mesh": 0}, {"children": [0]}, {"children": [0]}]"#)
        .replace(r#""scenes": [{"nodes": [0]}]"#, r#""scenes": [{"nodes": [1, 2]}]"#);
    let path = write_scene("shared", &json, true);
    let err = load_expecting_error(&path);
    assert!(matches!(err.kind, ImportErrorKind::Hierarchy(_)), "{err}");
}

#[test]
fn out_of_range_index_in_json_is_invalid() {
    let json = triangle_json("triangle.bin", "").replace(r#""nodes": [{"mesh": 0}]"#, r#""nodes": [{"mesh": 7}]"#);
    let path = write_scene("badindex", &json, true);
    let err = load_expecting_error(&path);
    assert!(matches!(err.kind, ImportErrorKind::Invalid(_)), "{err}");
    assert!(err.to_string().contains("nodes[0].mesh"), "{err}");
}

#[test]
fn requesting_a_missing_scene_is_an_error() {
    let mut world = App::new().world;
    let opts = ImportOptions { scene: Some(5), ..Default::default() };
    let err = load_scene(&mut world, &asset("MultipleScenes/MultipleScenes.gltf"), &opts).unwrap_err();
    assert!(matches!(err.kind, ImportErrorKind::NoSuchScene { index: 5, count: 2 }), "{err}");
}

#[test]
fn index_out_of_vertex_range_is_refused() {
    let json = triangle_json("triangle.bin", "")
        .replace(r#""uri": "triangle.bin", "byteLength": 36"#, r#""uri": "triangle.bin", "byteLength": 42"#)
        .replace(
            r#""bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 36}]"#,
            r#""bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 36}, {"buffer": 0, "byteOffset": 36, "byteLength": 6}]"#,
        )
        .replace(
            r#""max": [1,1,0]}]"#,
            r#""max": [1,1,0]}, {"bufferView": 1, "componentType": 5123, "count": 3, "type": "SCALAR"}]"#,
        )
        .replace(r#""attributes": {"POSITION": 0}}"#, r#""attributes": {"POSITION": 0}, "indices": 1}"#);
    let dir = scratch_dir("badindices");
    let mut bin = triangle_bin();
    bin.extend_from_slice(&[0, 0, 1, 0, 9, 0]);
    std::fs::write(dir.join("triangle.bin"), bin).unwrap();
    let path = dir.join("scene.gltf");
    std::fs::write(&path, json).unwrap();
    let err = load_expecting_error(&path);
    assert!(err.to_string().contains("index 9"), "{err}");
}

#[test]
fn an_accessor_asking_for_absurd_memory_is_refused_before_allocating() {
    // A sparse accessor needs no bufferView: its base is all zeros, and nothing in the file
    // bounds its count.
    let json = triangle_json("triangle.bin", "").replace(
        r#""accessors": [{"bufferView": 0, "componentType": 5126, "count": 3,"#,
        r#""accessors": [{"componentType": 5126, "count": 4000000000,
                  "sparse": {"count": 1, "indices": {"bufferView": 0, "componentType": 5125},
                             "values": {"bufferView": 0}},"#,
    );
    let path = write_scene("hugecount", &json, true);
    let err = load_expecting_error(&path);
    assert!(matches!(err.kind, ImportErrorKind::LimitExceeded { .. }), "{err}");
    assert!(err.to_string().contains("--limit vertices=N"), "the file-wide total is checked first: {err}");
}

/// Loads into a fresh world, which must succeed; returns the app for further checks.
fn load_ok(path: &Path, options: &ImportOptions, why: &str) -> App {
    let mut app = App::new();
    app.add_plugins(CorePlugin);
    load_scene(&mut app.world, path, options).expect(why);
    app
}

/// Options with one limit set (`NAME=N`, as on the command line).
fn with_limit(setting: &str) -> ImportOptions {
    let mut options = ImportOptions::default();
    options.limits.apply(setting).unwrap();
    options
}

fn assert_limit(err: &penumbra::engine::import::ImportError, limit: Limit) {
    match &err.kind {
        ImportErrorKind::LimitExceeded { name, .. } => assert_eq!(*name, limit, "{err}"),
        _ => panic!("expected the {limit} limit, got: {err}"),
    }
    assert!(err.to_string().contains(&format!("--limit {limit}=N")), "says how to raise it: {err}");
}

#[test]
fn an_out_of_range_position_accessor_is_an_error_not_a_panic() {
    // gltf-json's own validation indexes the accessor list with POSITION unchecked.
    let json = triangle_json("triangle.bin", "").replace(r#""POSITION": 0"#, r#""POSITION": 9"#);
    let err = load_expecting_error(&write_scene("position9", &json, true));
    assert!(matches!(err.kind, ImportErrorKind::Invalid(_)) && err.to_string().contains("accessor 9"), "{err}");
}

#[test]
fn one_accessor_reused_by_many_primitives_meets_the_totals() {
    let prims = vec![r#"{"attributes": {"POSITION": 0}}"#; 50].join(",");
    let json = triangle_json("triangle.bin", "").replace(r#"[{"attributes": {"POSITION": 0}}]"#, &format!("[{prims}]"));
    let path = write_scene("reused", &json, true);
    // 150 vertices declared; 50 × 36 bytes decoded.
    assert_limit(&load_expecting_error_with(&path, &with_limit("vertices=149")), Limit::Vertices);
    assert_limit(&load_expecting_error_with(&path, &with_limit("decoded-bytes=1000")), Limit::DecodedBytes);
    load_ok(&path, &with_limit("vertices=150"), "at the limit is allowed");
}

#[test]
fn deep_hierarchies_are_refused_past_the_node_depth_limit() {
    let chain = |n: usize| {
        let nodes: Vec<String> = (0..n)
            .map(|i| if i + 1 < n { format!(r#"{{"children": [{}]}}"#, i + 1) } else { r#"{"mesh": 0}"#.into() })
            .collect();
        triangle_json("triangle.bin", "")
            .replace(r#""nodes": [{"mesh": 0}]"#, &format!(r#""nodes": [{}]"#, nodes.join(",")))
    };
    let err = load_expecting_error(&write_scene("deep", &chain(1100), true));
    assert_limit(&err, Limit::NodeDepth);
    let path = write_scene("deep40", &chain(40), true);
    assert_limit(&load_expecting_error_with(&path, &with_limit("node-depth=39")), Limit::NodeDepth);
    load_ok(&path, &with_limit("node-depth=40"), "40 levels under a limit of 40");
}

#[test]
fn a_scene_listing_a_root_twice_is_refused() {
    let json =
        triangle_json("triangle.bin", "").replace(r#""scenes": [{"nodes": [0]}]"#, r#""scenes": [{"nodes": [0, 0]}]"#);
    let err = load_expecting_error(&write_scene("tworoots", &json, true));
    assert!(matches!(err.kind, ImportErrorKind::Hierarchy(_)), "{err}");
}

#[test]
fn animation_keys_buffer_sizes_and_image_files_have_limits() {
    let anim = r#""animations": [{"channels": [{"sampler": 0, "target": {"node": 0, "path": "translation"}}],
                                  "samplers": [{"input": 0, "output": 0}]}],"#;
    let path = write_scene("animkeys", &triangle_json("triangle.bin", anim), true);
    assert_limit(&load_expecting_error_with(&path, &with_limit("animation-keys=2")), Limit::AnimationKeys);

    let path = write_scene("bufbytes", &triangle_json("triangle.bin", ""), true);
    assert_limit(&load_expecting_error_with(&path, &with_limit("buffer-bytes=35")), Limit::BufferBytes);

    let textured = triangle_json(
        "triangle.bin",
        r#""images": [{"uri": "big.png"}], "textures": [{"source": 0}],
        "materials": [{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}],"#,
    )
    .replace(r#"{"attributes": {"POSITION": 0}}"#, r#"{"attributes": {"POSITION": 0}, "material": 0}"#);
    let path = write_scene("imagebytes", &textured, true);
    std::fs::write(path.parent().unwrap().join("big.png"), vec![0u8; 4096]).unwrap();
    let err = load_expecting_error_with(&path, &with_limit("image-bytes=4000"));
    assert_limit(&err, Limit::ImageBytes);
}

#[test]
fn a_skin_with_an_absurd_sparse_inverse_bind_accessor_is_refused_before_allocating() {
    let skin = r#""skins": [{"joints": [0], "inverseBindMatrices": 1}],"#;
    let json = triangle_json("triangle.bin", skin).replace(
        r#""min": [0,0,0], "max": [1,1,0]}]"#,
        r#""min": [0,0,0], "max": [1,1,0]},
           {"componentType": 5126, "count": 4000000000, "type": "MAT4",
            "sparse": {"count": 1, "indices": {"bufferView": 0, "componentType": 5125}, "values": {"bufferView": 0}}}]"#,
    );
    let err = load_expecting_error(&write_scene("hugeskin", &json, true));
    assert_limit(&err, Limit::AccessorElements);
}

#[test]
fn an_obj_face_index_of_i64_min_is_an_error_not_an_overflow() {
    let dir = scratch_dir("obj-i64min");
    let path = dir.join("bad.obj");
    std::fs::write(&path, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -9223372036854775808 1 2\n").unwrap();
    let err = load_expecting_error(&path);
    assert!(err.to_string().contains("names no vertex"), "{err}");
}

/// A small valid PNG of `w`×`h` pixels.
fn png(w: u32, h: u32) -> Vec<u8> {
    let mut out = std::io::Cursor::new(Vec::new());
    image::RgbaImage::from_pixel(w, h, image::Rgba([200, 100, 50, 255]))
        .write_to(&mut out, image::ImageFormat::Png)
        .unwrap();
    out.into_inner()
}

/// The triangle with `images` (URIs), each the base colour of a material of its own (the importer
/// decodes every image a material uses, drawn or not).
fn textured_triangle(name: &str, images: &[&str]) -> PathBuf {
    let list: Vec<String> = images.iter().map(|u| format!(r#"{{"uri": "{u}"}}"#)).collect();
    let textures: Vec<String> = (0..images.len()).map(|i| format!(r#"{{"source": {i}}}"#)).collect();
    let materials: Vec<String> = (0..images.len())
        .map(|i| format!(r#"{{"pbrMetallicRoughness": {{"baseColorTexture": {{"index": {i}}}}}}}"#))
        .collect();
    let extra = format!(
        r#""images": [{}], "textures": [{}], "materials": [{}],"#,
        list.join(","),
        textures.join(","),
        materials.join(",")
    );
    let json = triangle_json("triangle.bin", &extra)
        .replace(r#"{"attributes": {"POSITION": 0}}"#, r#"{"attributes": {"POSITION": 0}, "material": 0}"#);
    write_scene(name, &json, true)
}

#[test]
fn decoded_image_totals_are_checked_from_headers_before_decoding() {
    let path = textured_triangle("imagetotal", &["a.png", "b.png"]);
    let dir = path.parent().unwrap();
    std::fs::write(dir.join("a.png"), png(4, 4)).unwrap();
    std::fs::write(dir.join("b.png"), png(4, 4)).unwrap();
    // 64 bytes each decoded, and 20 of mip chain (2×2 and 1×1): 84 held.
    assert_limit(&load_expecting_error_with(&path, &with_limit("total-image-bytes=100")), Limit::TotalImageBytes);
    assert_limit(&load_expecting_error_with(&path, &with_limit("total-image-bytes=167")), Limit::TotalImageBytes);
    load_ok(&path, &with_limit("total-image-bytes=168"), "168 bytes of images and chains fit");
    // One image named three times is read and decoded once: it counts once.
    let path = textured_triangle("imageshared", &["a.png", "a.png", "a.png"]);
    std::fs::write(path.parent().unwrap().join("a.png"), png(4, 4)).unwrap();
    let app = load_ok(&path, &with_limit("total-image-bytes=84"), "one decode of 84 bytes");
    assert_eq!(app.world.resource::<Assets<Image>>().len(), 1, "the three entries share one image");
}

#[test]
fn the_bytes_read_from_files_have_a_total() {
    // Two buffers naming the same 36-byte file: 72 bytes read.
    let json = triangle_json("triangle.bin", "").replace(
        r#""buffers": [{"uri": "triangle.bin", "byteLength": 36}]"#,
        r#""buffers": [{"uri": "triangle.bin", "byteLength": 36}, {"uri": "triangle.bin", "byteLength": 36}]"#,
    );
    let path = write_scene("readtotal", &json, true);
    assert_limit(&load_expecting_error_with(&path, &with_limit("read-bytes=71")), Limit::ReadBytes);
    load_ok(&path, &with_limit("read-bytes=72"), "72 bytes may be read");
}

#[test]
fn obj_totals_and_textures_count_against_the_limits() {
    let dir = scratch_dir("obj-limits");
    let path = dir.join("two.obj");
    std::fs::write(
        &path,
        "mtllib two.mtl\nusemtl m\no a\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\no b\nv 0 0 1\nv 1 0 1\nv 0 1 1\nf 4 5 6\n",
    )
    .unwrap();
    std::fs::write(dir.join("two.mtl"), "newmtl m\nmap_Kd tex.png\n").unwrap();
    std::fs::write(dir.join("tex.png"), png(8, 8)).unwrap();
    // Three vertices per object: six over the file.
    assert_limit(&load_expecting_error_with(&path, &with_limit("vertices=5")), Limit::Vertices);
    // The 8×8 texture: 256 bytes decoded and 84 of mip chain.
    assert_limit(&load_expecting_error_with(&path, &with_limit("total-image-bytes=339")), Limit::TotalImageBytes);
    load_ok(&path, &with_limit("total-image-bytes=340"), "the texture and its chain fit");
    load_ok(&path, &with_limit("vertices=6"), "six vertices fit");
}

/// `scene` spawned into a fresh world (its materials and images are the world's assets).
fn spawned(scene: &penumbra::engine::import::GltfScene) -> App {
    let mut app = App::new();
    app.add_plugins(CorePlugin);
    scene.spawn(&mut app.world);
    app
}

/// KHR_materials_ior and KHR_materials_specular values outside their schemas' ranges are
/// replaced (the default, or the nearest allowed value) with a warning naming the material and
/// the value, and the file still loads.
#[test]
fn out_of_range_ior_and_specular_are_replaced_with_a_warning_naming_the_material() {
    let json = triangle_json(
        "triangle.bin",
        r#""extensionsUsed": ["KHR_materials_ior", "KHR_materials_specular"],
  "materials": [{"name": "odd", "extensions": {
      "KHR_materials_ior": {"ior": 0.5},
      "KHR_materials_specular": {"specularFactor": 2.0, "specularColorFactor": [-1.0, 0.0, 0.0]}}}],"#,
    )
    .replace(r#""attributes": {"POSITION": 0}"#, r#""attributes": {"POSITION": 0}, "material": 0"#);
    let path = write_scene("odd_specular", &json, true);
    let scene = penumbra::engine::import::GltfScene::load(&path, &ImportOptions::default()).expect("loads");
    let warnings = scene.warnings.join("\n");
    for expected in
        ["material \"odd\": KHR_materials_ior ior 0.5", "specularFactor 2 is outside 0..=1", "specularColorFactor"]
    {
        assert!(warnings.contains(expected), "{expected:?} in {warnings}");
    }
    assert!(!warnings.contains("not supported"), "{warnings}");
    let app = spawned(&scene);
    let materials = app.world.resource::<Assets<StandardMaterial>>();
    let (_, m) = materials.iter().next().expect("one material");
    assert_eq!((m.ior, m.specular, m.specular_color), (1.5, 1.0, Vec3::ONE));
}

/// The specular sample imports every parameter it sets, with no warning.
#[test]
fn the_specular_sample_imports_its_factors_and_textures() {
    let scene = penumbra::engine::import::GltfScene::load(&asset("SpecularTest/SpecularTest.glb"), &Default::default())
        .expect("loads");
    assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
    let app = spawned(&scene);
    let materials = app.world.resource::<Assets<StandardMaterial>>();
    let all: Vec<&StandardMaterial> = materials.iter().map(|(_, m)| m).collect();
    assert!(all.iter().any(|m| m.specular == 0.0), "the black sphere's strength 0");
    assert!(all.iter().any(|m| m.specular_texture.is_some()));
    assert!(all.iter().any(|m| m.specular_color_texture.is_some()));
    assert!(all.iter().any(|m| m.specular_color.max_element() > 1.0), "colour factors above 1 are kept");
}

/// KHR_materials_pbrSpecularGlossiness is converted, not refused: diffuse to base colour,
/// specular to the specular colour at IOR 0 (F0 = that colour), roughness = 1 − glossiness,
/// metallic 0; with a warning that the conversion is approximate.
#[test]
fn specular_glossiness_factors_convert_to_the_specular_extension_at_ior_zero() {
    let json = triangle_json(
        "triangle.bin",
        r#""extensionsUsed": ["KHR_materials_pbrSpecularGlossiness"],
  "extensionsRequired": ["KHR_materials_pbrSpecularGlossiness"],
  "materials": [{"name": "old", "extensions": {"KHR_materials_pbrSpecularGlossiness": {
      "diffuseFactor": [0.5, 0.25, 1.0, 1.0], "specularFactor": [0.2, 0.3, 0.4], "glossinessFactor": 0.75}}}],"#,
    )
    .replace(r#""attributes": {"POSITION": 0}"#, r#""attributes": {"POSITION": 0}, "material": 0"#);
    let path = write_scene("spec_gloss", &json, true);
    let scene = penumbra::engine::import::GltfScene::load(&path, &ImportOptions::default()).expect("loads");
    let warnings = scene.warnings.join("\n");
    assert!(
        warnings.contains("material \"old\": KHR_materials_pbrSpecularGlossiness (archived) converted"),
        "{warnings}"
    );
    assert!(warnings.contains("approximate"), "{warnings}");
    let app = spawned(&scene);
    let materials = app.world.resource::<Assets<StandardMaterial>>();
    let (_, m) = materials.iter().next().expect("one material");
    assert_eq!(m.base_color, Vec4::new(0.5, 0.25, 1.0, 1.0));
    assert_eq!((m.metallic, m.roughness, m.ior, m.specular), (0.0, 0.25, 0.0, 1.0));
    assert_eq!(m.specular_color, Vec3::new(0.2, 0.3, 0.4));
    assert_eq!(m.ior_reflectance(), 1.0, "IOR 0: F0 is the specular colour");
}

/// The sample with a specular-glossiness bottle beside its metallic-roughness twin: the
/// converted material reads its diffuse texture as base colour, its specular-glossiness texture
/// as specular colour and, through an image made at import, as roughness.
#[test]
fn the_specular_glossiness_sample_converts_its_textures() {
    let scene = penumbra::engine::import::GltfScene::load(
        &asset("SpecGlossVsMetalRough/SpecGlossVsMetalRough.gltf"),
        &ImportOptions::default(),
    )
    .expect("loads");
    let converted = scene.warnings.iter().filter(|w| w.contains("converted to metallic-roughness")).count();
    assert_eq!(converted, 2, "{:?}", scene.warnings);
    assert!(!scene.warnings.iter().any(|w| w.contains("not supported")), "{:?}", scene.warnings);
    let app = spawned(&scene);
    let materials = app.world.resource::<Assets<StandardMaterial>>();
    let bottle = materials
        .iter()
        .map(|(_, m)| m)
        .find(|m| m.specular_color_texture.is_some() && m.normal_texture.is_some())
        .expect("the specular-glossiness bottle");
    assert_eq!((bottle.metallic, bottle.roughness, bottle.ior), (0.0, 1.0, 0.0));
    let (rough, sg) = (bottle.metallic_roughness_texture.unwrap(), bottle.specular_color_texture.unwrap());
    assert!(bottle.base_color_texture.is_some());
    assert_ne!(rough.image, sg.image, "roughness comes from an image made from the glossiness");
    let images = app.world.resource::<Assets<Image>>();
    let roughness = images.get(rough.image).expect("the roughness image");
    assert!(roughness.rgba8.chunks_exact(4).all(|p| p[0] == 255 && p[2] == 0), "occlusion 1, metallic 0");
}

/// KHR_materials_clearcoat is read from the material's JSON: factors, textures and the coat's
/// normal scale; a factor out of range is clamped and a texture index past the file's textures
/// is dropped, each with a warning naming the material.
#[test]
fn clearcoat_is_read_and_bad_values_are_named() {
    let json = triangle_json(
        "triangle.bin",
        r#""extensionsUsed": ["KHR_materials_clearcoat"],
  "materials": [{"name": "coated", "extensions": {"KHR_materials_clearcoat": {
      "clearcoatFactor": 1.5, "clearcoatRoughnessFactor": 0.25,
      "clearcoatTexture": {"index": 7}}}}],"#,
    )
    .replace(r#""attributes": {"POSITION": 0}"#, r#""attributes": {"POSITION": 0}, "material": 0"#);
    let path = write_scene("clearcoat", &json, true);
    let scene = penumbra::engine::import::GltfScene::load(&path, &ImportOptions::default()).expect("loads");
    let warnings = scene.warnings.join("\n");
    assert!(warnings.contains("material \"coated\": KHR_materials_clearcoat clearcoatFactor 1.5"), "{warnings}");
    assert!(warnings.contains("clearcoatTexture names no texture of the file (7)"), "{warnings}");
    assert!(!warnings.contains("not supported"), "{warnings}");
    let app = spawned(&scene);
    let materials = app.world.resource::<Assets<StandardMaterial>>();
    let (_, m) = materials.iter().next().expect("one material");
    assert_eq!((m.clearcoat, m.clearcoat_roughness), (1.0, 0.25));
    assert!(m.clearcoat_texture.is_none());
}

/// KHR_materials_sheen is read from the material's JSON: the sheen's colour, roughness and
/// textures; a colour out of range is clamped, a malformed one falls back to black, and a
/// texture index past the file's textures is dropped, each with a warning naming the material.
#[test]
fn sheen_is_read_and_bad_values_are_named() {
    let json = triangle_json(
        "triangle.bin",
        r#""extensionsUsed": ["KHR_materials_sheen"],
  "materials": [{"name": "velvet", "extensions": {"KHR_materials_sheen": {
      "sheenColorFactor": [1.5, 0.5, 0.25], "sheenRoughnessFactor": 0.75,
      "sheenColorTexture": {"index": 3}}}},
    {"name": "broken", "extensions": {"KHR_materials_sheen": {"sheenColorFactor": [1, "a", 0]}}}],"#,
    )
    .replace(r#""attributes": {"POSITION": 0}"#, r#""attributes": {"POSITION": 0}, "material": 0"#);
    let path = write_scene("sheen", &json, true);
    let scene = penumbra::engine::import::GltfScene::load(&path, &ImportOptions::default()).expect("loads");
    let warnings = scene.warnings.join("\n");
    assert!(warnings.contains("material \"velvet\": KHR_materials_sheen sheenColorFactor"), "{warnings}");
    assert!(warnings.contains("is outside 0..=1; clamped"), "{warnings}");
    assert!(warnings.contains("sheenColorTexture names no texture of the file (3)"), "{warnings}");
    assert!(warnings.contains("material \"broken\": KHR_materials_sheen sheenColorFactor"), "{warnings}");
    assert!(!warnings.contains("not supported"), "{warnings}");
    let app = spawned(&scene);
    let materials = app.world.resource::<Assets<StandardMaterial>>();
    let velvet = materials.iter().map(|(_, m)| m).find(|m| m.sheen_roughness == 0.75).expect("the velvet");
    assert_eq!(velvet.sheen_color, Vec3::new(1.0, 0.5, 0.25));
    assert!(velvet.sheen_color_texture.is_none());
}

/// KHR_materials_transmission, _volume and _dispersion are read from the material's JSON; a
/// negative thickness, a non-positive attenuation distance and a negative dispersion fall back
/// to the extension's defaults, each with a warning naming the material.
#[test]
fn transmission_and_volume_are_read_and_bad_values_are_named() {
    let json = triangle_json(
        "triangle.bin",
        r#""extensionsUsed": ["KHR_materials_transmission", "KHR_materials_volume", "KHR_materials_dispersion"],
  "materials": [{"name": "glass", "extensions": {
      "KHR_materials_transmission": {"transmissionFactor": 0.75},
      "KHR_materials_volume": {"thicknessFactor": 0.5, "attenuationDistance": 2.0,
                               "attenuationColor": [0.5, 0.25, 1.0]},
      "KHR_materials_dispersion": {"dispersion": 0.3}}},
    {"name": "bad", "extensions": {
      "KHR_materials_transmission": {"transmissionFactor": 1},
      "KHR_materials_volume": {"thicknessFactor": -1, "attenuationDistance": 0},
      "KHR_materials_dispersion": {"dispersion": -2}}}],"#,
    )
    .replace(r#""attributes": {"POSITION": 0}"#, r#""attributes": {"POSITION": 0}, "material": 0"#);
    let path = write_scene("transmission", &json, true);
    let scene = penumbra::engine::import::GltfScene::load(&path, &ImportOptions::default()).expect("loads");
    let warnings = scene.warnings.join("\n");
    assert!(warnings.contains("material \"bad\": KHR_materials_volume thicknessFactor -1"), "{warnings}");
    assert!(warnings.contains("attenuationDistance 0 is not a positive number"), "{warnings}");
    assert!(warnings.contains("KHR_materials_dispersion dispersion -2"), "{warnings}");
    assert!(!warnings.contains("not supported"), "{warnings}");
    let app = spawned(&scene);
    let materials = app.world.resource::<Assets<StandardMaterial>>();
    let glass = materials.iter().map(|(_, m)| m).find(|m| m.transmission == 0.75).expect("the glass");
    assert_eq!((glass.thickness, glass.attenuation_distance, glass.dispersion), (0.5, 2.0, 0.3));
    assert_eq!(glass.attenuation_color, Vec3::new(0.5, 0.25, 1.0));
}

/// KHR_materials_anisotropy is read from the material's JSON (strength, rotation, texture),
/// and a rotation that is not a number is named with the material.
#[test]
fn anisotropy_is_read_and_bad_values_are_named() {
    let json = triangle_json(
        "triangle.bin",
        r#""extensionsUsed": ["KHR_materials_anisotropy"],
  "materials": [{"name": "brushed", "extensions": {"KHR_materials_anisotropy": {
      "anisotropyStrength": 0.6, "anisotropyRotation": 1.5}}},
    {"name": "bad", "extensions": {"KHR_materials_anisotropy": {"anisotropyRotation": "left"}}}],"#,
    )
    .replace(r#""attributes": {"POSITION": 0}"#, r#""attributes": {"POSITION": 0}, "material": 0"#);
    let path = write_scene("anisotropy", &json, true);
    let scene = penumbra::engine::import::GltfScene::load(&path, &ImportOptions::default()).expect("loads");
    let warnings = scene.warnings.join("\n");
    assert!(warnings.contains("material \"bad\": KHR_materials_anisotropy anisotropyRotation"), "{warnings}");
    assert!(!warnings.contains("not supported"), "{warnings}");
    let app = spawned(&scene);
    let materials = app.world.resource::<Assets<StandardMaterial>>();
    let brushed = materials.iter().map(|(_, m)| m).find(|m| m.anisotropy_strength == 0.6).expect("the brushed");
    assert_eq!(brushed.anisotropy_rotation, 1.5);
}

/// The anisotropy sample imports every sphere's strength, without a warning.
#[test]
fn the_anisotropy_sample_imports_its_strengths() {
    let scene = penumbra::engine::import::GltfScene::load(
        &asset("AnisotropyStrengthTest/AnisotropyStrengthTest.glb"),
        &Default::default(),
    )
    .expect("loads");
    assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
    let mut app = spawned(&scene);
    let materials = app.world.resource::<Assets<StandardMaterial>>();
    let strengths: std::collections::BTreeSet<u32> =
        materials.iter().map(|(_, m)| (m.anisotropy_strength * 100.0).round() as u32).collect();
    assert!(strengths.len() >= 4 && strengths.contains(&0) && strengths.contains(&100), "{strengths:?}");
    let drawn: Vec<(Handle<Mesh>, Handle<StandardMaterial>)> =
        app.world.query::<(&Mesh3d, &MeshMaterial3d)>().iter(&app.world).map(|(m, mat)| (m.0, mat.0)).collect();
    let (meshes, materials) = (app.world.resource::<Assets<Mesh>>(), app.world.resource::<Assets<StandardMaterial>>());
    let anisotropic: Vec<_> =
        drawn.iter().filter(|(_, mat)| materials.get(*mat).is_ok_and(|m| m.has_anisotropy())).collect();
    assert!(!anisotropic.is_empty());
    for (mesh, _) in anisotropic {
        assert!(!meshes.get(*mesh).expect("live").tangents.is_empty(), "anisotropic meshes get tangents");
    }
}

/// KHR_materials_iridescence is read from the material's JSON; a film IOR below 1 falls back to
/// the default with a warning naming the material; the sample imports without warnings.
#[test]
fn iridescence_is_read_and_bad_values_are_named() {
    let json = triangle_json(
        "triangle.bin",
        r#""extensionsUsed": ["KHR_materials_iridescence"],
  "materials": [{"name": "bubble", "extensions": {"KHR_materials_iridescence": {
      "iridescenceFactor": 0.8, "iridescenceIor": 1.4, "iridescenceThicknessMinimum": 50,
      "iridescenceThicknessMaximum": 600}}},
    {"name": "bad", "extensions": {"KHR_materials_iridescence": {"iridescenceIor": 0.5}}}],"#,
    )
    .replace(r#""attributes": {"POSITION": 0}"#, r#""attributes": {"POSITION": 0}, "material": 0"#);
    let path = write_scene("iridescence", &json, true);
    let scene = penumbra::engine::import::GltfScene::load(&path, &ImportOptions::default()).expect("loads");
    let warnings = scene.warnings.join("\n");
    assert!(
        warnings.contains("material \"bad\": KHR_materials_iridescence iridescenceIor 0.5 is below 1"),
        "{warnings}"
    );
    let app = spawned(&scene);
    let materials = app.world.resource::<Assets<StandardMaterial>>();
    let bubble = materials.iter().map(|(_, m)| m).find(|m| m.iridescence == 0.8).expect("the bubble");
    assert_eq!(
        (bubble.iridescence_ior, bubble.iridescence_thickness_min, bubble.iridescence_thickness_max),
        (1.4, 50.0, 600.0)
    );
    let sample = penumbra::engine::import::GltfScene::load(
        &asset("IridescenceSuzanne/IridescenceSuzanne.glb"),
        &Default::default(),
    )
    .expect("loads");
    assert!(sample.warnings.is_empty(), "{:?}", sample.warnings);
}

/// The clearcoat sample imports its coats, their textures and the coat's normal maps.
#[test]
fn the_clearcoat_sample_imports_its_coats() {
    let scene =
        penumbra::engine::import::GltfScene::load(&asset("ClearCoatTest/ClearCoatTest.glb"), &Default::default())
            .expect("loads");
    assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
    let app = spawned(&scene);
    let materials = app.world.resource::<Assets<StandardMaterial>>();
    let all: Vec<&StandardMaterial> = materials.iter().map(|(_, m)| m).collect();
    assert!(all.iter().any(|m| m.clearcoat == 1.0 && m.clearcoat_texture.is_none()));
    assert!(all.iter().any(|m| m.clearcoat_texture.is_some()), "partial coating");
    assert!(all.iter().any(|m| m.clearcoat_roughness_texture.is_some()), "roughness variations");
    assert!(all.iter().any(|m| m.clearcoat_normal_texture.is_some()), "coat normal map");
}

// ---- Degenerate and spec-violating values (issue: reliability round two) ----

/// The triangle fixture with `extra_root` JSON members added (cameras, lights, materials …)
/// and `node` members added to its one node; loads it and returns the scene or the error.
fn triangle_with(name: &str, extra_root: &str, node: &str) -> (PathBuf, Result<GltfScene, ImportError>) {
    let json = triangle_json("triangle.bin", extra_root)
        .replace(r#""nodes": [{"mesh": 0}]"#, &format!(r#""nodes": [{{"mesh": 0{node}}}]"#));
    let path = write_scene(name, &json, true);
    let loaded = GltfScene::load(&path, &ImportOptions::default());
    (path, loaded)
}

fn camera_json(camera: &str) -> String {
    format!(r#""cameras": [{camera}],"#)
}

/// Cameras the glTF schema forbids are refused, naming the file and the camera: before, each
/// loaded and rendered an empty (or upside-down) frame without a word.
#[test]
fn cameras_the_specification_forbids_are_refused_by_name() {
    let perspective =
        |fields: &str| format!(r#"{{"name": "Main", "type": "perspective", "perspective": {{{fields}}}}}"#);
    let cases = [
        (perspective(r#""yfov": 0, "znear": 0.1"#), "yfov 0"),
        (perspective(r#""yfov": -0.8, "znear": 0.1"#), "yfov -0.8"),
        (perspective(r#""yfov": 0.8, "znear": 0"#), "znear 0"),
        (perspective(r#""yfov": 0.8, "znear": 10, "zfar": 5"#), "zfar 5"),
        (perspective(r#""yfov": 0.8, "znear": 10, "zfar": 10"#), "zfar 10"),
        (perspective(r#""yfov": 0.8, "znear": 0.1, "aspectRatio": 0"#), "aspectRatio 0"),
        (perspective(r#""yfov": 1e39, "znear": 0.1"#), "yfov inf"),
        (
            r#"{"name": "Main", "type": "orthographic", "orthographic": {"xmag": 0, "ymag": 1, "znear": 0, "zfar": 10}}"#
                .to_owned(),
            "xmag 0",
        ),
        (
            r#"{"name": "Main", "type": "orthographic", "orthographic": {"xmag": 1, "ymag": 1, "znear": 5, "zfar": 1}}"#
                .to_owned(),
            "zfar 1",
        ),
    ];
    for (i, (camera, expected)) in cases.iter().enumerate() {
        let json = triangle_json("triangle.bin", &camera_json(camera));
        let path = write_scene(&format!("camera-{i}"), &json, true);
        let err = load_expecting_error(&path);
        assert!(matches!(err.kind, ImportErrorKind::Camera { index: 0, .. }), "{err}");
        let msg = err.to_string();
        assert!(msg.contains("camera 0 (\"Main\")") && msg.contains(expected), "{expected}: {msg}");
    }
}

/// What the schema only advises against is made sensible with a warning: a field of view of π
/// or more (the projection flips beyond it), a negative magnification (a mirrored image).
#[test]
fn cameras_the_specification_advises_against_are_fixed_with_a_warning() {
    let camera = r#"{"type": "perspective", "perspective": {"yfov": 4.0, "znear": 0.1}},
        {"type": "orthographic", "orthographic": {"xmag": -2, "ymag": 1, "znear": 0, "zfar": 10}}"#;
    let (_, loaded) = triangle_with("camera-advised", &camera_json(camera), r#", "camera": 0, "scale": [0, 1, 1]"#);
    let scene = loaded.expect("loads");
    let warnings = scene.warnings.join("\n");
    assert!(warnings.contains("camera 0 (\"camera0\"): yfov 4 is not below π"), "{warnings}");
    assert!(warnings.contains("camera 1 (\"camera1\"): xmag -2 is negative"), "{warnings}");
    assert!(warnings.contains("node 0 (camera 0) has scale [0.0, 1.0, 1.0]"), "{warnings}");
    let mut app = spawned(&scene);
    let mut q = app.world.query::<&Camera>();
    let projections: Vec<Projection> = q.iter(&app.world).map(|c| c.projection).collect();
    assert!(
        projections.iter().any(|p| matches!(p, Projection::Perspective { yfov, .. } if *yfov < std::f32::consts::PI)),
        "{projections:?}"
    );
    assert!(
        projections.iter().all(|p| !matches!(p, Projection::Orthographic { ymag, .. } if *ymag < 0.0)),
        "{projections:?}"
    );
}

/// Light values the shading cannot carry are clamped at import with a warning: before, a point
/// light of 1e36 cd vanished (an overflow to infinity, then NaN) and a negative colour darkened
/// what it lit.
#[test]
fn lights_beyond_what_shading_carries_are_clamped_with_a_warning() {
    let lights = r#""extensionsUsed": ["KHR_lights_punctual"],
        "extensions": {"KHR_lights_punctual": {"lights": [
            {"type": "point", "intensity": 1e36, "name": "Nova"},
            {"type": "spot", "color": [1, -0.5, 1], "intensity": 10, "range": -2,
             "spot": {"innerConeAngle": 1.0, "outerConeAngle": 0.5}},
            {"type": "directional", "intensity": 3e38, "color": [1, 1e39, 1]}
        ]}},"#;
    let (_, loaded) = triangle_with("lights", lights, "");
    let scene = loaded.expect("loads");
    let warnings = scene.warnings.join("\n");
    for expected in [
        "light 0 (\"Nova\"): intensity 1e36 cd is beyond what shading carries",
        "light 1: color [1, -0.5, 1] must be finite and not negative; using [1, 0, 1]",
        "light 1: range -2 must be above 0",
        "light 1: spot cone angles inner 1, outer 0.5",
        "light 2: color [1, inf, 1] must be finite",
    ] {
        assert!(warnings.contains(expected), "{expected:?} in\n{warnings}");
    }
    let max = penumbra::engine::import::gltf::punctual_lights::MAX_INTENSITY;
    let json = triangle_json("triangle.bin", lights).replace(
        r#""nodes": [{"mesh": 0}]"#,
        r#""nodes": [{"mesh": 0, "children": [1, 2, 3]},
            {"extensions": {"KHR_lights_punctual": {"light": 0}}},
            {"extensions": {"KHR_lights_punctual": {"light": 1}}},
            {"extensions": {"KHR_lights_punctual": {"light": 2}}}]"#,
    );
    let path = write_scene("lights-spawned", &json, true);
    let mut app = spawned(&GltfScene::load(&path, &ImportOptions::default()).expect("loads"));
    let point = *app.world.query::<&PointLight>().single(&app.world).unwrap();
    assert_eq!(point.intensity, max);
    let spot = *app.world.query::<&SpotLight>().single(&app.world).unwrap();
    assert_eq!((spot.color, spot.range), (Vec3::new(1.0, 0.0, 1.0), None));
    assert!(spot.inner_cone_angle < spot.outer_cone_angle);
    let sun = *app.world.query::<&DirectionalLight>().single(&app.world).unwrap();
    assert!(sun.color.is_finite() && (sun.color * sun.illuminance).max_element() <= max * 1.0001, "{sun:?}");
}

/// Non-finite or out-of-range material factors are replaced at import with a warning: before,
/// an occlusion strength of −inf turned the object black without a word.
#[test]
fn material_factors_outside_the_schema_are_replaced_with_a_warning() {
    let materials = r#""materials": [{"name": "Bad",
        "pbrMetallicRoughness": {"baseColorFactor": [1, 2, -1, 1], "metallicFactor": 5, "roughnessFactor": -1e39},
        "normalTexture": {"index": 0, "scale": 1e39},
        "occlusionTexture": {"index": 0, "strength": -1e39},
        "emissiveFactor": [0, 0, 1e39],
        "alphaMode": "MASK", "alphaCutoff": -1}],
        "textures": [{"source": 0}],
        "images": [{"uri": "texel.png"}],"#;
    let json = triangle_json("triangle.bin", materials)
        .replace(r#""attributes": {"POSITION": 0}"#, r#""attributes": {"POSITION": 0}, "material": 0"#);
    let path = write_scene("materials", &json, true);
    image::RgbaImage::from_pixel(1, 1, image::Rgba([255; 4])).save(path.with_file_name("texel.png")).unwrap();
    let scene = GltfScene::load(&path, &ImportOptions::default()).expect("loads");
    let warnings = scene.warnings.join("\n");
    for expected in [
        "material \"Bad\": baseColorFactor.g 2 is outside 0..=1; using 1",
        "baseColorFactor.b -1 is outside",
        "metallicFactor 5 is outside 0..=1; using 1",
        "roughnessFactor -inf is not a finite number; using 1",
        "normalTexture.scale inf is not a finite number; using 1",
        "occlusionTexture.strength -inf is not a finite number; using 1",
        "emissiveFactor.b inf is not a finite number; using 0",
        "alphaCutoff -1 is below 0; using 0",
    ] {
        assert!(warnings.contains(expected), "{expected:?} in\n{warnings}");
    }
    let app = spawned(&scene);
    let materials = app.world.resource::<Assets<StandardMaterial>>();
    let (_, m) = materials.iter().next().expect("one material");
    assert_eq!(m.base_color, Vec4::new(1.0, 1.0, 0.0, 1.0));
    assert_eq!((m.metallic, m.roughness, m.normal_scale, m.occlusion_strength), (1.0, 1.0, 1.0, 1.0));
    assert_eq!(m.emissive, Vec3::ZERO);
}

/// `extras` may be any JSON value anywhere (the schema says "any"): it is ignored, never an
/// error. Before, an array or a number was refused as a malformed file.
#[test]
fn extras_of_every_json_type_are_accepted() {
    for (i, extras) in [r#"[1, 2]"#, "5", r#""text""#, "true", "null", r#"{"a": {"b": [null]}}"#].iter().enumerate() {
        let root = format!(r#""extras": {extras},"#);
        let (path, loaded) = triangle_with(&format!("extras-{i}"), &root, &format!(r#", "extras": {extras}"#));
        let scene = loaded.unwrap_or_else(|e| panic!("extras {extras}: {e}"));
        assert!(scene.warnings.is_empty(), "{path:?}: {:?}", scene.warnings);
    }
}

/// glTF 1.0 is another format: refused by name (as JSON of either shape, and as GLB version 1),
/// as is a file that needs a newer glTF than 2.0.
#[test]
fn gltf_1_and_newer_versions_are_refused_by_name() {
    let json = triangle_json("triangle.bin", "").replace(r#""version": "2.0""#, r#""version": "1.0""#);
    let err = load_expecting_error(&write_scene("version-1", &json, true));
    assert!(err.to_string().contains("asset.version \"1.0\" is glTF 1.0"), "{err}");
    // A real glTF 1.0 file's JSON: objects where 2.0 has arrays.
    let v1 = r#"{"asset": {"version": "1.0"}, "scene": "s", "scenes": {"s": {"nodes": []}}, "nodes": {}}"#;
    let err = load_expecting_error(&write_scene("version-1-shape", v1, false));
    assert!(err.to_string().contains("glTF 1.0"), "{err}");
    let json =
        triangle_json("triangle.bin", "").replace(r#""version": "2.0""#, r#""version": "2.0", "minVersion": "2.1""#);
    let err = load_expecting_error(&write_scene("min-version", &json, true));
    assert!(err.to_string().contains("minVersion \"2.1\""), "{err}");
    let mut glb = std::fs::read(asset("BoxTextured/BoxTextured.glb")).unwrap();
    glb[4] = 1;
    let path = scratch_dir("glb-1").join("box.glb");
    std::fs::write(&path, &glb).unwrap();
    let err = load_expecting_error(&path);
    assert!(err.to_string().contains("GLB version 1 is glTF 1.0"), "{err}");
}

/// A GLB whose header declares fewer bytes than the file holds loads what the header declares,
/// with a warning; a buffer of byteLength 0 (the schema's minimum is 1) is skipped with one.
#[test]
fn short_glb_lengths_and_empty_buffers_are_named() {
    let mut glb = std::fs::read(asset("BoxTextured/BoxTextured.glb")).unwrap();
    let len = glb.len();
    glb.extend_from_slice(&[0; 64]);
    let path = scratch_dir("glb-long").join("box.glb");
    std::fs::write(&path, &glb).unwrap();
    let scene = GltfScene::load(&path, &ImportOptions::default()).expect("loads");
    let expected = format!("the GLB header declares {len} bytes but the file has {}", len + 64);
    assert!(scene.warnings.iter().any(|w| w.contains(&expected)), "{:?}", scene.warnings);

    let json = triangle_json("triangle.bin", "").replace(
        r#""uri": "triangle.bin", "byteLength": 36}]"#,
        r#""uri": "triangle.bin", "byteLength": 36}, {"uri": "empty.bin", "byteLength": 0}]"#,
    );
    let path = write_scene("empty-buffer", &json, true);
    std::fs::write(path.with_file_name("empty.bin"), b"").unwrap();
    let scene = GltfScene::load(&path, &ImportOptions::default()).expect("loads");
    assert!(
        scene.warnings.iter().any(|w| w.contains("buffers[1] has byteLength 0 (glTF requires at least 1)")),
        "{:?}",
        scene.warnings
    );
}

/// The scene path itself must be a regular file: a FIFO would block the import forever (buffer
/// and image URIs were already checked; the scene path was not), a folder is named as one.
#[cfg(unix)]
#[test]
fn a_scene_path_that_is_not_a_regular_file_is_refused() {
    let dir = scratch_dir("fifo");
    let fifo = dir.join("scene.gltf");
    let status = std::process::Command::new("mkfifo").arg(&fifo).status().expect("mkfifo runs");
    assert!(status.success());
    let err = load_expecting_error(&fifo);
    assert!(matches!(err.kind, ImportErrorKind::NotAFile { .. }), "{err}");
    assert!(err.to_string().contains("it is a FIFO (named pipe), not a regular file"), "{err}");
    let folder = dir.join("folder.glb");
    std::fs::create_dir(&folder).unwrap();
    assert!(load_expecting_error(&folder).to_string().contains("it is a folder"));
    let obj = dir.join("scene.obj");
    std::process::Command::new("mkfifo").arg(&obj).status().unwrap();
    assert!(matches!(load_expecting_error(&obj).kind, ImportErrorKind::NotAFile { .. }));
}
