//! Compressed geometry: `KHR_draco_mesh_compression` (Khronos' Draco sample variants) and
//! `EXT_meshopt_compression` / `KHR_meshopt_compression` (gltfpack's output) draw as the plain
//! files they were made from; broken compressed data is an error naming the file, the primitive
//! or bufferView, and the problem.
//!
//! The meshopt files were made with gltfpack 1.2 (meshoptimizer's glTF packer) from the plain
//! test assets: `gltfpack -cc -i CesiumMan.glb -o CesiumMan-meshopt.glb` (vertex codec,
//! octahedral normals, quaternion and exponential animation filters, index codec) and
//! `gltfpack -cc -ce khr -i BoxVertexColors.glb -o BoxVertexColors-meshopt-khr.glb` (the ratified
//! extension: vertex codec version 1 and the COLOR filter). Both quantise (KHR_mesh_quantization).

mod common;

use std::path::PathBuf;

use common::golden_scenes::THREE_QUARTER;
use common::{Shot, Tolerance, asset, check_golden, flip_mean, render_asset, scratch_dir};
use penumbra::engine::import::{GltfScene, ImportErrorKind, ImportOptions};
use penumbra::render::RenderSettings;
use penumbra::render::headless::ShotSettings;

fn shot() -> ShotSettings {
    ShotSettings { size: Some((128, 128)), camera: THREE_QUARTER, exposure_ev100: Some(0.0), ..Default::default() }
}

fn render(rel: &str) -> Shot {
    let scene = GltfScene::load(&asset(rel), &ImportOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    assert!(scene.warnings.is_empty(), "{rel}: {:?}", scene.warnings);
    render_asset(rel, &shot(), RenderSettings::default())
}

/// The fraction of pixels that differ from the top-left one (the background).
fn coverage(shot: &Shot) -> f32 {
    let background = &shot.rgba8[..4];
    let covered = shot.rgba8.chunks_exact(4).filter(|p| p.iter().zip(background).any(|(a, b)| a.abs_diff(*b) > 8));
    covered.count() as f32 / (shot.width * shot.height) as f32
}

/// Renders the compressed file and its plain counterpart from the same view; returns the
/// compressed render after checking it draws the model and matches (FLIP mean <= 0.01, the
/// issue's bar; quantisation moves vertices by up to a few ten-thousandths of the model).
fn draws_as_plain(compressed: &str, plain: &str) -> Shot {
    let a = render(compressed);
    let b = render(plain);
    assert!(coverage(&a) > 0.05, "{compressed} covers {:.3} of the image", coverage(&a));
    let error = flip_mean(&a.rgba8, &b.rgba8, a.width, a.height);
    eprintln!("{compressed} against {plain}: FLIP mean {error:.5}");
    assert!(error <= 0.01, "{compressed} against {plain}: FLIP mean {error}");
    a
}

#[test]
fn draco_files_draw_as_their_plain_counterparts() {
    let truck = draws_as_plain("CesiumMilkTruckDraco/CesiumMilkTruck.gltf", "CesiumMilkTruck/CesiumMilkTruck.glb");
    check_golden("CesiumMilkTruck-draco", &truck, Tolerance::default());
    // Morph targets stay plain accessors: they must line up with the decoded points.
    draws_as_plain(
        "MorphPrimitivesTestDraco/MorphPrimitivesTest.gltf",
        "MorphPrimitivesTestDraco/MorphPrimitivesTest-plain.gltf",
    );
}

#[test]
fn meshopt_files_draw_as_their_plain_counterparts() {
    let man = draws_as_plain("CesiumMan/CesiumMan-meshopt.glb", "CesiumMan/CesiumMan.glb");
    check_golden("CesiumMan-meshopt", &man, Tolerance::default());
    draws_as_plain("BoxVertexColors/BoxVertexColors-meshopt-khr.glb", "BoxVertexColors/BoxVertexColors.glb");
}

/// BoxDraco with its JSON changed by `edit` (and its buffer by `edit_bin`), in a scratch folder.
fn draco_variant(
    name: &str,
    edit: impl FnOnce(&mut serde_json::Value),
    edit_bin: impl FnOnce(&mut Vec<u8>),
) -> PathBuf {
    let dir = scratch_dir(name);
    let from = asset("BoxDraco/Box.gltf");
    let mut bin = std::fs::read(from.with_file_name("Box.bin")).unwrap();
    edit_bin(&mut bin);
    std::fs::write(dir.join("Box.bin"), bin).unwrap();
    let mut json: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&from).unwrap()).unwrap();
    edit(&mut json);
    let path = dir.join("scene.gltf");
    std::fs::write(&path, serde_json::to_string(&json).unwrap()).unwrap();
    path
}

