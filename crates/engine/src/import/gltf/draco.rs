//! `KHR_draco_mesh_compression`: a primitive whose geometry is one Draco stream, decoded at
//! import by draco-core (a pure-Rust Draco decoder that reads what Google's C++ Draco writes).
//!
//! [`decode`] reads the primitive's extension and decodes its stream with ceilings inside the
//! decoder (the points one also checked after it): no more points than its POSITION accessor declares (the extension requires the two
//! equal, and the declared counts are what the import's vertex total was checked on), no more
//! triangles than its indices accessor declares, and no more bytes than the import's decoded-data
//! budget has left, so a few bytes cannot ask for gigabytes; the primitive builder then takes each attribute the extension names from the
//! result ([`DracoPrimitive::read`]) instead of from the accessor (which carries only the count,
//! type and bounds), and the triangles in place of the indices accessor. Attributes the
//! extension does not name, and morph targets, are read from their accessors as usual.

use std::collections::HashMap;

use draco_core::draco_types::DataType;
use draco_core::geometry_attribute::PointAttribute;
use draco_core::geometry_indices::PointIndex;
use draco_core::{DecodeLimits, DecoderBuffer, Mesh, MeshDecoder};
use gltf::json::Value;

use gltf::accessor::DataType as GltfType;

use super::accessor::{AccessorError, AccessorResult, Buffers, read_component};

pub(crate) const EXTENSION: &str = "KHR_draco_mesh_compression";

/// A primitive's decoded Draco geometry.
pub(crate) struct DracoPrimitive {
    mesh: Mesh,
    /// Draco attribute unique id by glTF semantic name (`POSITION`, `TEXCOORD_0`...).
    ids: HashMap<String, u32>,
}

/// Decodes the primitive's Draco stream, if it has one. Errors are worded for
/// `mesh M primitive P: ...`.
pub(crate) fn decode(
    document: &gltf::Document,
    prim: &gltf::Primitive,
    buffers: &Buffers,
) -> Result<Option<DracoPrimitive>, AccessorError> {
    let Some(ext) = prim.extension_value(EXTENSION) else {
        return Ok(None);
    };
    decode_extension(document, prim, ext, buffers).map(Some).map_err(|e| e.context(EXTENSION))
}

fn decode_extension(
    document: &gltf::Document,
    prim: &gltf::Primitive,
    ext: &Value,
    buffers: &Buffers,
) -> AccessorResult<DracoPrimitive> {
    use gltf::mesh::Mode;
    if !matches!(prim.mode(), Mode::Triangles | Mode::TriangleStrip) {
        return Err(
            format!("mode {:?} cannot be Draco-compressed (only triangles and triangle strips)", prim.mode()).into()
        );
    }
    let view_index = ext
        .get("bufferView")
        .and_then(Value::as_u64)
        .ok_or_else(|| String::from("\"bufferView\" is missing or not an index"))? as usize;
    let view = document.views().nth(view_index).ok_or_else(|| format!("bufferView {view_index} does not exist"))?;
    let stream = buffers.view(&view)?;
    let names = ext
        .get("attributes")
        .and_then(Value::as_object)
        .ok_or_else(|| String::from("\"attributes\" is missing or not an object"))?;

    let limits = buffers.limits();
    let points = prim.get(&gltf::Semantic::Positions).map_or(0, |a| a.count() as u64);
    let faces = prim.indices().map_or(limits.accessor_elements, |a| a.count() as u64) / 3;
    let decode_limits = DecodeLimits::default()
        .with_max_points(points.min(limits.accessor_elements))
        .with_max_faces(faces.min(limits.accessor_elements / 3))
        .with_max_decoded_bytes(limits.decoded_bytes.saturating_sub(buffers.decoded()));
    let mut reader = DecoderBuffer::new(stream).with_limits(decode_limits);
    let mut mesh = Mesh::new();
    MeshDecoder::new().decode(&mut reader, &mut mesh).map_err(|e| {
        format!(
            "the compressed data (bufferView {view_index}) does not decode: {e} (its accessors declare {points} \
                 points and {faces} triangles, which the stream may not exceed)"
        )
    })?;

    // The decoder's own ceiling is not enforced on every path; the declared count bounds it here.
    if mesh.num_points() as u64 > points {
        return Err(format!(
            "the compressed data decodes to {} points, more than the {points} its POSITION accessor declares \
             (the extension requires them equal)",
            mesh.num_points()
        )
        .into());
    }
    let mut ids = HashMap::new();
    for (name, id) in names {
        let id = id
            .as_u64()
            .and_then(|id| u32::try_from(id).ok())
            .ok_or_else(|| format!("attributes.{name} is not a Draco attribute id"))?;
        if mesh.attribute_by_unique_id(id).is_none() {
            return Err(format!(
                "attributes.{name} names Draco attribute {id}, which the compressed data does not have"
            )
            .into());
        }
        ids.insert(name.clone(), id);
    }
    let points = mesh.num_points();
    if let Some(bad) = mesh.faces().iter().flatten().find(|p| p.0 as usize >= points) {
        return Err(format!("the compressed triangles name point {} of {points}", bad.0).into());
    }
    buffers.charge(mesh.num_faces() * 3, 4)?;
    Ok(DracoPrimitive { mesh, ids })
}

