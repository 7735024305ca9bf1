//! What Penumbra's whole path costs over the least a wgpu program can do, on the least a scene
//! can hold: one unlit triangle at 1920×1080.
//!
//! - `minimal wgpu`: a hand-written program (its own instance, adapter and device) that clears
//!   an 8-bit sRGB target and draws the triangle from a constant array: one render pass, one
//!   pipeline, no buffers.
//! - `penumbra`: the same triangle as an ECS entity (unlit material, camera), through
//!   extraction, prepare, the frame plan and the passes it picks (culling, the HDR forward pass,
//!   tonemapping), at MSAA 1 and at the default MSAA 4.
//!
//! - `helmet`: DamagedHelmet under a sun and two point lights (the reference suite's scene), as
//!   the frame plan builds it, and with features forced on that change nothing in the image: a
//!   zero-intensity environment (prefilter once, IBL shading and the background every frame),
//!   bloom at strength 0, and a shadowed spot light aimed away from everything the camera sees.
//!   That difference is what leaving unused work out saves.
//!
//! Both pipeline frames the same way (at most two in flight, no readback) and report the median
//! wall time per frame and the CPU time on the calling thread per frame, measured without
//! timestamp queries, then the GPU time per frame from as many frames again with them
//! (around every pass: the first pass's beginning to the last pass's end). Penumbra's CPU time
//! is split by stage (its schedules; the render stage's prepare, encode and submit). Run: `cargo bench --bench triangle [-- --frames N
//! --size WxH --no-helmet --variants]` (`--variants`: the minimal program also with a depth
//! attachment and with a copyable target, Penumbra's forward pass's other costs, and with four
//! samples per pixel in a 16-bit float or an 8-bit sRGB target, resolved or stored: what
//! multisampling itself costs on the adapter; and with a triangle covering the whole target:
//! at 4 samples without and with depth, and at 1 sample with depth: what a view-filling
//! surface costs).

use std::collections::VecDeque;
use std::time::Instant;

use penumbra::prelude::*;
use penumbra::render::{RenderOutput, RenderPlugin};

const FRAMES: usize = 300;
const WARMUP: usize = 30;

struct Times {
    wall: Vec<f64>,
    cpu: Vec<f64>,
    gpu: Vec<f64>,
    /// Penumbra's passes: (label, GPU ms per frame).
    passes: Vec<(&'static str, Vec<f64>)>,
    /// Penumbra's CPU time by part: (label, ms per frame).
    cpu_parts: Vec<(String, Vec<f64>)>,
}

fn push(parts: &mut Vec<(String, Vec<f64>)>, label: &str, ms: f64) {
    match parts.iter_mut().find(|(l, _)| l == label) {
        Some((_, v)) => v.push(ms),
        None => parts.push((label.to_string(), vec![ms])),
    }
}

fn median(v: &[f64]) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    s[s.len() / 2]
}

const SHADER: &str = r#"
@vertex
fn vs(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
    var p = array<vec2<f32>, 3>(vec2<f32>(-0.5, -0.5), vec2<f32>(0.5, -0.5), vec2<f32>(0.0, 0.5));
    return vec4<f32>(p[i], 0.0, 1.0);
}

// A triangle over the whole target: every sample written, as a ground plane filling the view.
@vertex
fn vs_cover(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
    var p = array<vec2<f32>, 3>(vec2<f32>(-1.0, -1.0), vec2<f32>(3.0, -1.0), vec2<f32>(-1.0, 3.0));
    return vec4<f32>(p[i], 0.5, 1.0);
}

@fragment
fn fs() -> @location(0) vec4<f32> {
    return vec4<f32>(1.0, 0.5, 0.2, 1.0);
}
"#;

/// The hand-written program: everything it needs, nothing else.
/// What the minimal program adds to its one pass, to find what Penumbra's forward pass pays
/// for (`--variants`).
#[derive(Clone, Copy, Default)]
struct Extras {
    /// A `Depth32Float` attachment, cleared and discarded, depth-tested (reverse-Z).
    depth: bool,
    /// The colour target can also be copied from (a headless output is read back).
    copy_src: bool,
    /// Four samples per pixel in a target of this format (what the triangle draws into),
    /// resolved into a single-sample target of the same format by the render pass, or (`false`)
    /// stored instead: what a multisampled target itself costs on the adapter.
    msaa: Option<(wgpu::TextureFormat, bool)>,
    /// The triangle covers the whole target instead of an eighth of it.
    cover: bool,
}

