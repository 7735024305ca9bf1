//! A scene staged for viewing: its `App` (scene spawned, renderer inserted, time running in
//! real time), the viewer's own orbit camera, and which of the file's cameras, if any, is being
//! looked through. Every loaded file gets a fresh `Staged` with its own renderer (asset handles
//! and entities are per world, so nothing GPU-side carries over); the old one is dropped whole.

use penumbra_engine::variants::SceneVariants;
use std::path::PathBuf;

use anyhow::{Result, anyhow};
use bevy_ecs::entity::Entity;
use bevy_ecs::query::Without;
use glam::{Vec2, Vec3};
use penumbra_engine::bounds::Aabb;
use penumbra_engine::components::{Camera, GlobalTransform, Name, Projection, Transform};
use penumbra_engine::environment::Environment;
use penumbra_engine::framing::{framing_camera_from, world_bounds};
use penumbra_engine::import::{GltfCamera, SceneFile};
use penumbra_engine::picking::{Ray, raycast};
use penumbra_engine::{App, Time, TimeMode};
use penumbra_render::headless::{CameraChoice, ShotSettings, StagedView, default_file_camera, stage_scene};
use penumbra_render::{RenderOutput, Renderer};

use super::orbit::{OrbitCamera, OrbitState};

pub struct Staged {
    pub app: App,
    /// The file (`None`: the embedded default scene).
    pub path: Option<PathBuf>,
    pub name: String,
    /// The viewer's camera, driven by the orbit controls.
    pub camera: Entity,
    pub orbit: OrbitCamera,
    /// A file camera being looked through instead (its glTF index and entity).
    pub through: Option<(usize, Entity)>,
    /// The file's cameras (glTF index, node name), listed once at staging for the Camera menu.
    pub cameras: Vec<(usize, String)>,
    /// The orbit camera's lens: its vertical field of view in a landscape viewport. A portrait
    /// viewport (docked panels can make one) keeps this field of view across its width instead
    /// ([`fitted_yfov`]), so a framed model stays in view.
    pub lens_yfov: f32,
    /// The near plane the scene was framed with; zoomed in closer, the near plane comes in
    /// with the camera ([`NEAR_PER_DISTANCE`] of the orbit distance), so a surface the camera
    /// closes in on is never cut away.
    pub lens_znear: f32,
}

/// The near plane's distance as a fraction of the orbit distance, at most.
const NEAR_PER_DISTANCE: f32 = 0.05;

/// What the command line asks of the first scene the viewer stages (later ones get defaults).
#[derive(Debug, Clone, Default)]
pub struct FirstLook {
    pub camera: CameraChoice,
    pub exposure_ev100: Option<f32>,
    /// The material variant to show (KHR_materials_variants).
    pub variant: Option<String>,
}

impl Staged {
    pub fn new(
        file: &SceneFile,
        path: Option<PathBuf>,
        look: FirstLook,
        environment: Option<Environment>,
        size: (u32, u32),
        renderer: Renderer,
    ) -> Result<Staged> {
        let FirstLook { camera: choice, exposure_ev100, variant } = look;
        // The viewer's camera is always an orbit camera; a file camera chosen on the command
        // line, or by default the file's first (where it sees the scene), is looked through
        // from the start.
        let orbit_choice = match choice {
            CameraChoice::Orbit { .. } => choice,
            _ => CameraChoice::THREE_QUARTER,
        };
        let shot = ShotSettings {
            size: Some(size),
            camera: orbit_choice,
            exposure_ev100,
            environment,
            animation: None,
            variant,
        };
        let (mut app, _) = stage_scene(file, &shot)?;
        let file_camera = match choice {
            CameraChoice::Gltf(index) => Some(index),
            CameraChoice::Auto => default_file_camera(&mut app),
            CameraChoice::Orbit { .. } => None,
        };
        app.world.resource_mut::<Time>().set_mode(TimeMode::Real);
        let camera = {
            let mut q = app.world.query_filtered::<(Entity, &Camera), Without<GltfCamera>>();
            q.iter(&app.world).find(|(_, c)| c.is_active).map(|(e, _)| e).ok_or_else(|| anyhow!("no active camera"))?
        };
        app.world.entity_mut(camera).insert(Name::new("viewer camera"));
        app.update();
        let name =
            path.as_ref().map_or_else(|| crate::scene::DEFAULT_SCENE_NAME.to_owned(), |p| p.display().to_string());
        let state = {
            let g = app.world.get::<GlobalTransform>(camera).copied().unwrap_or_default();
            let bounds = world_bounds(&mut app.world);
            orbit_from(&g, &bounds)
        };
        app.insert_resource(renderer);
        app.insert_resource(RenderOutput::External);
        let mut staged = Staged {
            app,
            path,
            name,
            camera,
            orbit: OrbitCamera::new(state),
            through: None,
            cameras: Vec::new(),
            lens_yfov: 45f32.to_radians(),
            lens_znear: 0.1,
        };
        if let Some(c) = staged.app.world.get::<Camera>(camera) {
            staged.lens_znear = c.projection.znear();
        }
        staged.cameras = staged.list_cameras();
        if let Some(index) = file_camera {
            staged.look_through(Some(index))?;
        }
        Ok(staged)
    }

