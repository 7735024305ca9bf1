//! Draco-compresses every triangle primitive of a GLB whose attributes are float POSITION,
//! NORMAL and TEXCOORD_0 with u32/u16 indices (what tools/large_mesh.py writes), as
//! `KHR_draco_mesh_compression` (required, no fallback), with draco-core's encoder at
//! compression level 7 and gltf-pipeline's default quantization (position 14 bits, normal 10,
//! texture coordinates 12).

use draco_core::draco_types::DataType;
use draco_core::geometry_attribute::{GeometryAttributeType, PointAttribute};
use draco_core::{EncoderBuffer, EncoderOptions, Mesh, MeshEncoder};
use serde_json::{Value, json};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let (input, output) = (&args[1], &args[2]);
    let bytes = std::fs::read(input).unwrap();
    let json_len = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
    let mut doc: Value = serde_json::from_slice(&bytes[20..20 + json_len]).unwrap();
    let bin = &bytes[28 + json_len..];
    let view = |doc: &Value, accessor: u64| -> (Vec<u8>, u64, u64) {
        let a = &doc["accessors"][accessor as usize];
        let v = &doc["bufferViews"][a["bufferView"].as_u64().unwrap() as usize];
        let start = (v["byteOffset"].as_u64().unwrap_or(0) + a["byteOffset"].as_u64().unwrap_or(0)) as usize;
        let n = a["count"].as_u64().unwrap();
        let comps = match a["type"].as_str().unwrap() {
            "SCALAR" => 1,
            "VEC2" => 2,
            "VEC3" => 3,
            _ => 4,
        };
        let size = if a["componentType"] == 5123 { 2 } else { 4 };
        (bin[start..start + (n * comps * size) as usize].to_vec(), n, a["componentType"].as_u64().unwrap())
    };
    let mut out_bin: Vec<u8> = Vec::new();
    let mut out_views = Vec::new();
    let meshes = doc["meshes"].as_array().unwrap().clone();
    for (m, mesh) in meshes.iter().enumerate() {
        for (p, prim) in mesh["primitives"].as_array().unwrap().iter().enumerate() {
            let mut dmesh = Mesh::new();
            let mut ids = serde_json::Map::new();
            let mut options = EncoderOptions::new();
            options.set_compression_level(7);
            for (name, ty, comps, bits) in [
                ("POSITION", GeometryAttributeType::Position, 3u8, 14),
                ("NORMAL", GeometryAttributeType::Normal, 3, 10),
                ("TEXCOORD_0", GeometryAttributeType::TexCoord, 2, 12),
            ] {
                let Some(acc) = prim["attributes"][name].as_u64() else { continue };
                let (data, n, _) = view(&doc, acc);
                let mut attribute = PointAttribute::new();
                attribute.init(ty, comps, DataType::Float32, false, n as usize);
                attribute.buffer_mut().write(0, &data);
                let id = dmesh.add_attribute(attribute);
                options.set_attribute_quantization(id, bits);
                ids.insert(name.into(), json!(id));
            }
            let (indices, _, kind) = view(&doc, prim["indices"].as_u64().unwrap());
            let flat: Vec<u32> = if kind == 5123 {
                indices.chunks_exact(2).map(|b| u16::from_le_bytes([b[0], b[1]]) as u32).collect()
            } else {
                indices.chunks_exact(4).map(|b| u32::from_le_bytes(b.try_into().unwrap())).collect()
            };
            // set_faces_from_flat_indices fills the faces already there.
            dmesh.set_num_faces(flat.len() / 3);
            dmesh.set_faces_from_flat_indices(&flat);
            let mut encoder = MeshEncoder::new();
            encoder.set_mesh(dmesh);
            let mut buffer = EncoderBuffer::new();
            encoder.encode(&options, &mut buffer).unwrap();
            let data = buffer.data();
            out_views.push(json!({"buffer": 0, "byteOffset": out_bin.len(), "byteLength": data.len()}));
            out_bin.extend_from_slice(data);
            while out_bin.len() % 4 != 0 {
                out_bin.push(0);
            }
            let prim_json = &mut doc["meshes"][m]["primitives"][p];
            prim_json["extensions"] = json!({"KHR_draco_mesh_compression": {"bufferView": out_views.len() - 1, "attributes": ids}});
            eprintln!("mesh {m} primitive {p}: {} bytes", data.len());
        }
    }
    // Accessors keep count, type and bounds; their data is the Draco stream's.
    for a in doc["accessors"].as_array_mut().unwrap() {
        a.as_object_mut().unwrap().remove("bufferView");
        a.as_object_mut().unwrap().remove("byteOffset");
    }
    doc["bufferViews"] = Value::Array(out_views);
    doc["buffers"] = json!([{"byteLength": out_bin.len()}]);
    doc["extensionsUsed"] = json!(["KHR_draco_mesh_compression"]);
    doc["extensionsRequired"] = json!(["KHR_draco_mesh_compression"]);
    let mut j = serde_json::to_vec(&doc).unwrap();
    while j.len() % 4 != 0 {
        j.push(b' ');
    }
    let total = 28 + j.len() + out_bin.len();
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(j.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&j);
    out.extend_from_slice(&(out_bin.len() as u32).to_le_bytes());
    out.extend_from_slice(b"BIN\0");
    out.extend_from_slice(&out_bin);
    std::fs::write(output, out).unwrap();
    println!("{output}: {total} bytes");
}