fn minimal(size: (u32, u32), frames: usize, extras: Extras) -> (String, Times) {
    let instance = wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle_from_env());
    let adapter = pollster::block_on(instance.enumerate_adapters(wgpu::Backends::VULKAN))
        .into_iter()
        .max_by_key(|a| a.get_info().device_type != wgpu::DeviceType::Cpu)
        .expect("a Vulkan adapter (on Debian without a GPU: apt-get install -y mesa-vulkan-drivers)");
    let timestamps = adapter.features().contains(wgpu::Features::TIMESTAMP_QUERY);
    let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
        label: Some("minimal"),
        required_features: if timestamps { wgpu::Features::TIMESTAMP_QUERY } else { wgpu::Features::empty() },
        required_limits: wgpu::Limits::default(),
        experimental_features: wgpu::ExperimentalFeatures::disabled(),
        memory_hints: wgpu::MemoryHints::Performance,
        trace: wgpu::Trace::Off,
    }))
    .expect("a device");
    let format = extras.msaa.map_or(wgpu::TextureFormat::Rgba8UnormSrgb, |(f, _)| f);
    let samples = if extras.msaa.is_some() { 4 } else { 1 };
    // An attachment-only texture of the frame's size, as a view.
    let attachment = |label, format, samples| {
        device
            .create_texture(&wgpu::TextureDescriptor {
                label: Some(label),
                size: wgpu::Extent3d { width: size.0, height: size.1, depth_or_array_layers: 1 },
                mip_level_count: 1,
                sample_count: samples,
                dimension: wgpu::TextureDimension::D2,
                format,
                usage: wgpu::TextureUsages::RENDER_ATTACHMENT,
                view_formats: &[],
            })
            .create_view(&Default::default())
    };
    let msaa_view = extras.msaa.map(|_| attachment("multisampled", format, samples));
    let resolve = extras.msaa.is_some_and(|(_, r)| r);
    let target = device.create_texture(&wgpu::TextureDescriptor {
        label: Some("target"),
        size: wgpu::Extent3d { width: size.0, height: size.1, depth_or_array_layers: 1 },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage: if extras.copy_src {
            wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC
        } else {
            wgpu::TextureUsages::RENDER_ATTACHMENT
        },
        view_formats: &[],
    });
    let view = target.create_view(&Default::default());
    let depth_view = extras.depth.then(|| attachment("depth", wgpu::TextureFormat::Depth32Float, samples));
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("triangle"),
        source: wgpu::ShaderSource::Wgsl(SHADER.into()),
    });
    let pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some("triangle"),
        layout: None,
        vertex: wgpu::VertexState {
            module: &module,
            entry_point: Some(if extras.cover { "vs_cover" } else { "vs" }),
            compilation_options: Default::default(),
            buffers: &[],
        },
        primitive: wgpu::PrimitiveState::default(),
        depth_stencil: extras.depth.then(|| wgpu::DepthStencilState {
            format: wgpu::TextureFormat::Depth32Float,
            depth_write_enabled: Some(true),
            depth_compare: Some(wgpu::CompareFunction::Greater),
            stencil: Default::default(),
            bias: Default::default(),
        }),
        multisample: wgpu::MultisampleState { count: samples, ..Default::default() },
        fragment: Some(wgpu::FragmentState {
            module: &module,
            entry_point: Some("fs"),
            compilation_options: Default::default(),
            targets: &[Some(format.into())],
        }),
        multiview_mask: None,
        cache: None,
    });
    let total = WARMUP + frames;
    let queries = timestamps.then(|| {
        let set = device.create_query_set(&wgpu::QuerySetDescriptor {
            label: Some("timestamps"),
            ty: wgpu::QueryType::Timestamp,
            count: 2 * total as u32,
        });
        let bytes = 16 * total as u64;
        let resolve = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("resolve"),
            size: bytes,
            usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let readback = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("readback"),
            size: bytes,
            usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
            mapped_at_creation: false,
        });
        (set, resolve, readback)
    });
    let mut in_flight = VecDeque::new();
    let mut times =
        Times { wall: Vec::new(), cpu: Vec::new(), gpu: Vec::new(), passes: Vec::new(), cpu_parts: Vec::new() };
    let mut last = Instant::now();
    // Frames 0..total are timed on the CPU without timestamp queries; the next `frames` write
    // them, for the GPU time.
    for frame in 0..total + frames {
        let timestamped = frame >= total;
        let query = 2 * (frame - if timestamped { total } else { 0 }) as u32;
        let start = Instant::now();
        let mut encoder = device.create_command_encoder(&Default::default());
        {
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("triangle"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: msaa_view.as_ref().unwrap_or(&view),
                    depth_slice: None,
                    resolve_target: resolve.then_some(&view),
                    ops: wgpu::Operations {
                        load: wgpu::LoadOp::Clear(wgpu::Color::BLACK),
                        // A resolved multisampled target is not kept (as Penumbra's).
                        store: if resolve { wgpu::StoreOp::Discard } else { wgpu::StoreOp::Store },
                    },
                })],
                depth_stencil_attachment: depth_view.as_ref().map(|view| wgpu::RenderPassDepthStencilAttachment {
                    view,
                    depth_ops: Some(wgpu::Operations { load: wgpu::LoadOp::Clear(0.0), store: wgpu::StoreOp::Discard }),
                    stencil_ops: None,
                }),
                timestamp_writes: queries.as_ref().filter(|_| timestamped).map(|(set, ..)| {
                    wgpu::RenderPassTimestampWrites {
                        query_set: set,
                        beginning_of_pass_write_index: Some(query),
                        end_of_pass_write_index: Some(query + 1),
                    }
                }),
                occlusion_query_set: None,
                multiview_mask: None,
            });
            pass.set_pipeline(&pipeline);
            pass.draw(0..3, 0..1);
        }
        in_flight.push_back(queue.submit([encoder.finish()]));
        let cpu = start.elapsed().as_secs_f64() * 1e3;
        while in_flight.len() > 2 {
            let oldest = in_flight.pop_front().expect("non-empty");
            let _ = device.poll(wgpu::PollType::Wait { submission_index: Some(oldest), timeout: None });
        }
        let now = Instant::now();
        if (WARMUP..total).contains(&frame) {
            times.wall.push((now - last).as_secs_f64() * 1e3);
            times.cpu.push(cpu);
        }
        last = now;
    }
    if let Some((set, resolve, readback)) = &queries {
        let mut encoder = device.create_command_encoder(&Default::default());
        encoder.resolve_query_set(set, 0..2 * total as u32, resolve, 0);
        encoder.copy_buffer_to_buffer(resolve, 0, readback, 0, 16 * total as u64);
        queue.submit([encoder.finish()]);
        readback.slice(..).map_async(wgpu::MapMode::Read, |_| {});
        let _ = device.poll(wgpu::PollType::wait_indefinitely());
        let data = readback.slice(..).get_mapped_range().expect("mapped above");
        let ticks: &[u64] = bytemuck::cast_slice(&data);
        let period = queue.get_timestamp_period() as f64;
        times.gpu = (WARMUP.min(frames / 2)..frames)
            .map(|f| (ticks[2 * f + 1].wrapping_sub(ticks[2 * f])) as f64 * period / 1e6)
            .collect();
    }
    let info = adapter.get_info();
    (format!("{} ({:?})", info.name, info.backend), times)
}

