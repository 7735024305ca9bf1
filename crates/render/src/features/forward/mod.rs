//! Forward pass: every batch as one instanced draw, or, when the cull pass culled its triangles
//! (`features::culling`), as one indexed draw of its culled triangle list through the
//! pulled-vertex variant of its pipeline. Opaque and masked batches first (sorted by pipeline,
//! material and mesh so state changes are minimal), then blended draws back to front.
//! With deferred local lights the pass splits around the deferred-lights compute pass: opaque
//! batches (also writing their surface), then the composite of the local light and the blended
//! batches. Gizmo lines, if any, end whichever pass ends the frame's drawing (after the blended
//! draws, depth-tested against everything).

use crate::features::culling::TriangleDraws;
use crate::features::deferred_lights::{CompositeFamily, DeferredLights};
use crate::features::environment::{BackgroundFamily, BackgroundMode};
use crate::features::gizmos::{GizmoDraw, GizmoFamily, GizmoKey};
use crate::frame_context::FrameContext;
use crate::pipelines::{PipelineCache, ShaderError};
use crate::resources::draws::{Batch, PipelineKey, TopologyKey};
use crate::resources::materials::extension::{EXTENSION_GROUP, TRANSMISSION_GROUP};
use crate::resources::materials::{MaterialFeatures, MaterialTable};
use crate::resources::mesh_pool::MeshPool;
use crate::targets::FrameTargets;

mod pipeline;
pub use pipeline::ForwardFamily;

/// Registers the forward pass's pipeline family (the pass itself holds no resources: it draws
/// the shared owners' buffers into the frame's targets).
/// `occlusion`: the visibility buffer's groups that a hybrid frame's draws read
/// (`features::visibility::occlusion_layouts`).
pub fn register(
    pipelines: &mut PipelineCache,
    view: &wgpu::BindGroupLayout,
    materials: &MaterialTable,
    transmission: &wgpu::BindGroupLayout,
    occlusion: &[wgpu::BindGroupLayout; 2],
) {
    pipelines.register(ForwardFamily::new(view, materials, transmission, occlusion));
}

#[derive(Debug, Default, Clone, Copy)]
pub struct DrawCounts {
    pub draw_calls: u32,
    pub instances: u32,
    pub primitives: u64,
}

impl std::ops::AddAssign for DrawCounts {
    fn add_assign(&mut self, other: Self) {
        self.draw_calls += other.draw_calls;
        self.instances += other.instances;
        self.primitives += other.primitives;
    }
}

pub struct ForwardInputs<'a> {
    pub targets: &'a FrameTargets,
    /// The frame's output: drawn into (with the tonemap in the fragment shader) when the
    /// targets have no HDR colour.
    pub output: &'a wgpu::TextureView,
    pub view_bind_group: &'a wgpu::BindGroup,
    pub mesh_pool: &'a MeshPool,
    pub materials: &'a MaterialTable,
    pub clear_color: wgpu::Color,
    /// With GPU culling: the first `batches` batches (the opaque ones) draw from these
    /// indirect arguments (`culling::ARGS_WORDS` words each, in batch order).
    pub indirect: Option<IndirectDraws<'a>>,
    /// Draw the environment behind the scene (`Pass::BACKGROUND`) in this pass, after the
    /// opaque batches (with deferred local lights; otherwise `encode_background` composites it
    /// over the resolved frame).
    pub background: bool,
    /// Gizmo lines drawn last in the pass that ends the frame's drawing.
    pub gizmos: Option<GizmoDraw<'a>>,
    /// The frame draws transmissive surfaces, which bind this group (the opaque colour's copy,
    /// `features::transmission`): the opaque pass then keeps its targets for the copy, and
    /// [`encode_rest`] draws them with the blended ones.
    pub transmission: Option<&'a wgpu::BindGroup>,
}

#[derive(Clone, Copy)]
pub struct IndirectDraws<'a> {
    pub args: &'a wgpu::Buffer,
    pub batches: usize,
    /// Batches the cull pass culled triangle by triangle: each draws its culled index list
    /// (whose arguments are in `args` as well) with the pulled-vertex variant of its pipeline.
    pub triangles: Option<&'a TriangleDraws>,
}