fn load_error(path: &std::path::Path) -> String {
    let err = GltfScene::load(path, &ImportOptions::default()).expect_err("must fail");
    let text = err.to_string();
    assert!(text.contains("scene.gltf") || text.contains("scene.glb"), "names the file: {text}");
    assert!(matches!(err.kind, ImportErrorKind::Primitive { .. } | ImportErrorKind::BufferView { .. }), "{text}");
    text
}

#[test]
fn broken_draco_data_is_an_error_naming_the_primitive() {
    let ext =
        |j: &mut serde_json::Value| j["meshes"][0]["primitives"][0]["extensions"]["KHR_draco_mesh_compression"].clone();
    let view = |j: &serde_json::Value| {
        j["meshes"][0]["primitives"][0]["extensions"]["KHR_draco_mesh_compression"]["bufferView"].as_u64().unwrap()
            as usize
    };
    // The whole file loads as it is.
    let fine = draco_variant("draco-fine", |_| {}, |_| {});
    let scene = GltfScene::load(&fine, &ImportOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);

    // A truncated stream: the bufferView stops halfway.
    let path = draco_variant(
        "draco-truncated",
        |j| {
            let v = view(j);
            let half = j["bufferViews"][v]["byteLength"].as_u64().unwrap() / 2;
            j["bufferViews"][v]["byteLength"] = half.into();
        },
        |_| {},
    );
    let e = load_error(&path);
    assert!(e.contains("mesh 0 primitive 0: KHR_draco_mesh_compression: the compressed data"), "{e}");
    assert!(e.contains("does not decode"), "{e}");

    // Not a Draco stream at all: its bytes zeroed.
    let path = draco_variant("draco-zeroed", |_| {}, |bin| bin.iter_mut().for_each(|b| *b = 0));
    assert!(load_error(&path).contains("does not decode"));

    // An attribute id the stream does not have.
    let path = draco_variant(
        "draco-attribute",
        |j| {
            let mut e = ext(j);
            e["attributes"]["POSITION"] = 9.into();
            j["meshes"][0]["primitives"][0]["extensions"]["KHR_draco_mesh_compression"] = e;
        },
        |_| {},
    );
    let e = load_error(&path);
    assert!(e.contains("attributes.POSITION names Draco attribute 9"), "{e}");

    // Lines cannot be Draco-compressed.
    let path = draco_variant("draco-lines", |j| j["meshes"][0]["primitives"][0]["mode"] = 1.into(), |_| {});
    assert!(load_error(&path).contains("cannot be Draco-compressed"));

    // More points than the POSITION accessor declares.
    let path = draco_variant("draco-count", |j| j["accessors"][2]["count"] = 10.into(), |_| {});
    let e = load_error(&path);
    assert!(e.contains("decodes to 24 points, more than the 10 its POSITION accessor declares"), "{e}");

    // A bufferView that does not exist.
    let path = draco_variant(
        "draco-view",
        |j| j["meshes"][0]["primitives"][0]["extensions"]["KHR_draco_mesh_compression"]["bufferView"] = 42.into(),
        |_| {},
    );
    assert!(load_error(&path).contains("bufferView 42 does not exist"));
}