/// The same triangle through Penumbra.
fn penumbra(size: (u32, u32), frames: usize, msaa: u32) -> Times {
    let mut app = App::new();
    app.add_plugins(CorePlugin).add_plugins(RenderPlugin);
    let triangle_mesh = Mesh {
        positions: vec![Vec3::new(-0.5, -0.5, 0.0), Vec3::new(0.5, -0.5, 0.0), Vec3::new(0.0, 0.5, 0.0)],
        normals: vec![Vec3::Z; 3],
        ..Default::default()
    };
    let mesh = app.world.resource_mut::<Assets<Mesh>>().add(triangle_mesh);
    let material = StandardMaterial { unlit: true, ..StandardMaterial::from_color(Vec4::new(1.0, 0.5, 0.2, 1.0), 1.0) };
    let material = app.world.resource_mut::<Assets<StandardMaterial>>().add(material);
    app.world.spawn((Mesh3d(mesh), MeshMaterial3d(material), Transform::IDENTITY));
    app.world.spawn((Camera::default(), Transform::from_xyz(0.0, 0.0, 2.0)));
    run(app, RenderSettings { msaa, ..Default::default() }, size, frames)
}

/// The reference suite's lit helmet, through its own camera; `forced` adds the unused features.
fn helmet(size: (u32, u32), frames: usize, forced: bool) -> Times {
    let mut app = App::new();
    app.add_plugins(CorePlugin).add_plugins(RenderPlugin);
    let path =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/assets/DamagedHelmet/DamagedHelmetLit.gltf");
    penumbra::engine::import::load_scene(&mut app.world, &path, &Default::default()).unwrap_or_else(|e| panic!("{e}"));
    let mut settings = RenderSettings::default();
    if forced {
        use penumbra::engine::environment::{Background, Environment, EnvironmentSource};
        app.insert_resource(Environment {
            source: EnvironmentSource::Studio,
            intensity: 0.0,
            rotation: 0.0,
            background: Background::Environment,
        });
        settings.post.bloom = Some(penumbra::render::BloomSettings { strength: 0.0, ..Default::default() });
        app.world.spawn((
            SpotLight { intensity: 100.0, range: Some(5.0), ..Default::default() },
            Transform::from_xyz(0.0, 0.0, -20.0).looking_at(Vec3::new(0.0, 0.0, -40.0), Vec3::Y),
        ));
        spawn_caster(&mut app);
    }
    app.update();
    let mut cameras = app.world.query::<&mut Camera>();
    for mut c in cameras.iter_mut(&mut app.world) {
        c.is_active = true;
    }
    run(app, settings, size, frames)
}