impl IndirectDraws<'_> {
    /// Whether batch `i` (of the whole list) draws triangle-culled.
    fn triangle_culled(&self, i: usize) -> bool {
        i < self.batches && self.triangles.is_some_and(|t| t.culled.get(i).copied().unwrap_or(false))
    }
}

/// The pipeline a batch draws with: its key, or that key's pulled-vertex variant when it is
/// triangle-culled.
fn draw_key(b: &Batch, indirect: Option<IndirectDraws>, i: usize) -> PipelineKey {
    PipelineKey { pulled_vertices: indirect.is_some_and(|d| d.triangle_culled(i)), ..b.key }
}

/// Encodes the pass. A batch whose pipeline cannot be compiled (a broken shader folder at
/// start-up) is skipped and its error returned; everything else still draws.
///
/// With deferred local lights (`targets.deferred`), the pass stops after the first
/// `opaque_count` batches, keeping colour, depth and the surface targets for the
/// deferred-lights pass; [`encode_after_deferred`] then adds its light and draws the rest.
/// Which part of the opaque phase a forward pass encodes. Occlusion culling splits it in two
/// render passes around the depth pyramid and the late cull.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum OpaquePhase {
    /// Everything in one pass.
    All,
    /// Clears, draws the opaque batches (the early draws) and keeps the targets.
    Early,
    /// Loads what `Early` left, draws the opaque batches (the late draws) and goes on as `All`.
    Late,
}

#[allow(clippy::too_many_arguments)]
pub fn encode(
    cx: &mut FrameContext,
    inputs: &ForwardInputs,
    batches: &[Batch],
    opaque_count: usize,
    phase: OpaquePhase,
) -> (DrawCounts, Option<ShaderError>) {
    let (encoder, device, pipelines, mut timer) =
        (&mut *cx.encoder, cx.device, &mut *cx.pipelines, cx.timer.as_deref_mut());
    let mut error = compile(device, pipelines, batches, 0, inputs.indirect);
    let samples = inputs.targets.samples;
    if inputs.background
        && let Err(e) = pipelines.get::<BackgroundFamily>(
            device,
            BackgroundMode::InPass { samples, surface: inputs.targets.deferred.is_some() },
        )
    {
        error = Some(e);
    }
    let (attachment, resolve_error) =
        super::resolve::prepare(device, pipelines, inputs.targets.color_attachment(inputs.output));
    if resolve_error.is_some() {
        error = resolve_error;
    }
    let (color, resolve) = (attachment.draw, attachment.pass_resolve);
    let split = inputs.targets.deferred.as_ref();
    if split.is_none()
        && phase != OpaquePhase::Early
        && let Some(e) = compile_gizmos(device, pipelines, inputs, GizmoKey { samples, occluded: false })
    {
        error = Some(e);
    }
    let (early, late) = (phase == OpaquePhase::Early, phase == OpaquePhase::Late);
    // Multisampled colour need not be stored once resolved (unless a later pass goes on).
    let ends = split.is_none() && !early && inputs.transmission.is_none();
    // With transmissive draws the pass resolves for the transmission copy and keeps its
    // targets for the draws after it.
    let resolves = ends || (split.is_none() && !early && inputs.transmission.is_some());
    let store = if resolve.is_some() && ends { wgpu::StoreOp::Discard } else { wgpu::StoreOp::Store };
    let clear_surface = |view| {
        let load = if late { wgpu::LoadOp::Load } else { wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT) };
        Some(wgpu::RenderPassColorAttachment {
            view,
            depth_slice: None,
            resolve_target: None,
            ops: wgpu::Operations { load, store: wgpu::StoreOp::Store },
        })
    };
    // With deferred lights the colour's alpha carries roughness, 0 for the background.
    let clear = wgpu::Color { a: if split.is_some() { 0.0 } else { inputs.clear_color.a }, ..inputs.clear_color };
    let mut attachments = vec![Some(wgpu::RenderPassColorAttachment {
        view: color,
        depth_slice: None,
        resolve_target: if resolves { resolve } else { None },
        ops: wgpu::Operations { load: if late { wgpu::LoadOp::Load } else { wgpu::LoadOp::Clear(clear) }, store },
    })];
    if let Some(d) = split {
        attachments.push(clear_surface(&d.surface_shape_view));
    }
    let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
        label: Some("forward"),
        color_attachments: &attachments,
        depth_stencil_attachment: inputs.targets.depth_view.as_ref().map(|view| {
            wgpu::RenderPassDepthStencilAttachment {
                view,
                // Reverse-Z: the far plane is 0.
                depth_ops: Some(wgpu::Operations {
                    load: if late { wgpu::LoadOp::Load } else { wgpu::LoadOp::Clear(0.0) },
                    store: if ends { wgpu::StoreOp::Discard } else { wgpu::StoreOp::Store },
                }),
                stencil_ops: None,
            }
        }),
        timestamp_writes: timer.as_deref_mut().and_then(|t| t.pass(if late { "forward late" } else { "forward" })),
        occlusion_query_set: None,
        multiview_mask: None,
    });
    let opaque = opaque_count.min(batches.len());
    let mut counts = draw(&mut pass, pipelines, inputs, &batches[..opaque], 0, None);
    // The background fills what the opaque draws left uncovered: after them (early depth
    // rejects it under every surface), before blended draws (which show it through). The early
    // half of occlusion culling leaves it to the late half.
    if inputs.background
        && !early
        && let Some(pipeline) = pipelines
            .cached::<BackgroundFamily>(&BackgroundMode::InPass { samples, surface: inputs.targets.deferred.is_some() })
    {
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, inputs.view_bind_group, &[]);
        pass.draw(0..3, 0..1);
    }
    if ends {
        counts += draw(&mut pass, pipelines, inputs, &batches[opaque..], opaque, None);
        draw_gizmos(&mut pass, pipelines, inputs, GizmoKey { samples, occluded: false });
    }
    drop(pass);
    if resolves {
        super::resolve::encode(encoder, device, pipelines, &attachment, timer);
    }
    (counts, error)
}