    /// The active camera's exposure, and how the staged one was chosen (metered, given, or
    /// EV100 0 for a scene without lights).
    pub fn exposure_summary(&mut self) -> Option<String> {
        let mut q = self.app.world.query::<&Camera>();
        let ev = q.iter(&self.app.world).find(|c| c.is_active)?.exposure.ev100;
        let chosen = self.app.world.get_resource::<StagedView>().map(|v| v.exposure);
        Some(match chosen {
            Some(c) if (c.ev100() - ev).abs() < 1e-4 => c.to_string(),
            Some(c) => format!("EV100 {ev:.2} (set here; staged at {c})"),
            None => format!("EV100 {ev:.2}"),
        })
    }

    /// The scene's material variants and the one shown (none listed: the file has none).
    pub fn variants(&mut self) -> SceneVariants {
        let mut q = self.app.world.query::<&SceneVariants>();
        q.iter(&self.app.world).next().cloned().unwrap_or_default()
    }

    /// Shows material variant `name` (`None`: each primitive's own material).
    pub fn select_variant(&mut self, name: Option<&str>) -> Result<()> {
        let mut q = self.app.world.query_filtered::<Entity, bevy_ecs::query::With<SceneVariants>>();
        let Some(root) = q.iter(&self.app.world).next() else { return Ok(()) };
        match name {
            Some(name) => penumbra_engine::variants::select_variant(&mut self.app.world, root, name)?,
            None => {
                if let Some(mut v) = self.app.world.get_mut::<SceneVariants>(root) {
                    v.active = None;
                }
            }
        }
        Ok(())
    }

    fn list_cameras(&mut self) -> Vec<(usize, String)> {
        let mut q = self.app.world.query::<(&GltfCamera, Option<&Name>)>();
        let mut v: Vec<(usize, String)> = q
            .iter(&self.app.world)
            .map(|(g, n)| (g.index, n.map_or_else(|| format!("camera {}", g.index), |n| n.as_str().to_owned())))
            .collect();
        v.sort();
        v
    }

    /// Looks through file camera `index`, or back through the orbit camera.
    pub fn look_through(&mut self, index: Option<usize>) -> Result<()> {
        let target = match index {
            None => None,
            Some(i) => {
                let mut q = self.app.world.query::<(Entity, &GltfCamera)>();
                let found = q.iter(&self.app.world).find(|(_, g)| g.index == i).map(|(e, _)| e);
                Some((i, found.ok_or_else(|| anyhow!("the file has no camera {i}"))?))
            }
        };
        let mut q = self.app.world.query::<(Entity, &mut Camera)>();
        for (e, mut c) in q.iter_mut(&mut self.app.world) {
            let active = match target {
                Some((_, t)) => e == t,
                None => e == self.camera,
            };
            if c.is_active != active {
                c.is_active = active;
            }
        }
        self.through = target;
        Ok(())
    }

