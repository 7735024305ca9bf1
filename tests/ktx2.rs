//! KTX2 textures draw as their PNG original: Basis Universal data (KHR_texture_basisu: ETC1S and
//! UASTC) transcoded to the adapter's block format with their mip chains (or to RGBA8), and
//! plain KTX2 files of ordinary formats (8-bit texels, BC, ETC2, ASTC; zstd, zlib or none)
//! uploaded as they are where the device samples them, decoded to RGBA8 where not. A texture
//! without a chain gets one made on the GPU; broken files are errors naming the image.
//!
//! tests/assets/BoxTexturedKtx2 is BoxTextured with its PNG texture encoded by Basis Universal's
//! `basisu` tool and by KTX-Software's `ktx` tool (see its README.md for the commands).

mod common;

use common::golden_scenes::THREE_QUARTER;
use common::{Shot, Tolerance, asset, check_golden, flip_mean, render_asset, scratch_dir};
use penumbra::engine::compressed_image::{Codec, Source};
use penumbra::engine::import::{GltfScene, ImportErrorKind, ImportOptions};
use penumbra::render::headless::{ShotSettings, render_frames, stage_scene};
use penumbra::render::{MemoryStats, RenderSettings, Renderer};

fn shot() -> ShotSettings {
    ShotSettings { size: Some((128, 128)), camera: THREE_QUARTER, exposure_ev100: Some(0.0), ..Default::default() }
}

fn settings() -> RenderSettings {
    RenderSettings { max_anisotropy: Some(1), ..Default::default() }
}

fn render(rel: &str) -> Shot {
    let scene = GltfScene::load(&asset(rel), &ImportOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    assert!(scene.warnings.is_empty(), "{rel}: {:?}", scene.warnings);
    render_asset(rel, &shot(), settings())
}

/// Renders the scene at `path` and says what its textures took on the GPU.
fn render_path(path: &std::path::Path) -> (Shot, MemoryStats) {
    render_path_on(common::gpu(), path)
}

fn render_path_on(gpu: penumbra::render::GpuContext, path: &std::path::Path) -> (Shot, MemoryStats) {
    let scene = GltfScene::load(path, &ImportOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    assert!(scene.warnings.is_empty(), "{}: {:?}", path.display(), scene.warnings);
    let (mut app, size) = stage_scene(&scene, &shot()).unwrap();
    let renderer = Renderer::new(gpu, settings()).unwrap();
    let rgba8 = render_frames(&mut app, renderer, size, 1).unwrap();
    let memory = app.world.resource::<Renderer>().memory();
    (Shot { width: size.0, height: size.1, rgba8 }, memory)
}

#[test]
fn basis_textures_draw_as_their_png_original() {
    let png = render("BoxTextured/BoxTextured.glb");
    for (rel, golden, codec, max) in [
        // ETC1S is the small codec (0.5 bits per texel here): colour bleeds at the logo's edges
        // and the encoder's own mip filter soften it.
        ("BoxTexturedKtx2/BoxTextured-etc1s.gltf", "BoxTextured-etc1s", Codec::Etc1s, 0.07),
        // UASTC keeps the texels (0.002 where the GPU makes the chain from level 0); the file's
        // own smaller levels, each encoded on its own, add the rest.
        ("BoxTexturedKtx2/BoxTextured-uastc.gltf", "BoxTextured-uastc", Codec::Uastc, 0.02),
        ("BoxTexturedKtx2/BoxTextured-uastc-nomips.gltf", "", Codec::Uastc, 0.005),
    ] {
        let scene = GltfScene::load(&asset(rel), &ImportOptions::default()).unwrap();
        let image = scene.images().next().expect("an image");
        let compressed = image.compressed.as_ref().expect("kept compressed");
        assert_eq!(compressed.source(), Source::Basis(codec), "{rel}");
        assert!(image.rgba8.is_empty(), "{rel}: no texels on the host");
        let shot = render(rel);
        let error = flip_mean(&shot.rgba8, &png.rgba8, 128, 128);
        eprintln!("{rel} against the PNG: FLIP mean {error:.5}");
        assert!(error > 0.0 && error < max, "{rel} against the PNG: FLIP mean {error}");
        if !golden.is_empty() {
            check_golden(golden, &shot, Tolerance::default());
        }
    }
}

/// BoxTextured drawing `image` (a KTX2 file of tests/assets/BoxTexturedKtx2, through
/// KHR_texture_basisu as the Basis files are) with its bytes changed by `edit`, in a scratch
/// folder.
fn scene_with(name: &str, image: &str, edit: impl FnOnce(&mut Vec<u8>)) -> std::path::PathBuf {
    let dir = scratch_dir(name);
    let from = asset("BoxTexturedKtx2/BoxTextured-uastc.gltf");
    let mut json: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&from).unwrap()).unwrap();
    json["images"][0]["uri"] = image.into();
    std::fs::copy(from.with_file_name("BoxTextured.bin"), dir.join("BoxTextured.bin")).unwrap();
    let mut bytes = std::fs::read(from.with_file_name(image)).unwrap();
    edit(&mut bytes);
    std::fs::write(dir.join(image), bytes).unwrap();
    std::fs::write(dir.join("scene.gltf"), serde_json::to_string(&json).unwrap()).unwrap();
    dir.join("scene.gltf")
}