impl DracoPrimitive {
    /// The attribute's values as `N` floats each, converted as the accessor describes them
    /// (normalised integers per the glTF spec), or `None` when the extension does not carry it.
    pub(crate) fn read<const N: usize>(
        &self,
        semantic: &gltf::Semantic,
        accessor: &gltf::Accessor,
        buffers: &Buffers,
    ) -> Option<AccessorResult<Vec<[f32; N]>>> {
        let id = *self.ids.get(&semantic.to_string())?;
        let attribute = self.mesh.attribute_by_unique_id(id)?;
        Some(
            self.convert(attribute, accessor.normalized(), buffers)
                .map_err(|e| e.context(format!("{EXTENSION} attribute {id}"))),
        )
    }

    fn convert<const N: usize>(
        &self,
        a: &PointAttribute,
        normalized: bool,
        buffers: &Buffers,
    ) -> AccessorResult<Vec<[f32; N]>> {
        let components = a.num_components() as usize;
        if components != N {
            return Err(format!("has {components} components, the accessor {N}").into());
        }
        // The glTF component type the values are in: converted (normalised per the accessor)
        // by the accessor reader's own conversion.
        let ty = match a.data_type() {
            DataType::Float32 => GltfType::F32,
            DataType::Uint8 => GltfType::U8,
            DataType::Int8 => GltfType::I8,
            DataType::Uint16 => GltfType::U16,
            DataType::Int16 => GltfType::I16,
            DataType::Uint32 => GltfType::U32,
            other => return Err(format!("has component type {other:?}, which no glTF accessor has").into()),
        };
        let points = self.mesh.num_points();
        buffers.charge(points, N * 4)?;
        let width = a.data_type().byte_length();
        let stride = usize::try_from(a.byte_stride()).unwrap_or(0).max(width * N);
        let data = a.buffer().data();
        (0..points)
            .map(|p| {
                let v = a.mapped_index(PointIndex(p as u32)).0 as usize;
                let value = (v < a.size())
                    .then(|| data.get(v.checked_mul(stride)?..)?.get(..width * N))
                    .flatten()
                    .ok_or_else(|| AccessorError::from(format!("point {p} names value {v} of {}", a.size())))?;
                Ok(std::array::from_fn(|c| read_component(&value[c * width..], ty, normalized)))
            })
            .collect()
    }

    /// The triangles, as a list of indices.
    pub(crate) fn indices(&self) -> Vec<u32> {
        self.mesh.faces().iter().flatten().map(|p| p.0).collect()
    }
}
