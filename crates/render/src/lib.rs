//! Penumbra's render world.
//!
//! ```text
//! main world --extract--> RenderScene --prepare--> resources, features --plan--> passes --> output
//! ```
//! Layers, each depending only on those above it in this list's reverse (docs/architecture.md):
//! - [`gpu`]: context, formats, buffers, readback, timing; knows no feature.
//! - [`pipelines`]: the shader library and the generic pipeline cache.
//! - [`scene`]: extraction, the only code that reads the ECS, and the [`RenderScene`] it fills.
//! - [`resources`]: shared owners (mesh pool, textures, materials, instances, light store, the
//!   draw list).
//! - [`bindings`], [`view`], [`targets`]: the shared view group and the frame's targets.
//! - [`features`]: one folder per rendering feature (its settings, resources, pipeline
//!   families, bindings and passes).
//! - [`frame`]: which passes run this frame and why; [`renderer::Renderer`] drives prepare →
//!   plan → encode; [`RenderPlugin`] wires extraction and headless rendering into the `App`.

pub mod bindings;
pub mod explain;
pub mod features;
pub mod frame;
pub mod frame_context;
pub mod gpu;
pub mod headless;
pub mod metering;
pub mod pass;
pub mod pipelines;
pub mod quality;
pub mod renderer;
pub mod resources;
pub mod scene;
pub mod settings;
pub mod stats;
pub mod targets;
pub mod view;

use bevy_ecs::prelude::*;
use bevy_ecs::schedule::ScheduleLabel;
use penumbra_engine::{App, Plugin};

pub use features::bloom::BloomSettings;
pub use features::clusters::LightWalk;
pub use features::clusters::grid::ClusterConfig;
pub use features::culling::{OcclusionCulling, TriangleCulling};
pub use features::environment::EnvironmentSettings;
pub use features::exposure::AutoExposure;
pub use features::shadows::{ShadowFilter, ShadowSettings};
pub use features::visibility::Raster;
pub use gpu::context::{AdapterRequest, ContextError, GpuContext, INSTALL_HINT, RetryBackoff};
pub use pipelines::{PipelineCacheDir, PipelineStore, ReloadReport, ShaderError};
pub use quality::QualityPreset;
pub use renderer::{FrameError, Renderer, RendererError};
pub use resources::draws::{AlphaTest, DebugView, LocalLights, Tonemapper};
pub use scene::world::RenderScene;
pub use settings::{PostSettings, RenderSettings, SettingsError, ShaderSource};
pub use stats::{FrameStats, MemoryStats};
pub use targets::MsaaResolve;

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
            .add_systems(Extract, scene::extract::systems())
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