#[test]
fn broken_ktx2_files_are_errors_naming_the_image() {
    let load = |path: &std::path::Path| GltfScene::load(path, &ImportOptions::default());
    for image in ["CesiumLogoFlat-etc1s.ktx2", "CesiumLogoFlat-uastc.ktx2", "CesiumLogoFlat-bc7-zstd.ktx2"] {
        let variant = |name: &str, edit: &dyn Fn(&mut Vec<u8>)| scene_with(name, image, edit);
        assert!(load(&variant("ktx2-fine", &|_| {})).is_ok());
        // Cut short: the level index points past the end.
        let err = load(&variant("ktx2-header", &|b| b.truncate(60))).expect_err("must fail");
        assert!(err.to_string().contains("truncated"), "{err}");
        let err = load(&variant("ktx2-truncated", &|b| b.truncate(b.len() / 2))).expect_err("must fail");
        assert!(matches!(err.kind, ImportErrorKind::Image { .. }), "{err}");
        assert!(err.to_string().contains(image) && err.to_string().contains("scene.gltf"), "{err}");
        // A chain past 1×1: more levels than a 256×256 image has.
        let err =
            load(&variant("ktx2-levels", &|b| b[40..44].copy_from_slice(&10u32.to_le_bytes()))).expect_err("must fail");
        assert!(err.to_string().contains("has 10 mip levels, more than the 9 a 256×256 image has"), "{err}");
        // A format Penumbra does not read (R16G16B16A16_SFLOAT), and BC6H (HDR).
        for (vk, says) in [(97, "vkFormat 97, which Penumbra does not read"), (143, "BC6H, high dynamic range")] {
            let err = load(&variant("ktx2-vkformat", &|b| b[12..16].copy_from_slice(&(vk as u32).to_le_bytes())))
                .expect_err("must fail");
            assert!(err.to_string().contains(says), "{err}");
        }
        // Levels that do not hold what the format says: the Basis files' data read as RGBA8,
        // the BC7 file's as BC1 (half the bytes per block).
        let vk = if image.contains("bc7") { 131u32 } else { 37 };
        let err =
            load(&variant("ktx2-layout", &|b| b[12..16].copy_from_slice(&vk.to_le_bytes()))).expect_err("must fail");
        assert!(err.to_string().contains("is corrupt") || err.to_string().contains("BasisLZ"), "{err}");
    }
}

/// The level index entries (offset, length, uncompressed length) of a KTX2 file.
fn level_index(bytes: &[u8], level: usize) -> [u64; 3] {
    let at = 80 + level * 24;
    std::array::from_fn(|i| u64::from_le_bytes(bytes[at + i * 8..at + i * 8 + 8].try_into().unwrap()))
}

