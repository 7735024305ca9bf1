// Skinning and morph targets, computed once per changed pose into the draw's own copy of its
// mesh's vertices in the pool (the "skin cache" approach): every later pass (culling, shadow
// casters, the forward pass) draws the deformed copy as an ordinary mesh, so a character seen by
// four cascades and a point light is deformed once, not six times, and no raster pipeline needs
// a skinned variant.
//
// One workgroup row per job (workgroup_id.y + 65535 · workgroup_id.z), one thread per vertex.
// Order per vertex, as glTF defines it: morph targets displace the bind-pose attributes, then
// the skin blends its joints' matrices (mesh_from_bind, see `components::skin`) by the weights.

// The pool's vertex layout (`GpuVertex`, 16 words): position 0-2, normal 3-5, tangent 6-9,
// uv0 10-11, uv1 12-13, colour 14-15.
const VERTEX_WORDS: u32 = 16u;
const NO_SKIN: u32 = 0xffffffffu;
// Words per vertex per morph target: position, normal and tangent displacements.
const MORPH_WORDS: u32 = 9u;
// Words per skinned vertex: four u16 joints in two words, then four f32 weights.
const SKIN_WORDS: u32 = 6u;

struct Job {
    source_vertex: u32,
    output_vertex: u32,
    vertex_count: u32,
    // Words into `deform_data`, or NO_SKIN.
    skin_offset: u32,
    // First row of this draw's joint matrices in `joint_rows` (three rows a joint).
    joint_row: u32,
    morph_offset: u32,
    target_count: u32,
    // First of this draw's morph weights in `morph_weights`.
    weight_offset: u32,
};

struct Params {
    job_count: u32,
    _pad_a: u32,
    _pad_b: u32,
    _pad_c: u32,
};

@group(0) @binding(0) var<storage, read_write> vertices: array<u32>;
@group(0) @binding(1) var<storage, read> jobs: array<Job>;
@group(0) @binding(2) var<storage, read> deform_data: array<u32>;
@group(0) @binding(3) var<storage, read> joint_rows: array<vec4<f32>>;
@group(0) @binding(4) var<storage, read> morph_weights: array<f32>;
@group(0) @binding(5) var<uniform> params: Params;

fn read3(base: u32) -> vec3<f32> {
    return vec3<f32>(bitcast<f32>(vertices[base]), bitcast<f32>(vertices[base + 1u]), bitcast<f32>(vertices[base + 2u]));
}

fn data3(base: u32) -> vec3<f32> {
    return vec3<f32>(
        bitcast<f32>(deform_data[base]),
        bitcast<f32>(deform_data[base + 1u]),
        bitcast<f32>(deform_data[base + 2u])
    );
}

fn write3(base: u32, v: vec3<f32>) {
    vertices[base] = bitcast<u32>(v.x);
    vertices[base + 1u] = bitcast<u32>(v.y);
    vertices[base + 2u] = bitcast<u32>(v.z);
}

// Zero stays zero (lines and points carry no normals): normalising it would write NaN.
fn unit_or_zero(v: vec3<f32>) -> vec3<f32> {
    let len2 = dot(v, v);
    return select(vec3<f32>(0.0), v * inverseSqrt(len2), len2 > 1e-30);
}

@compute @workgroup_size(64)
fn deform(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) lane: u32) {
    let job_index = wg.y + wg.z * 65535u;
    if job_index >= params.job_count {
        return;
    }
    let job = jobs[job_index];
    let v = wg.x * 64u + lane;
    if v >= job.vertex_count {
        return;
    }
    let src = (job.source_vertex + v) * VERTEX_WORDS;
    let dst = (job.output_vertex + v) * VERTEX_WORDS;
    var position = read3(src);
    var normal = read3(src + 3u);
    var tangent = read3(src + 6u);

    for (var t = 0u; t < job.target_count; t++) {
        let w = morph_weights[job.weight_offset + t];
        if w != 0.0 {
            let base = job.morph_offset + (t * job.vertex_count + v) * MORPH_WORDS;
            position += w * data3(base);
            normal += w * data3(base + 3u);
            tangent += w * data3(base + 6u);
        }
    }

    if job.skin_offset != NO_SKIN {
        let s = job.skin_offset + v * SKIN_WORDS;
        let packed = vec2<u32>(deform_data[s], deform_data[s + 1u]);
        let joints = vec4<u32>(packed.x & 0xffffu, packed.x >> 16u, packed.y & 0xffffu, packed.y >> 16u);
        let weights = vec4<f32>(
            bitcast<f32>(deform_data[s + 2u]),
            bitcast<f32>(deform_data[s + 3u]),
            bitcast<f32>(deform_data[s + 4u]),
            bitcast<f32>(deform_data[s + 5u])
        );
        // Weights were normalised at import; all zero means "not skinned" (bind pose kept).
        if dot(weights, vec4<f32>(1.0)) > 0.0 {
            var row_x = vec4<f32>(0.0);
            var row_y = vec4<f32>(0.0);
            var row_z = vec4<f32>(0.0);
            for (var i = 0u; i < 4u; i++) {
                let r = job.joint_row + joints[i] * 3u;
                row_x += weights[i] * joint_rows[r];
                row_y += weights[i] * joint_rows[r + 1u];
                row_z += weights[i] * joint_rows[r + 2u];
            }
            let p = vec4<f32>(position, 1.0);
            position = vec3<f32>(dot(row_x, p), dot(row_y, p), dot(row_z, p));
            // Columns of the blended linear part; normals by its cofactor matrix (correct
            // under non-uniform scale), tangents by the linear part itself.
            let c0 = vec3<f32>(row_x.x, row_y.x, row_z.x);
            let c1 = vec3<f32>(row_x.y, row_y.y, row_z.y);
            let c2 = vec3<f32>(row_x.z, row_y.z, row_z.z);
            let linear = mat3x3<f32>(c0, c1, c2);
            let cofactor = mat3x3<f32>(cross(c1, c2), cross(c2, c0), cross(c0, c1));
            // The cofactor is det · inverse-transpose: a mirroring blend (det < 0) would turn
            // normals inwards without the sign.
            let det = dot(c0, cross(c1, c2));
            normal = cofactor * normal * select(1.0, -1.0, det < 0.0);
            tangent = linear * tangent;
        }
    }

    write3(dst, position);
    write3(dst + 3u, unit_or_zero(normal));
    write3(dst + 6u, unit_or_zero(tangent));
    // Tangent handedness, UVs and colour are not deformed.
    for (var i = 9u; i < VERTEX_WORDS; i++) {
        vertices[dst + i] = vertices[src + i];
    }
}