    /// Orbiting from a file camera starts where it looks from: the orbit camera takes over its
    /// pose and lens.
    pub fn take_over_file_camera(&mut self) {
        let Some((_, file_camera)) = self.through else { return };
        let (Some(g), Some(cam)) = (
            self.app.world.get::<GlobalTransform>(file_camera).copied(),
            self.app.world.get::<Camera>(file_camera).copied(),
        ) else {
            return;
        };
        let bounds = world_bounds(&mut self.app.world);
        let state = orbit_from(&g, &bounds);
        self.orbit = OrbitCamera::new(state);
        if let Projection::Perspective { yfov, znear, .. } = cam.projection {
            self.lens_yfov = yfov;
            self.lens_znear = znear;
        }
        if let Some(mut ours) = self.app.world.get_mut::<Camera>(self.camera) {
            *ours = Camera { is_active: true, ..cam };
        }
        let _ = self.look_through(None);
    }

    /// A goal that shows the whole scene (as it is now) from the current direction.
    pub fn framing_goal(&mut self, aspect: f32) -> OrbitState {
        let bounds = world_bounds(&mut self.app.world);
        let current = self.orbit.goal.transform();
        let (_, t) = framing_camera_from(&bounds, current.rotation * Vec3::Z, self.yfov(), aspect);
        let target = if bounds.is_empty() { self.orbit.goal.target } else { bounds.center() };
        OrbitState::looking_at(t.translation, target)
    }

    pub fn yfov(&self) -> f32 {
        match self.app.world.get::<Camera>(self.camera).map(|c| c.projection) {
            Some(Projection::Perspective { yfov, .. }) => yfov,
            _ => 45f32.to_radians(),
        }
    }

    /// The world ray through a window pixel, from the orbit camera's goal pose.
    pub fn ray_through(&self, pixel: Vec2, size: (u32, u32)) -> Ray {
        let (w, h) = (size.0.max(1) as f32, size.1.max(1) as f32);
        let t = self.orbit.current.transform();
        let tan = (0.5 * self.yfov()).tan();
        let ndc = Vec2::new(2.0 * pixel.x / w - 1.0, 1.0 - 2.0 * pixel.y / h);
        Ray { origin: t.translation, direction: t.rotation * Vec3::new(ndc.x * tan * w / h, ndc.y * tan, -1.0) }
    }

    /// What is under a window pixel: the entity and the world point.
    pub fn pick(&mut self, pixel: Vec2, size: (u32, u32)) -> Option<(Entity, Vec3)> {
        let ray = self.ray_through(pixel, size);
        raycast(&mut self.app.world, ray).map(|hit| (hit.entity, hit.point))
    }

    /// Writes the eased orbit pose into the viewer camera (unless a file camera is in use), and
    /// its field of view fitted to the viewport's `aspect`.
    pub fn advance_camera(&mut self, dt: f32, aspect: f32) {
        let transform: Transform = self.orbit.update(dt);
        let fitted = fitted_yfov(self.lens_yfov, aspect);
        let near = self.lens_znear.min(self.orbit.current.distance * NEAR_PER_DISTANCE);
        // Written only when it changes: a write marks the camera changed.
        let current = self.app.world.get::<Camera>(self.camera).map(|c| c.projection);
        if self.through.is_none()
            && let Some(Projection::Perspective { yfov, znear, aspect_ratio }) = current
            && (yfov != fitted || znear != near)
            && let Some(mut c) = self.app.world.get_mut::<Camera>(self.camera)
        {
            c.projection = Projection::Perspective { yfov: fitted, znear: near, aspect_ratio };
        }
        if self.through.is_none()
            && let Some(mut t) = self.app.world.get_mut::<Transform>(self.camera)
            && *t != transform
        {
            *t = transform;
        }
    }
}

/// The vertical field of view that shows `lens_yfov` across the narrower side of a viewport of
/// `aspect` (width / height): the lens's own in landscape, wider in portrait.
pub fn fitted_yfov(lens_yfov: f32, aspect: f32) -> f32 {
    if aspect >= 1.0 || aspect.is_nan() || aspect <= 0.0 {
        return lens_yfov;
    }
    2.0 * ((0.5 * lens_yfov).tan() / aspect).atan()
}

/// The orbit state of a camera pose: it looks at the point of its view ray nearest the scene's
/// centre.
fn orbit_from(g: &GlobalTransform, bounds: &Aabb) -> OrbitState {
    let eye = g.translation();
    let target = if bounds.is_empty() {
        eye + g.forward()
    } else {
        let t = (bounds.center() - eye).dot(g.forward()).max(1e-3);
        eye + g.forward() * t
    };
    OrbitState::looking_at(eye, target)
}