/// What [`encode_rest`] draws after the opaque pass kept its targets.
#[derive(Clone, Copy)]
pub struct Rest<'a> {
    /// After the deferred-lights pass: adds its light to the frame (with `true`: the pass ran).
    pub deferred: Option<(&'a DeferredLights, bool)>,
    /// Then draws the rest of the batches (`batches[opaque_count..]`: transmissive and blended,
    /// back to front) and the gizmos, and resolves. Without, the pass ends keeping its targets
    /// (the transmission copy reads them before the rest is drawn).
    pub draws: bool,
}

/// Goes on from the opaque pass that kept its targets: adds the deferred-lights pass's light
/// and draws the transmissive and blended batches, as `rest` says.
#[allow(clippy::too_many_arguments)]
pub fn encode_rest(
    cx: &mut FrameContext,
    inputs: &ForwardInputs,
    batches: &[Batch],
    opaque_count: usize,
    rest: Rest,
) -> (DrawCounts, Option<ShaderError>) {
    let (encoder, device, pipelines, mut timer) =
        (&mut *cx.encoder, cx.device, &mut *cx.pipelines, cx.timer.as_deref_mut());
    let targets = inputs.targets;
    let composite_group = match rest.deferred {
        Some((deferred, _)) => match deferred.composite_group() {
            Some(g) => Some(g),
            None => return (DrawCounts::default(), None),
        },
        None => None,
    };
    let start = opaque_count.min(batches.len());
    let blended = if rest.draws { &batches[start..] } else { &[] };
    let mut error = compile(device, pipelines, blended, start, inputs.indirect);
    if composite_group.is_some()
        && let Err(e) = pipelines.get::<CompositeFamily>(device, targets.samples)
    {
        error = Some(e);
    }
    if rest.draws
        && let Some(e) =
            compile_gizmos(device, pipelines, inputs, GizmoKey { samples: targets.samples, occluded: false })
    {
        error = Some(e);
    }
    let (attachment, resolve_error) =
        super::resolve::prepare(device, pipelines, targets.color_attachment(inputs.output));
    if resolve_error.is_some() {
        error = resolve_error;
    }
    // Without the draws, the pass resolves for the transmission copy.
    let (color, resolve) = (attachment.draw, attachment.pass_resolve);
    let store = if resolve.is_some() && rest.draws { wgpu::StoreOp::Discard } else { wgpu::StoreOp::Store };
    let depth_store = if rest.draws { wgpu::StoreOp::Discard } else { wgpu::StoreOp::Store };
    let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
        label: Some(if rest.draws { "transmissive and blended draws" } else { "deferred composite" }),
        color_attachments: &[Some(wgpu::RenderPassColorAttachment {
            view: color,
            depth_slice: None,
            resolve_target: resolve,
            ops: wgpu::Operations { load: wgpu::LoadOp::Load, store },
        })],
        depth_stencil_attachment: targets.depth_view.as_ref().map(|view| wgpu::RenderPassDepthStencilAttachment {
            view,
            depth_ops: Some(wgpu::Operations { load: wgpu::LoadOp::Load, store: depth_store }),
            stencil_ops: None,
        }),
        timestamp_writes: timer
            .as_deref_mut()
            .and_then(|t| t.pass(if rest.draws { "transparent" } else { "composite" })),
        occlusion_query_set: None,
        multiview_mask: None,
    });
    if let (Some((_, true)), Some(group)) = (rest.deferred, composite_group)
        && let Some(composite) = pipelines.cached::<CompositeFamily>(&targets.samples)
    {
        pass.set_pipeline(composite);
        pass.set_bind_group(0, group, &[]);
        pass.draw(0..3, 0..1);
    }
    let counts = draw(&mut pass, pipelines, inputs, blended, start, None);
    if rest.draws {
        draw_gizmos(&mut pass, pipelines, inputs, GizmoKey { samples: targets.samples, occluded: false });
    }
    drop(pass);
    super::resolve::encode(encoder, device, pipelines, &attachment, timer);
    (counts, error)
}