#[test]
fn plain_ktx2_files_with_corrupt_levels_are_errors_naming_the_level() {
    let load = |path: &std::path::Path| GltfScene::load(path, &ImportOptions::default()).expect_err("must fail");
    for image in ["CesiumLogoFlat-bc7-zstd.ktx2", "CesiumLogoFlat-astc6x6-zlib.ktx2"] {
        // Level 0's stream with a damaged frame header.
        let err = load(&scene_with("ktx2-stream", image, |b| {
            let [offset, _, _] = level_index(b, 0);
            b[offset as usize..offset as usize + 4].fill(0xa5);
        }));
        let text = err.to_string();
        assert!(text.contains(image) && text.contains("mip level 0"), "{text}");
        // A level that claims the wrong size before supercompression.
        let err = load(&scene_with("ktx2-claim", image, |b| {
            let at = 80 + 2 * 24 + 16;
            b[at..at + 8].copy_from_slice(&12345u64.to_le_bytes());
        }));
        assert!(err.to_string().contains("its mip level 2 holds 12345 bytes"), "{err}");
    }
    // Not supercompressed: a level cut short by a wrong length.
    let err = load(&scene_with("ktx2-length", "CesiumLogoFlat-rgb8-zlib.ktx2", |b| {
        b[44..48].copy_from_slice(&0u32.to_le_bytes());
    }));
    assert!(err.to_string().contains("its mip level 0 holds"), "{err}");
}

/// Plain KTX2 files, written by KTX-Software's `ktx create` and `ktx transcode`, draw as the PNG
/// does: as they are where the device samples their format (taking less memory than RGBA8),
/// decoded to RGBA8 where it does not, where their size is not whole blocks, or where they have
/// no chain (the GPU makes it from RGBA8).
#[test]
fn plain_ktx2_textures_draw_as_their_png_original() {
    use wgpu::Features as F;
    let png = render("BoxTextured/BoxTextured.glb");
    let original = GltfScene::load(&asset("BoxTextured/BoxTextured.glb"), &ImportOptions::default()).unwrap();
    let texels = original.images().next().unwrap().rgba8.clone();
    let features = common::gpu().device.features();
    for (image, name, max, needs) in [
        // Texels: the same image, the file's chain made by `ktx` (box filter).
        ("CesiumLogoFlat-rgba8-zstd.ktx2", "R8G8B8A8", 0.005, None),
        ("CesiumLogoFlat-rgb8-zlib.ktx2", "R8G8B8", 0.001, None),
        // Blocks transcoded from the UASTC file (its own levels), as the UASTC file draws.
        ("CesiumLogoFlat-bc7-zstd.ktx2", "BC7", 0.02, Some(F::TEXTURE_COMPRESSION_BC)),
        ("CesiumLogoFlat-bc1-zstd.ktx2", "BC1_RGB", 0.04, Some(F::TEXTURE_COMPRESSION_BC)),
        ("CesiumLogoFlat-etc2-zstd.ktx2", "ETC2_R8G8B8A8", 0.045, Some(F::TEXTURE_COMPRESSION_ETC2)),
        // No chain: decoded, and the chain made on the GPU.
        ("CesiumLogoFlat-bc7-nomips-zstd.ktx2", "BC7", 0.005, None),
        // Encoded by astcenc through `ktx create` (box-filtered chain).
        ("CesiumLogoFlat-astc4x4-zstd.ktx2", "ASTC_4x4", 0.015, Some(F::TEXTURE_COMPRESSION_ASTC)),
        // 256 is not a whole number of 6×6 blocks: decoded on every device.
        ("CesiumLogoFlat-astc6x6-zlib.ktx2", "ASTC_6x6", 0.03, None),
    ] {
        let path = scene_with("ktx2-plain", image, |_| {});
        let scene = GltfScene::load(&path, &ImportOptions::default()).unwrap_or_else(|e| panic!("{e}"));
        let compressed = scene.images().next().and_then(|i| i.compressed.clone()).expect("kept as KTX2");
        assert!(matches!(compressed.source(), Source::Plain { name: n, .. } if n == name), "{image}: {compressed:?}");
        // Level 0 decoded on the CPU against the PNG's texels (mean difference per channel, of 255).
        let decoded = compressed.decode_rgba8().unwrap();
        let diff = decoded.iter().zip(&texels).map(|(&a, &b)| a.abs_diff(b) as f64).sum::<f64>() / texels.len() as f64;
        eprintln!("{image}: level 0 differs from the PNG's texels by {diff:.3} of 255 on average");
        if needs.is_none() && !name.starts_with("BC") && !name.starts_with("ASTC") {
            assert_eq!(diff, 0.0, "{image}: texels as they were");
        }
        assert!(diff < 3.0, "{image}: level 0 decodes to other texels");
        let (shot, memory) = render_path(&path);
        let error = flip_mean(&shot.rgba8, &png.rgba8, 128, 128);
        eprintln!(
            "{image} against the PNG: FLIP mean {error:.5}, {} of {} bytes",
            memory.textures, memory.textures_rgba8
        );
        assert!(error < max, "{image} against the PNG: FLIP mean {error}");
        let native = needs.is_some_and(|f| features.contains(f)) && !compressed.block_formats().is_empty();
        if native {
            // A quarter (an eighth for BC1), and whole blocks at the chain's small end.
            assert!(memory.textures * 3 < memory.textures_rgba8, "{image}: {memory:?}");
        } else {
            assert_eq!(memory.textures, memory.textures_rgba8, "{image}: RGBA8, {memory:?}");
        }
    }
}

