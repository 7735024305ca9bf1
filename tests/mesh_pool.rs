//! The mesh pool on a real device: identical meshes share one entry, growth keeps every earlier
//! allocation's bytes, and released entries are evicted and their ranges reused.

use std::sync::Arc;

use penumbra::prelude::*;
use penumbra::render::resources::mesh_pool::{GpuVertex, MeshPool};
use penumbra::render::scene::world::Snapshot;

mod common;
use common::gpu;

fn snapshot(mesh: Mesh, version: u64) -> Snapshot<Mesh> {
    Snapshot { version, data: Arc::new(mesh) }
}

/// The pool's vertex buffer, read back.
fn read_vertices(pool: &MeshPool) -> Vec<GpuVertex> {
    let ctx = gpu();
    let size = pool.vertex_buffer().size();
    let staging = ctx.device.create_buffer(&wgpu::BufferDescriptor {
        label: None,
        size,
        usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
        mapped_at_creation: false,
    });
    let mut enc = ctx.device.create_command_encoder(&Default::default());
    enc.copy_buffer_to_buffer(pool.vertex_buffer(), 0, &staging, 0, size);
    ctx.queue.submit([enc.finish()]);
    staging.slice(..).map_async(wgpu::MapMode::Read, |_| {});
    ctx.device.poll(wgpu::PollType::wait_indefinitely()).unwrap();
    let data = staging.slice(..).get_mapped_range().unwrap();
    bytemuck_cast(&data)
}

fn bytemuck_cast(bytes: &[u8]) -> Vec<GpuVertex> {
    bytes.chunks_exact(64).map(|c| *bytemuck::from_bytes::<GpuVertex>(c)).collect()
}

#[test]
fn identical_meshes_share_an_entry_and_growth_preserves_data() {
    let ctx = gpu();
    let mut pool = MeshPool::new(&ctx.device);
    let mut assets = Assets::<Mesh>::new();
    let a = assets.add(Mesh::uv_sphere(1.0, 16, 8));
    let b = assets.add(Mesh::uv_sphere(1.0, 16, 8));
    let ia = pool.get_or_upload(&ctx.device, &ctx.queue, a, &snapshot(Mesh::uv_sphere(1.0, 16, 8), 1), 1);
    let ib = pool.get_or_upload(&ctx.device, &ctx.queue, b, &snapshot(Mesh::uv_sphere(1.0, 16, 8), 1), 1);
    assert_eq!(ia, ib, "identical content must share one pool entry");
    assert_eq!(pool.stats().entries, 1);
    let first_range = pool.entry(ia).unwrap().vertices.clone();
    let capacity = pool.stats().vertex_capacity_bytes;

    // A mesh larger than the whole initial buffer forces growth.
    let big_count = (capacity / 64) as u32 + 10;
    let big = Mesh {
        positions: (0..big_count).map(|i| Vec3::new(i as f32, 0.0, 0.0)).collect(),
        topology: Topology::PointList,
        ..Default::default()
    };
    let c = assets.add(big.clone());
    let ic = pool.get_or_upload(&ctx.device, &ctx.queue, c, &snapshot(big, 1), 1);
    ctx.queue.submit([]);
    assert!(pool.stats().vertex_capacity_bytes > capacity, "the vertex buffer grew");
    assert_eq!(pool.entry(ia).unwrap().vertices, first_range, "earlier allocations keep their offsets");

    let vertices = read_vertices(&pool);
    let sphere = Mesh::uv_sphere(1.0, 16, 8);
    for (k, i) in first_range.clone().enumerate() {
        assert_eq!(vertices[i as usize].position, sphere.positions[k].to_array(), "sphere vertex {k} lost in growth");
    }
    let big_range = pool.entry(ic).unwrap().vertices.clone();
    assert_eq!(vertices[big_range.start as usize + 7].position, [7.0, 0.0, 0.0]);
}