/// Where a hybrid frame's forward draws go (`features::visibility::overlay`).
pub struct Overlay<'a> {
    /// Cleared to transparent; premultiplied colour and coverage, which the visibility buffer's
    /// shading composites over the opaque colour.
    pub colour: &'a wgpu::TextureView,
    /// Cleared to the far plane: the overlay's own draws test each other.
    pub depth: &'a wgpu::TextureView,
    /// Group 2 of the draws' pipelines (group 1 of the gizmos'): the visibility buffer, against
    /// which each sample is tested. Transmissive draws bind `ForwardInputs::transmission` in
    /// its place: the same with the opaque colour's copy.
    pub occlusion: &'a wgpu::BindGroup,
    pub samples: u32,
}

/// A hybrid frame's forward draws: the opaque batches `opaque` (indices into `batches`: those
/// the visibility buffer does not rasterise, line and point meshes), then the blended batches
/// (`batches[opaque_count..]`, back to front) and the gizmo lines, into `overlay`. Their keys
/// have `visibility_occlusion` set.
pub fn encode_overlay(
    cx: &mut FrameContext,
    inputs: &ForwardInputs,
    batches: &[Batch],
    opaque_count: usize,
    opaque: &[usize],
    overlay: Overlay,
) -> (DrawCounts, Option<ShaderError>) {
    let (encoder, device, pipelines, timer) =
        (&mut *cx.encoder, cx.device, &mut *cx.pipelines, cx.timer.as_deref_mut());
    let start = opaque_count.min(batches.len());
    let blended = &batches[start..];
    let mut error = compile(device, pipelines, blended, start, inputs.indirect);
    for &i in opaque {
        error = compile(device, pipelines, &batches[i..=i], i, inputs.indirect).or(error);
    }
    let gizmo_key = GizmoKey { samples: overlay.samples, occluded: true };
    error = compile_gizmos(device, pipelines, inputs, gizmo_key).or(error);
    let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
        label: Some("visibility overlay"),
        color_attachments: &[Some(wgpu::RenderPassColorAttachment {
            view: overlay.colour,
            depth_slice: None,
            resolve_target: None,
            ops: wgpu::Operations { load: wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT), store: wgpu::StoreOp::Store },
        })],
        depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
            view: overlay.depth,
            depth_ops: Some(wgpu::Operations { load: wgpu::LoadOp::Clear(0.0), store: wgpu::StoreOp::Discard }),
            stencil_ops: None,
        }),
        timestamp_writes: timer.and_then(|t| t.pass("visibility overlay")),
        occlusion_query_set: None,
        multiview_mask: None,
    });
    pass.set_bind_group(TRANSMISSION_GROUP, overlay.occlusion, &[]);
    let mut counts = DrawCounts::default();
    let group2 = Some(overlay.occlusion);
    for &i in opaque {
        counts += draw(&mut pass, pipelines, inputs, &batches[i..=i], i, group2);
    }
    counts += draw(&mut pass, pipelines, inputs, blended, start, group2);
    if let Some(g) = inputs.gizmos
        && let Some(pipeline) = pipelines.cached::<GizmoFamily>(&gizmo_key)
    {
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, inputs.view_bind_group, &[]);
        // Group 1 of the gizmo pipeline's layout (it has no material).
        pass.set_bind_group(1, overlay.occlusion, &[]);
        pass.set_vertex_buffer(0, g.vertices.slice(..));
        pass.draw(0..g.count, 0..1);
    }
    (counts, error)
}

