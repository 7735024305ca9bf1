//! The stats panel (F1): frame rate, CPU and GPU milliseconds (per pass, from timestamp
//! queries: the viewer turns GPU timing on while the panel is open), draw calls, triangles,
//! lights and the memory of the main GPU pools.

use penumbra_render::Renderer;

use crate::view::ui_state::FrameInfo;

fn mib(bytes: u64) -> String {
    format!("{:.1} MiB", bytes as f64 / (1 << 20) as f64)
}

pub fn panel(ui: &mut egui::Ui, renderer: &Renderer, info: &FrameInfo<'_>) {
    let s = renderer.stats();
    egui::CollapsingHeader::new("Stats").default_open(true).show(ui, |ui| {
        egui::Grid::new("stats").num_columns(2).striped(true).show(ui, |ui| {
            let mut row = |name: &str, value: String| {
                ui.label(name);
                ui.monospace(value);
                ui.end_row();
            };
            row("FPS", format!("{:.0} ({:.2} ms)", info.fps, info.frame_ms));
            row("CPU", format!("{:.2} ms (prepare {:.2})", s.cpu_ms, s.prepare_ms));
            row(
                "GPU",
                s.gpu_total_ms().map_or_else(|| "(no timestamp queries)".to_owned(), |ms| format!("{ms:.2} ms")),
            );
            row("draw calls", s.draw_calls.to_string());
            row("instances", s.instances.to_string());
            row("triangles", s.primitives.to_string());
            row("lights", format!("{} ({} local)", s.lights, s.local_lights));
            row("pipelines", s.pipelines.to_string());

            if renderer.context().info.device_type == wgpu::DeviceType::Cpu {
                // The CPU rasteriser's compile mode decides both reload latency and frame time.
                row(
                    "shader compiles",
                    match penumbra_render::gpu::context::CpuShaderCompiles::in_effect() {
                        penumbra_render::gpu::context::CpuShaderCompiles::Fast => "fast (GALLIVM_PERF=nopt)".to_owned(),
                        penumbra_render::gpu::context::CpuShaderCompiles::Optimized => "optimized".to_owned(),
                    },
                );
            }
        });
        if let Some(exposure) = &info.exposure {
            // Long (how it was metered): wrapped under the grid, not a column that widens it.
            ui.add(egui::Label::new(format!("exposure: {exposure}")).wrap());
        }
        if let Some(gpu) = &s.gpu {
            ui.collapsing("GPU passes", |ui| {
                egui::Grid::new("passes").num_columns(2).striped(true).show(ui, |ui| {
                    for (pass, ms) in &gpu.passes {
                        ui.label(*pass);
                        ui.monospace(format!("{ms:.3} ms"));
                        ui.end_row();
                    }
                });
            });
        }
        let m = renderer.memory();
        ui.collapsing("GPU memory", |ui| {
            egui::Grid::new("memory").num_columns(2).striped(true).show(ui, |ui| {
                for (pool, bytes) in [
                    ("meshes", m.mesh_pool),
                    ("textures", m.textures),
                    ("instances", m.instances),
                    ("frame targets", m.targets),
                    ("lights", m.lights),
                    ("clusters", m.clusters),
                    ("shadow atlas", m.shadows),
                    ("environment", m.environment),
                    ("post", m.post),
                    ("deformation", m.deform),
                ] {
                    ui.label(pool);
                    ui.monospace(mib(bytes));
                    ui.end_row();
                }
                if m.textures_rgba8 > m.textures {
                    ui.label("saved by texture compression");
                    ui.monospace(mib(m.textures_rgba8 - m.textures));
                    ui.end_row();
                }
            });
        });
    });
}
