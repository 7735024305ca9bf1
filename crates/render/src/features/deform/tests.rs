//! Tests of `deform`.

use super::*;
use glam::{Quat, Vec4};
use penumbra_engine::mesh::MorphTarget;
use penumbra_engine::scenes::SplitMix64;

#[test]
fn gpu_job_mirrors_the_shaders_job() {
    crate::pipelines::shader_library::assert_mirrors_wgsl!(
        GpuJob,
        "deform.wgsl",
        [],
        "Job",
        [source_vertex, output_vertex, vertex_count, skin_offset, joint_row, morph_offset, target_count, weight_offset]
    );
}

#[test]
fn pose_bounds_contain_every_skinned_and_morphed_vertex() {
    let mut rng = SplitMix64(7);
    let n = 400;
    let mut mesh = Mesh::default();
    let mut target = MorphTarget::default();
    for i in 0..n {
        mesh.positions.push(Vec3::new(rng.uniform(-1.0, 1.0), rng.uniform(0.0, 2.0), rng.uniform(-1.0, 1.0)));
        target.positions.push(Vec3::new(rng.uniform(-0.2, 0.2), rng.uniform(-0.2, 0.2), 0.0));
        let j = [(i % 5) as u16, ((i / 5) % 5) as u16, 0, 4];
        // Every tenth vertex is unskinned (all weights 0).
        let w = if i % 10 == 0 {
            Vec4::ZERO
        } else {
            let w = Vec4::new(rng.uniform(0.0, 1.0), rng.uniform(0.0, 1.0), rng.uniform(0.0, 0.3), 0.0);
            w / w.element_sum()
        };
        mesh.joints.push(j);
        mesh.weights.push(w);
    }
    mesh.morph_targets.push(target);
    let words = source_words(&mesh);
    let mut data = vec![0u32; words as usize];
    let source = pack_source(&mesh, &std::sync::Arc::new(mesh.clone()), 0..words, &mut data);
    assert_eq!(source.joint_count, 5);
    for trial in 0..20 {
        let pose = ExtractedDeform {
            joints: (0..5)
                .map(|j| {
                    Mat4::from_scale_rotation_translation(
                        Vec3::splat(rng.uniform(0.5, 2.0)),
                        Quat::from_rotation_y(rng.uniform(-3.0, 3.0) + j as f32),
                        Vec3::new(rng.uniform(-5.0, 5.0), rng.uniform(-5.0, 5.0), 0.0),
                    )
                })
                .collect(),
            morph_weights: vec![rng.uniform(-1.5, 1.5)],
        };
        let b = pose_bounds(&source, &pose);
        // The CPU twin of what deform.wgsl computes.
        for (v, p) in mesh.deformed_positions(&pose.joints, &pose.morph_weights).into_iter().enumerate() {
            let inside = p.cmpge(b.min - 1e-4).all() && p.cmple(b.max + 1e-4).all();
            assert!(inside, "trial {trial}: vertex {v} at {p} is outside {b:?}");
        }
    }
}

#[test]
fn packing_puts_joints_weights_and_displacements_where_the_shader_reads_them() {
    let mut mesh = Mesh {
        positions: vec![Vec3::ZERO, Vec3::X],
        joints: vec![[1, 2, 3, 65535], [0; 4]],
        weights: vec![Vec4::new(0.5, 0.25, 0.25, 0.0), Vec4::X],
        ..Default::default()
    };
    mesh.morph_targets.push(MorphTarget {
        positions: vec![Vec3::Y, Vec3::Z],
        normals: vec![],
        tangents: vec![Vec3::X, Vec3::X],
    });
    let words = source_words(&mesh);
    assert_eq!(words as usize, 2 * SKIN_WORDS + 2 * MORPH_WORDS);
    let mut data = vec![0u32; words as usize + 10];
    let s = pack_source(&mesh, &std::sync::Arc::new(mesh.clone()), 10..10 + words, &mut data[10..]);
    assert_eq!((s.skin_offset, s.morph_offset), (Some(10), 10 + 2 * SKIN_WORDS as u32));
    let d = &data[10..];
    assert_eq!(d[0], 1 | 2 << 16);
    // The fourth influence has weight 0: its padding index 65535 is packed as joint 0.
    assert_eq!(d[1], 3);
    assert_eq!(s.joint_count, 4);
    assert_eq!(f32::from_bits(d[3]), 0.25);
    let m = 2 * SKIN_WORDS;
    // Target 0, vertex 1: position (0, 0, 1), normal 0, tangent (1, 0, 0).
    let v1: Vec<f32> = d[m + MORPH_WORDS..m + 2 * MORPH_WORDS].iter().map(|w| f32::from_bits(*w)).collect();
    assert_eq!(v1, [0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0]);
}