fn compile_gizmos(
    device: &wgpu::Device,
    pipelines: &mut PipelineCache,
    inputs: &ForwardInputs,
    key: GizmoKey,
) -> Option<ShaderError> {
    inputs.gizmos.and_then(|_| pipelines.get::<GizmoFamily>(device, key).err())
}

/// The frame's gizmo lines, after everything else the pass draws.
fn draw_gizmos(pass: &mut wgpu::RenderPass<'_>, pipelines: &PipelineCache, inputs: &ForwardInputs, key: GizmoKey) {
    let Some(g) = inputs.gizmos else { return };
    let Some(pipeline) = pipelines.cached::<GizmoFamily>(&key) else { return };
    pass.set_pipeline(pipeline);
    pass.set_bind_group(0, inputs.view_bind_group, &[]);
    pass.set_vertex_buffer(0, g.vertices.slice(..));
    pass.draw(0..g.count, 0..1);
}

/// Creates the pipelines of `batches` (the part of the frame's list from index `start`) before
/// a pass borrows the cache immutably; returns the first error.
fn compile(
    device: &wgpu::Device,
    pipelines: &mut PipelineCache,
    batches: &[Batch],
    start: usize,
    indirect: Option<IndirectDraws>,
) -> Option<ShaderError> {
    pipelines
        .prepare::<ForwardFamily>(device, batches.iter().enumerate().map(|(i, b)| draw_key(b, indirect, start + i)))
        .err()
}