#[test]
fn released_entries_are_evicted_and_their_space_reused() {
    let ctx = gpu();
    let mut pool = MeshPool::new(&ctx.device);
    let mut assets = Assets::<Mesh>::new();
    let a = assets.add(Mesh::cuboid(Vec3::ONE));
    let ia = pool.get_or_upload(&ctx.device, &ctx.queue, a, &snapshot(Mesh::cuboid(Vec3::ONE), 1), 1);
    let range = pool.entry(ia).unwrap().vertices.clone();
    assert_eq!(pool.evict(2), 0, "an entry still referenced stays");
    pool.release_asset(a);
    assert_eq!(pool.evict(3), 1);
    assert!(pool.entry(ia).is_none());
    let b = assets.add(Mesh::plane(1.0));
    let ib = pool.get_or_upload(&ctx.device, &ctx.queue, b, &snapshot(Mesh::plane(1.0), 1), 4);
    assert_eq!(pool.entry(ib).unwrap().vertices.start, range.start, "the freed range is reused");
    // Entries not drawn for longer than the eviction window go too (and come back on use).
    let late = 4 + pool.evict_after_frames + 1;
    assert_eq!(pool.evict(late), 1);
    let again = pool.get_or_upload(&ctx.device, &ctx.queue, b, &snapshot(Mesh::plane(1.0), 1), late);
    assert!(pool.entry(again).is_some());
    ctx.queue.submit([]);
}

#[test]
fn line_entries_and_their_deformed_copies_start_at_a_multiple_of_four_vertices() {
    let ctx = gpu();
    let mut pool = MeshPool::new(&ctx.device);
    let mut assets = Assets::<Mesh>::new();
    let lines = Mesh {
        topology: Topology::LineList,
        positions: vec![Vec3::ZERO, Vec3::X, Vec3::Y],
        indices: Some(vec![0, 1, 1, 2, 2, 0]),
        ..Default::default()
    };
    let mut line_ids = Vec::new();
    // Odd-sized entries between them, so a start of a multiple of four is no accident.
    for (i, odd) in [1u32, 3, 5].into_iter().enumerate() {
        let points = Mesh {
            topology: Topology::PointList,
            positions: (0..odd).map(|k| Vec3::splat((10 * i as u32 + k) as f32)).collect(),
            ..Default::default()
        };
        let p = assets.add(points.clone());
        pool.get_or_upload(&ctx.device, &ctx.queue, p, &snapshot(points, 1), 1);
        let moved = Mesh { positions: lines.positions.iter().map(|p| *p + i as f32).collect(), ..lines.clone() };
        let l = assets.add(moved.clone());
        line_ids.push(pool.get_or_upload(&ctx.device, &ctx.queue, l, &snapshot(moved, 1), 1));
    }
    // Odd-sized entries between the derived copies too (where each lands is the allocator's
    // choice; `align_within`'s unit test covers the arithmetic).
    let mut derived_ids = Vec::new();
    for (k, odd) in [3usize, 1, 5].into_iter().enumerate() {
        let points =
            Mesh { topology: Topology::PointList, positions: vec![Vec3::splat(k as f32); odd], ..Default::default() };
        let p = assets.add(points.clone());
        pool.get_or_upload(&ctx.device, &ctx.queue, p, &snapshot(points, 1), 1);
        derived_ids.push(pool.allocate_derived(&ctx.device, &ctx.queue, line_ids[k]).unwrap());
    }
    ctx.queue.submit([]);
    let vertices = read_vertices(&pool);
    for (i, id) in line_ids.iter().enumerate() {
        let e = pool.entry(*id).unwrap();
        assert_eq!(e.vertices.start % 4, 0, "line entry {i} starts at {}", e.vertices.start);
        // Three segments, four corners each, six indices each (two triangles).
        assert_eq!((e.vertices.len(), e.element_count()), (12, 18));
        // Corner 2 of the second segment (1 -> 2) is a copy of vertex 2.
        assert_eq!(vertices[e.vertices.start as usize + 6].position, (Vec3::Y + i as f32).to_array());
    }
    for id in derived_ids {
        let d = pool.entry(id).unwrap();
        assert_eq!((d.vertices.start % 4, d.vertices.len()), (0, 12), "a deformed copy of lines");
    }
}