/// An OBJ material may name a KTX2 texture too: it is kept compressed like a glTF one.
#[test]
fn obj_materials_take_ktx2_textures() {
    let dir = scratch_dir("ktx2-obj");
    std::fs::copy(asset("BoxTexturedKtx2/CesiumLogoFlat-uastc.ktx2"), dir.join("logo.ktx2")).unwrap();
    std::fs::write(dir.join("quad.mtl"), "newmtl logo\nKd 1 1 1\nmap_Kd logo.ktx2\n").unwrap();
    std::fs::write(
        dir.join("quad.obj"),
        "mtllib quad.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nusemtl logo\nf 1/1 2/2 3/3 4/4\n",
    )
    .unwrap();
    let scene = penumbra::engine::import::ObjScene::load(&dir.join("quad.obj"), &ImportOptions::default())
        .unwrap_or_else(|e| panic!("{e}"));
    assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
    let mut app = common::scene_app();
    scene.spawn(&mut app.world);
    let images = app.world.resource::<penumbra::engine::Assets<penumbra::engine::image::Image>>();
    let image = images.iter().map(|(_, i)| i).next().expect("the texture");
    assert!(image.compressed.is_some() && image.rgba8.is_empty(), "kept compressed");
}

/// ETC2 and ASTC blocks sampled by a GPU draw what decoding them on the CPU draws: wgpu's GL
/// backend on Mesa's llvmpipe samples both (GLES 3 requires ETC2), lavapipe's Vulkan neither, so
/// the one device takes the native path and the other the decoder's.
#[test]
fn etc2_and_astc_sampled_by_the_gpu_draw_as_decoded_on_the_cpu() {
    use wgpu::Features as F;
    let gl = penumbra::render::GpuContext::new_headless(&penumbra::render::AdapterRequest {
        backends: Some(wgpu::Backends::GL),
        ..Default::default()
    })
    .unwrap_or_else(|e| panic!("this test needs wgpu's GL backend (libegl1 libegl-mesa0 libgl1-mesa-dri): {e}"));
    assert!(gl.device.features().contains(F::TEXTURE_COMPRESSION_ETC2), "GLES 3 samples ETC2");
    for (image, family) in [
        ("CesiumLogoFlat-etc2-zstd.ktx2", F::TEXTURE_COMPRESSION_ETC2),
        ("CesiumLogoFlat-astc4x4-zstd.ktx2", F::TEXTURE_COMPRESSION_ASTC),
    ] {
        assert!(
            gl.device.features().contains(family),
            "{image}: this GL adapter does not sample {family:?} (llvmpipe does)"
        );
        let path = scene_with("ktx2-native", image, |_| {});
        let (native, memory) = render_path_on(gl.clone(), &path);
        assert!(memory.textures * 3 < memory.textures_rgba8, "{image} sampled as blocks on GL: {memory:?}");
        let (decoded, _) = render_path(&path);
        let error = flip_mean(&native.rgba8, &decoded.rgba8, 128, 128);
        eprintln!("{image}: sampled on GL against decoded on Vulkan: FLIP mean {error:.5}");
        assert!(error < 0.005, "{image}: FLIP mean {error} between the GPU's and the CPU's decoding");
    }
}

/// The RGBA size limit applies to KTX2 files too (checked from the header, before any level is
/// inflated).
#[test]
fn a_ktx2_over_the_image_size_limit_is_refused() {
    let path = scene_with("ktx2-limit", "CesiumLogoFlat-rgba8-zstd.ktx2", |_| {});
    let mut options = ImportOptions::default();
    options.limits.image_bytes = 100_000; // the file is 14 KB, its RGBA level 0 256 KiB
    let err = GltfScene::load(&path, &options).expect_err("over the limit");
    assert!(err.to_string().contains("decoded RGBA size"), "{err}");
}
