//! Penumbra's render world.
//!
//! ```text
//! main world --extract--> RenderScene --prepare--> GPU pools --frame plan--> passes --> output
//! ```
//! - [`extract`] is the only code that reads the ECS; it fills [`world::RenderScene`] with plain
//!   data, touching only what changed.
//! - [`renderer::Renderer`] owns the GPU side: `prepare/` (mesh pool, textures, materials,
//!   instances, lights), `pipelines/` (shader library, pipeline cache), [`frame`] (which passes
//!   run) and `passes/` (forward, tonemap).
//! - [`RenderPlugin`] wires extraction and (for headless targets) rendering into the `App`.

pub mod array_layers;
pub mod context;
pub mod entity_table;
pub mod environment;
pub mod explain;
pub mod extract;
pub mod frame;
pub mod headless;
pub mod host_memory;
pub mod passes;
pub mod pipelines;
pub mod prepare;
pub mod quality;
pub mod readback;
pub mod renderer;
pub mod targets;
pub mod timing;
pub mod world;

use bevy_ecs::prelude::*;
use bevy_ecs::schedule::ScheduleLabel;
use penumbra_engine::{App, Plugin};

pub use context::{AdapterRequest, ContextError, GpuContext, INSTALL_HINT, RetryBackoff};
pub use pipelines::pipeline_cache::Tonemapper;
pub use pipelines::shader_library::ShaderError;
pub use quality::QualityPreset;
pub use renderer::{FrameStats, MemoryStats, RenderSettings, Renderer, RendererError, ShaderSource};
pub use targets::MsaaResolve;
pub use world::RenderScene;

/// Runs after `PostUpdate`: reads the main world into `RenderScene`.
#[derive(ScheduleLabel, Clone, Debug, PartialEq, Eq, Hash)]
pub struct Extract;

/// Runs after `Extract`: renders when the app renders headless.
#[derive(ScheduleLabel, Clone, Debug, PartialEq, Eq, Hash)]
pub struct Render;

/// Where the frame goes.
#[derive(Resource, Debug, Clone, Copy, PartialEq, Eq)]
pub enum RenderOutput {
    /// The renderer's own offscreen target of this size, read back with `Renderer::read_frame`
    /// (or `read_headless`, which does not fail on a shader error).
    Headless { width: u32, height: u32 },
    /// Whoever drives the app (the viewer's window loop) calls `Renderer::render` itself.
    External,
}

/// Adds extraction and the headless render step. Insert a [`Renderer`] resource to draw.
pub struct RenderPlugin;

impl Plugin for RenderPlugin {
    fn build(&self, app: &mut App) {
        app.init_resource::<RenderScene>()
            // Extraction's list of changed draws: propagation and the drawable components'
            // hooks fill it from now on.
            .init_resource::<penumbra_engine::components::DrawChanges>()
            .add_stage(Extract)
            .add_stage(Render)
            .add_systems(Extract, extract::systems())
            .add_systems(Render, render_headless);
    }
}

fn render_headless(output: Option<Res<RenderOutput>>, scene: Res<RenderScene>, renderer: Option<ResMut<Renderer>>) {
    let (Some(output), Some(mut renderer)) = (output, renderer) else {
        return;
    };
    if let RenderOutput::Headless { width, height } = *output {
        renderer.render_headless(&scene, (width, height));
    }
}