/// Draws `batches`, the part of the frame's batch list that starts at index `start`.
/// `group2`: what the pipelines of materials that are not transmissive bind as group 2, if
/// anything (transmissive ones bind `inputs.transmission` there).
fn draw(
    pass: &mut wgpu::RenderPass<'_>,
    pipelines: &PipelineCache,
    inputs: &ForwardInputs,
    batches: &[Batch],
    start: usize,
    group2: Option<&wgpu::BindGroup>,
) -> DrawCounts {
    let mut counts = DrawCounts::default();
    if batches.is_empty() {
        return counts;
    }
    pass.set_bind_group(0, inputs.view_bind_group, &[]);
    pass.set_vertex_buffer(0, inputs.mesh_pool.vertex_buffer().slice(..));
    pass.set_index_buffer(inputs.mesh_pool.index_buffer().slice(..), wgpu::IndexFormat::Uint32);
    let compiled = pipelines.compiled::<ForwardFamily>();
    let mut bound_key = None;
    let mut bound_material = None;
    // Whether the culled index list is bound in place of the pool's indices.
    let mut triangle_indices_bound = false;
    let mut i = 0;
    while i < batches.len() {
        let b = &batches[i];
        let (Some(entry), Some(material)) = (inputs.mesh_pool.entry(b.mesh_id), inputs.materials.get(&b.material))
        else {
            i += 1;
            continue;
        };
        let key = draw_key(b, inputs.indirect, start + i);
        if bound_key != Some(key) {
            let Some(pipeline) = compiled.get(&key) else {
                i += 1;
                continue;
            };
            pass.set_pipeline(pipeline);
            bound_key = Some(key);
        }
        if bound_material != Some(b.material) {
            pass.set_bind_group(1, &material.bind_group, &[]);
            if let Some((extension, _)) = &material.extension {
                pass.set_bind_group(EXTENSION_GROUP, extension, &[]);
            }
            let transmissive = material.features.has(MaterialFeatures::TRANSMISSION);
            if let Some(group) = if transmissive { inputs.transmission } else { group2 } {
                pass.set_bind_group(TRANSMISSION_GROUP, group, &[]);
            }
            bound_material = Some(b.material);
        }
        let per_primitive = match b.key.topology {
            TopologyKey::Triangles => 3,
            // Each segment is a quad (resources/line_quads.rs).
            TopologyKey::Lines => 6,
            TopologyKey::Points => 1,
        };
        let culled = inputs.indirect.filter(|d| start + i < d.batches);
        let triangles = culled.and_then(|d| d.triangles.filter(|_| d.triangle_culled(start + i)));
        if triangles.is_some() != triangle_indices_bound {
            let indices = triangles.map_or(inputs.mesh_pool.index_buffer(), |t| &t.indices);
            pass.set_index_buffer(indices.slice(..), wgpu::IndexFormat::Uint32);
            triangle_indices_bound = triangles.is_some();
        }
        let mut run = 1;
        match (culled, &entry.indices) {
            (Some(d), Some(_)) if triangles.is_some() => {
                pass.draw_indexed_indirect(d.args, (start + i) as u64 * crate::features::culling::ARGS_WORDS * 4);
            }
            (Some(d), Some(_)) => {
                // Consecutive indexed batches with this pipeline and material differ only in
                // mesh: one multi-draw (the mesh pool shares one vertex and index buffer).
                while i + run < batches.len()
                    && start + i + run < d.batches
                    && !d.triangle_culled(start + i + run)
                    && batches[i + run].key == b.key
                    && batches[i + run].material == b.material
                    && inputs.mesh_pool.entry(batches[i + run].mesh_id).is_some_and(|e| e.indices.is_some())
                {
                    run += 1;
                }
                let offset = (start + i) as u64 * crate::features::culling::ARGS_WORDS * 4;
                if run == 1 {
                    pass.draw_indexed_indirect(d.args, offset);
                } else {
                    pass.multi_draw_indexed_indirect(d.args, offset, run as u32);
                }
            }
            (Some(d), None) => {
                pass.draw_indirect(d.args, (start + i) as u64 * crate::features::culling::ARGS_WORDS * 4);
            }
            (None, Some(r)) => pass.draw_indexed(r.clone(), entry.vertices.start as i32, b.first..b.first + b.count),
            (None, None) => pass.draw(entry.vertices.clone(), b.first..b.first + b.count),
        }
        counts.draw_calls += 1;
        // Submitted, before culling (the GPU decides how many of them draw).
        for b in &batches[i..i + run] {
            let elements = inputs.mesh_pool.entry(b.mesh_id).map_or(0, |e| e.element_count());
            counts.instances += b.count;
            counts.primitives += (elements / per_primitive) as u64 * b.count as u64;
        }
        i += run;
    }
    counts
}

/// The background over the resolved frame (`BackgroundMode::Composite`): one full-screen
/// triangle, single-sampled, adding the environment where the surfaces' coverage (alpha) falls
/// short of 1. The forward pass cleared colour and alpha to 0 for it.
pub fn encode_background(cx: &mut FrameContext, view_bind_group: &wgpu::BindGroup) -> Result<(), ShaderError> {
    let (encoder, device, pipelines, targets, timer) =
        (&mut *cx.encoder, cx.device, &mut *cx.pipelines, cx.targets, cx.timer.as_deref_mut());
    // A frame without HDR colour (direct output) has no background to composite.
    let Some(hdr_view) = targets.hdr_view() else { return Ok(()) };
    let pipeline = pipelines.get::<BackgroundFamily>(device, BackgroundMode::Composite)?;
    let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
        label: Some("background"),
        color_attachments: &[Some(wgpu::RenderPassColorAttachment {
            view: hdr_view,
            depth_slice: None,
            resolve_target: None,
            ops: wgpu::Operations { load: wgpu::LoadOp::Load, store: wgpu::StoreOp::Store },
        })],
        depth_stencil_attachment: None,
        timestamp_writes: timer.and_then(|t| t.pass("background")),
        occlusion_query_set: None,
        multiview_mask: None,
    });
    pass.set_pipeline(pipeline);
    pass.set_bind_group(0, view_bind_group, &[]);
    pass.draw(0..3, 0..1);
    Ok(())
}