/// A GLB's JSON chunk and binary chunk.
fn split_glb(bytes: &[u8]) -> (serde_json::Value, Vec<u8>) {
    let json_len = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
    let json = serde_json::from_slice(&bytes[20..20 + json_len]).unwrap();
    let bin_at = 20 + json_len;
    let bin_len = u32::from_le_bytes(bytes[bin_at..bin_at + 4].try_into().unwrap()) as usize;
    (json, bytes[bin_at + 8..bin_at + 8 + bin_len].to_vec())
}

fn join_glb(json: &serde_json::Value, bin: &[u8]) -> Vec<u8> {
    let mut j = serde_json::to_vec(json).unwrap();
    while !j.len().is_multiple_of(4) {
        j.push(b' ');
    }
    let mut b = bin.to_vec();
    while !b.len().is_multiple_of(4) {
        b.push(0);
    }
    let total = 12 + 8 + j.len() + 8 + b.len();
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(j.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&j);
    out.extend_from_slice(&(b.len() as u32).to_le_bytes());
    out.extend_from_slice(b"BIN\0");
    out.extend_from_slice(&b);
    out
}

fn meshopt_variant(name: &str, edit: impl FnOnce(&mut serde_json::Value, &mut Vec<u8>)) -> PathBuf {
    let (mut json, mut bin) =
        split_glb(&std::fs::read(asset("BoxVertexColors/BoxVertexColors-meshopt-khr.glb")).unwrap());
    edit(&mut json, &mut bin);
    let path = scratch_dir(name).join("scene.glb");
    std::fs::write(&path, join_glb(&json, &bin)).unwrap();
    path
}

#[test]
fn broken_meshopt_data_is_an_error_naming_the_buffer_view() {
    const KHR: &str = "KHR_meshopt_compression";
    let fine = meshopt_variant("meshopt-fine", |_, _| {});
    let scene = GltfScene::load(&fine, &ImportOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
    let first_compressed = |j: &serde_json::Value| {
        j["bufferViews"].as_array().unwrap().iter().position(|v| v["extensions"][KHR].is_object()).unwrap()
    };
    let view = first_compressed(&split_glb(&std::fs::read(&fine).unwrap()).0);

    // The compressed bytes cut short.
    let path = meshopt_variant("meshopt-truncated", |j, _| {
        let v = first_compressed(j);
        let n = j["bufferViews"][v]["extensions"][KHR]["byteLength"].as_u64().unwrap();
        j["bufferViews"][v]["extensions"][KHR]["byteLength"] = (n / 2).into();
    });
    let e = load_error(&path);
    assert!(e.contains(&format!("bufferView {view}: {KHR}: the")), "{e}");
    assert!(e.contains("does not decode"), "{e}");

    // The codec's header byte overwritten: an unknown version.
    let path = meshopt_variant("meshopt-header", |j, bin| {
        let v = first_compressed(j);
        let at = j["bufferViews"][v]["extensions"][KHR]["byteOffset"].as_u64().unwrap_or(0) as usize;
        bin[at] = 0xff;
    });
    assert!(load_error(&path).contains("does not decode"));

    // The view's own stride differs from the extension's.
    let path = meshopt_variant("meshopt-view-stride", |j, _| {
        let v = first_compressed(j);
        let stride = j["bufferViews"][v]["extensions"][KHR]["byteStride"].as_u64().unwrap();
        j["bufferViews"][v]["byteStride"] = (stride + 4).into();
    });
    assert!(load_error(&path).contains("differs from the extension's"));

    // A stride the codec does not allow, and compressed data past the end of its buffer.
    let path = meshopt_variant("meshopt-stride", |j, _| {
        let v = first_compressed(j);
        j["bufferViews"][v]["extensions"][KHR]["byteStride"] = 6.into();
    });
    assert!(load_error(&path).contains("byteStride 6 is not allowed"));
    let path = meshopt_variant("meshopt-outside", |j, _| {
        let v = first_compressed(j);
        j["bufferViews"][v]["extensions"][KHR]["byteOffset"] = 1_000_000.into();
    });
    assert!(load_error(&path).contains("runs past the end of buffer"));
}