/// A small box in the spot's cone, far behind the helmet's camera: its shadow map has a caster.
fn spawn_caster(app: &mut App) {
    let mesh = app.world.resource_mut::<Assets<Mesh>>().add(Mesh::cuboid(Vec3::ONE));
    let material = app.world.resource_mut::<Assets<StandardMaterial>>().add(StandardMaterial::default());
    app.world.spawn((Mesh3d(mesh), MeshMaterial3d(material), Transform::from_xyz(0.0, 0.0, -23.0)));
}

/// Pipelined frames of `app` at `size`, timed.
fn run(mut app: App, settings: RenderSettings, size: (u32, u32), frames: usize) -> Times {
    let ctx = penumbra::render::GpuContext::new_headless(&Default::default()).unwrap_or_else(|e| panic!("{e}"));
    app.insert_resource(Renderer::new(ctx, settings.clone()).expect("a renderer"));
    app.insert_resource(RenderOutput::Headless { width: size.0, height: size.1 });
    let mut in_flight = VecDeque::new();
    let mut times =
        Times { wall: Vec::new(), cpu: Vec::new(), gpu: Vec::new(), passes: Vec::new(), cpu_parts: Vec::new() };
    let mut last = Instant::now();
    let mut last_gpu_frame = 0;
    // As with the minimal program: frames timed on the CPU first, with GPU timing off (its
    // per-frame query resolve and read-back are not part of a frame), then `frames` more with it
    // on, for the GPU times.
    let total = WARMUP + frames;
    for frame in 0..total + frames {
        if frame == total {
            let timed = RenderSettings { gpu_timing: true, ..settings.clone() };
            app.world.resource_mut::<Renderer>().set_settings(timed).expect("valid settings");
        }
        let start = Instant::now();
        let stages = app.update_timed();
        let cpu = start.elapsed().as_secs_f64() * 1e3;
        let renderer = app.world.resource::<Renderer>();
        if (WARMUP..total).contains(&frame) {
            for (label, ms) in &stages {
                push(&mut times.cpu_parts, &format!("{label:?}"), *ms);
            }
            let s = renderer.stats();
            push(&mut times.cpu_parts, "of which prepare", s.prepare_ms);
            push(&mut times.cpu_parts, "encode", s.cpu_ms - s.prepare_ms);
            push(&mut times.cpu_parts, "submit", s.submit_ms);
        }
        if let Some(s) = renderer.last_submission() {
            in_flight.push_back(s.clone());
        }
        while in_flight.len() > 2 {
            let oldest = in_flight.pop_front().expect("non-empty");
            let _ =
                renderer.context().device.poll(wgpu::PollType::Wait { submission_index: Some(oldest), timeout: None });
        }
        let now = Instant::now();
        if (WARMUP..total).contains(&frame) {
            times.wall.push((now - last).as_secs_f64() * 1e3);
            times.cpu.push(cpu);
        }
        if frame >= total + WARMUP.min(frames / 2)
            && let Some(t) = renderer.stats().gpu.as_ref().filter(|t| t.frame > last_gpu_frame)
        {
            last_gpu_frame = t.frame;
            times.gpu.push(t.span_ms);
            for (label, ms) in &t.passes {
                match times.passes.iter_mut().find(|(l, _)| l == label) {
                    Some((_, v)) => v.push(*ms),
                    None => times.passes.push((label, vec![*ms])),
                }
            }
        }
        last = now;
    }
    times
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let arg = |name: &str| args.iter().position(|a| a == name).and_then(|i| args.get(i + 1)).cloned();
    let frames = arg("--frames").and_then(|f| f.parse().ok()).unwrap_or(FRAMES);
    let size = arg("--size")
        .and_then(|s| s.split_once('x').and_then(|(w, h)| Some((w.parse().ok()?, h.parse().ok()?))))
        .unwrap_or((1920, 1080));
    // `--no-helmet`: the triangle rows only (the helmet takes most of a run on lavapipe).
    let helmets = !args.iter().any(|a| a == "--no-helmet");
    let (adapter, base) = minimal(size, frames, Extras::default());
    let mut runs = vec![("minimal wgpu", "1 pass, sRGB8 target", base)];
    if args.iter().any(|a| a == "--variants") {
        let depth = Extras { depth: true, ..Default::default() };
        let copy_src = Extras { copy_src: true, ..Default::default() };
        runs.push(("minimal wgpu", "+ depth", minimal(size, frames, depth).1));
        runs.push(("minimal wgpu", "+ COPY_SRC target", minimal(size, frames, copy_src).1));
        runs.push((
            "minimal wgpu",
            "+ both",
            minimal(size, frames, Extras { depth: true, copy_src: true, ..Default::default() }).1,
        ));
        let msaa = |format, resolve| Extras { msaa: Some((format, resolve)), ..Default::default() };
        let (hdr, srgb8) = (wgpu::TextureFormat::Rgba16Float, wgpu::TextureFormat::Rgba8UnormSrgb);
        runs.push(("minimal wgpu", "MSAA 4 RGBA16F resolved", minimal(size, frames, msaa(hdr, true)).1));
        runs.push(("minimal wgpu", "MSAA 4 RGBA16F stored", minimal(size, frames, msaa(hdr, false)).1));
        runs.push(("minimal wgpu", "MSAA 4 sRGB8 resolved", minimal(size, frames, msaa(srgb8, true)).1));
        runs.push(("minimal wgpu", "MSAA 4 sRGB8 stored", minimal(size, frames, msaa(srgb8, false)).1));
        // What the many-lights scene's ground asks of the adapter: every sample and its depth.
        let covered = |depth| Extras { depth, cover: true, ..msaa(srgb8, true) };
        runs.push(("minimal wgpu", "MSAA 4 sRGB8 resolved, covering", minimal(size, frames, covered(false)).1));
        runs.push(("minimal wgpu", "+ depth, covering", minimal(size, frames, covered(true)).1));
        let covered_1 = Extras { depth: true, cover: true, ..Default::default() };
        runs.push(("minimal wgpu", "MSAA 1 sRGB8 + depth, covering", minimal(size, frames, covered_1).1));
    }
    runs.extend([
        ("penumbra", "MSAA 1", penumbra(size, frames, 1)),
        ("penumbra", "MSAA 4 (default)", penumbra(size, frames, 4)),
    ]);
    if helmets {
        runs.push(("helmet", "as planned", helmet(size, frames, false)));
        runs.push(("helmet", "unused features on", helmet(size, frames, true)));
    }
    println!(
        "one unlit triangle (covering: the whole target) at {}x{}, {frames} frames (median), {adapter}",
        size.0, size.1
    );
    println!(
        "{:<14} {:<32} {:>9} {:>9} {:>9} {:>12}",
        "program", "settings", "frame ms", "CPU ms", "GPU ms", "frame ratio"
    );
    let base_wall = median(&runs[0].2.wall);
    for (program, settings, t) in &runs {
        let wall = median(&t.wall);
        println!(
            "{program:<14} {settings:<32} {wall:>9.3} {:>9.3} {:>9.3} {:>11.2}x",
            median(&t.cpu),
            median(&t.gpu),
            wall / base_wall
        );
        if !t.passes.is_empty() {
            let split: Vec<String> = t.passes.iter().map(|(l, v)| format!("{l} {:.3}", median(v))).collect();
            println!("{:<47} GPU ms by pass: {}", "", split.join(", "));
        }
        if !t.cpu_parts.is_empty() {
            let split: Vec<String> = t.cpu_parts.iter().map(|(l, v)| format!("{l} {:.3}", median(v))).collect();
            println!("{:<47} CPU ms by stage: {}", "", split.join(", "));
        }
    }
}
