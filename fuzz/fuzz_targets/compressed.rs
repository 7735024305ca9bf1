//! Compressed geometry through the importer's decoders: a Draco stream
//! (`KHR_draco_mesh_compression`: draco-core under the import limits, then attribute conversion
//! and mesh validation) or one meshopt-compressed bufferView (`KHR_meshopt_compression`: every
//! mode and filter, meshoptimizer's decoders). The input is wrapped in a minimal GLB whose binary
//! chunk is the stream, so the mutations land in the compressed bytes rather than in JSON.
//!
//! Layout: `[pick, a, b, c, stream...]`. Draco (`pick` even): `a`, `b`, `c` are the Draco
//! attribute ids of POSITION, NORMAL and TEXCOORD_0. Meshopt (`pick` odd): `pick >> 1` picks the
//! mode (its two low bits, mod 3) and `pick >> 3` the filter (mod 5); `a` is the byte stride, `b | c << 8` the count.
#![no_main]

use std::path::Path;

use libfuzzer_sys::fuzz_target;
use penumbra_engine::import::{GltfScene, ImportOptions};

fn glb(json: String, bin: &[u8]) -> Vec<u8> {
    let mut j = json.into_bytes();
    while j.len() % 4 != 0 {
        j.push(b' ');
    }
    let mut b = bin.to_vec();
    while b.len() % 4 != 0 {
        b.push(0);
    }
    let total = 28 + j.len() + b.len();
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

fn draco(ids: [u8; 3], len: usize) -> String {
    let [p, n, t] = ids;
    format!(
        r#"{{"asset":{{"version":"2.0"}},"extensionsUsed":["KHR_draco_mesh_compression"],"extensionsRequired":["KHR_draco_mesh_compression"],
"buffers":[{{"byteLength":{len}}}],"bufferViews":[{{"buffer":0,"byteLength":{len}}}],
"accessors":[{{"componentType":5126,"count":3,"type":"VEC3","min":[-1,-1,-1],"max":[1,1,1]}},{{"componentType":5126,"count":3,"type":"VEC3"}},{{"componentType":5126,"count":3,"type":"VEC2"}},{{"componentType":5125,"count":3,"type":"SCALAR"}}],
"meshes":[{{"primitives":[{{"attributes":{{"POSITION":0,"NORMAL":1,"TEXCOORD_0":2}},"indices":3,
"extensions":{{"KHR_draco_mesh_compression":{{"bufferView":0,"attributes":{{"POSITION":{p},"NORMAL":{n},"TEXCOORD_0":{t}}}}}}}}}]}}],
"nodes":[{{"mesh":0}}],"scenes":[{{"nodes":[0]}}]}}"#
    )
}

fn meshopt(pick: u8, stride: u8, count: u16, len: usize) -> String {
    let mode = ["ATTRIBUTES", "TRIANGLES", "INDICES"][((pick >> 1) & 3) as usize % 3];
    let filter = ["NONE", "OCTAHEDRAL", "QUATERNION", "EXPONENTIAL", "COLOR"][(pick >> 3) as usize % 5];
    let size = stride as usize * count as usize;
    format!(
        r#"{{"asset":{{"version":"2.0"}},"extensionsUsed":["KHR_meshopt_compression"],"extensionsRequired":["KHR_meshopt_compression"],
"buffers":[{{"byteLength":{len}}},{{"byteLength":{size},"extensions":{{"KHR_meshopt_compression":{{"fallback":true}}}}}}],
"bufferViews":[{{"buffer":1,"byteLength":{size},"extensions":{{"KHR_meshopt_compression":{{"buffer":0,"byteLength":{len},"byteStride":{stride},"count":{count},"mode":"{mode}","filter":"{filter}"}}}}}}],
"scenes":[{{"nodes":[]}}]}}"#
    )
}

fuzz_target!(|data: &[u8]| {
    let [pick, a, b, c, stream @ ..] = data else { return };
    let json = if pick & 1 == 0 {
        draco([*a, *b, *c], stream.len())
    } else {
        meshopt(*pick, *a, u16::from_le_bytes([*b, *c]), stream.len())
    };
    let mut options = ImportOptions::default();
    options.limits.decoded_bytes = 64 << 20;
    let _ = GltfScene::from_bytes(&glb(json, stream), Path::new("/nonexistent-penumbra-fuzz/scene.glb"), &options);
});
