//! The inspector: the selected entity's transform, visibility, material factors and light
//! parameters, edited live. Each part is edited as a copy and written back only when changed;
//! a material is an asset shared by every entity that uses it, and the panel says so.

use bevy_ecs::component::{Component, Mutable};
use bevy_ecs::entity::Entity;
use bevy_ecs::world::World;
use glam::{EulerRot, Quat, Vec3};
use penumbra_engine::assets::Assets;
use penumbra_engine::components::{
    AmbientLight, Camera, DirectionalLight, DiskLight, MeshMaterial3d, Name, PointLight, RectLight, SphereLight,
    SpotLight, Transform, TubeLight, Visibility,
};
use penumbra_engine::material::StandardMaterial;

pub fn panel(ui: &mut egui::Ui, world: &mut World, selected: Option<Entity>) {
    egui::CollapsingHeader::new("Inspector").default_open(true).show(ui, |ui| {
        let Some(e) = selected.filter(|&e| world.get_entity(e).is_ok()) else {
            ui.label("Click an object, or a row of the scene tree.");
            return;
        };
        let name = world.get::<Name>(e).map_or_else(|| "(unnamed)".to_owned(), |n| n.as_str().to_owned());
        ui.heading(name);
        ui.label(format!("entity {}", e.index()));
        edit::<Transform>(ui, world, e, "Transform", transform);
        edit::<Visibility>(ui, world, e, "Visibility", |ui, v| {
            ui.horizontal(|ui| {
                ui.selectable_value(v, Visibility::Inherited, "inherited");
                ui.selectable_value(v, Visibility::Visible, "visible");
                ui.selectable_value(v, Visibility::Hidden, "hidden");
            });
        });
        material(ui, world, e);
        edit::<DirectionalLight>(ui, world, e, "Directional light", |ui, l| {
            color(ui, &mut l.color);
            ui.add(egui::DragValue::new(&mut l.illuminance).range(0.0..=f32::MAX).speed(10.0).suffix(" lux"));
            ui.checkbox(&mut l.shadows, "shadows");
        });
        edit::<PointLight>(ui, world, e, "Point light", |ui, l| {
            color(ui, &mut l.color);
            intensity(ui, &mut l.intensity, " cd");
            range(ui, &mut l.range);
            ui.checkbox(&mut l.shadows, "shadows");
        });
        edit::<SpotLight>(ui, world, e, "Spot light", |ui, l| {
            color(ui, &mut l.color);
            intensity(ui, &mut l.intensity, " cd");
            range(ui, &mut l.range);
            ui.horizontal(|ui| {
                ui.label("cone inner / outer");
                ui.drag_angle(&mut l.inner_cone_angle);
                ui.drag_angle(&mut l.outer_cone_angle);
            });
            let outer = l.outer_cone_angle.clamp(1e-3, std::f32::consts::FRAC_PI_2);
            l.outer_cone_angle = outer;
            l.inner_cone_angle = l.inner_cone_angle.clamp(0.0, outer);
            ui.checkbox(&mut l.shadows, "shadows");
        });
        edit::<SphereLight>(ui, world, e, "Sphere light", |ui, l| {
            color(ui, &mut l.color);
            intensity(ui, &mut l.intensity, " cd");
            ui.add(egui::DragValue::new(&mut l.radius).range(0.0..=f32::MAX).speed(0.01).prefix("radius "));
            range(ui, &mut l.range);
        });
        edit::<TubeLight>(ui, world, e, "Tube light", |ui, l| {
            color(ui, &mut l.color);
            intensity(ui, &mut l.intensity, " cd");
            ui.add(egui::DragValue::new(&mut l.length).range(0.0..=f32::MAX).speed(0.01).prefix("length "));
            ui.add(egui::DragValue::new(&mut l.radius).range(0.0..=f32::MAX).speed(0.01).prefix("radius "));
            range(ui, &mut l.range);
        });
        edit::<RectLight>(ui, world, e, "Rectangle light", |ui, l| {
            color(ui, &mut l.color);
            intensity(ui, &mut l.luminance, " nit");
            ui.add(egui::DragValue::new(&mut l.width).range(0.0..=f32::MAX).speed(0.01).prefix("width "));
            ui.add(egui::DragValue::new(&mut l.height).range(0.0..=f32::MAX).speed(0.01).prefix("height "));
            range(ui, &mut l.range);
        });
        edit::<DiskLight>(ui, world, e, "Disk light", |ui, l| {
            color(ui, &mut l.color);
            intensity(ui, &mut l.luminance, " nit");
            ui.add(egui::DragValue::new(&mut l.radius).range(0.0..=f32::MAX).speed(0.01).prefix("radius "));
            range(ui, &mut l.range);
        });
        edit::<AmbientLight>(ui, world, e, "Ambient light", |ui, l| {
            color(ui, &mut l.color);
            intensity(ui, &mut l.intensity, "");
        });
        edit::<Camera>(ui, world, e, "Camera", |ui, c| {
            ui.add(egui::Slider::new(&mut c.exposure.ev100, -6.0..=18.0).text("exposure (EV100)"));
            ui.checkbox(&mut c.is_active, "active");
        });
    });
}

/// Shows `T` of `e` (if it has one) under `title`; writes it back only when the edit changed it.
fn edit<T: Component<Mutability = Mutable> + Clone + PartialEq>(
    ui: &mut egui::Ui,
    world: &mut World,
    e: Entity,
    title: &str,
    body: impl FnOnce(&mut egui::Ui, &mut T),
) {
    let Some(before) = world.get::<T>(e).cloned() else { return };
    let mut value = before.clone();
    egui::CollapsingHeader::new(title).default_open(true).show(ui, |ui| body(ui, &mut value));
    if value != before
        && let Some(mut c) = world.get_mut::<T>(e)
    {
        *c = value;
    }
}

fn transform(ui: &mut egui::Ui, t: &mut Transform) {
    let row = |ui: &mut egui::Ui, label: &str, v: &mut Vec3, speed: f64| {
        ui.horizontal(|ui| {
            ui.label(label);
            for c in [&mut v.x, &mut v.y, &mut v.z] {
                ui.add(egui::DragValue::new(c).speed(speed));
            }
        });
    };
    let scale = (t.translation.length().max(t.scale.max_element()) as f64 * 0.01).max(1e-4);
    row(ui, "translation", &mut t.translation, scale);
    let (y, x, z) = t.rotation.to_euler(EulerRot::YXZ);
    let mut degrees = Vec3::new(x, y, z) * (180.0 / std::f32::consts::PI);
    let before = degrees;
    row(ui, "rotation °", &mut degrees, 0.5);
    if degrees != before {
        let r = degrees * (std::f32::consts::PI / 180.0);
        t.rotation = Quat::from_euler(EulerRot::YXZ, r.y, r.x, r.z);
    }
    row(ui, "scale", &mut t.scale, 0.01);
}

fn color(ui: &mut egui::Ui, c: &mut Vec3) {
    labelled_color(ui, "colour", c);
}

fn labelled_color(ui: &mut egui::Ui, label: &str, c: &mut Vec3) {
    ui.horizontal(|ui| {
        ui.label(label);
        let mut rgb = c.to_array();
        if ui.color_edit_button_rgb(&mut rgb).changed() {
            *c = Vec3::from_array(rgb);
        }
    });
}

fn intensity(ui: &mut egui::Ui, v: &mut f32, unit: &str) {
    let speed = (*v as f64 * 0.01).max(0.01);
    ui.add(egui::DragValue::new(v).range(0.0..=f32::MAX).speed(speed).prefix("intensity ").suffix(unit.to_owned()));
}

fn range(ui: &mut egui::Ui, r: &mut Option<f32>) {
    ui.horizontal(|ui| {
        let mut set = r.is_some();
        ui.checkbox(&mut set, "range");
        match (set, r.as_mut()) {
            (true, Some(v)) => {
                ui.add(egui::DragValue::new(v).range(1e-3..=f32::MAX).speed(0.05).suffix(" m"));
            }
            (true, None) => *r = Some(10.0),
            (false, _) => *r = None,
        }
    });
}

/// The entity's material asset, if any.
fn material(ui: &mut egui::Ui, world: &mut World, e: Entity) {
    let Some(handle) = world.get::<MeshMaterial3d>(e).map(|m| m.0) else { return };
    let users = {
        let mut q = world.query::<&MeshMaterial3d>();
        q.iter(world).filter(|m| m.0 == handle).count()
    };
    let Some(before) = world.get_resource::<Assets<StandardMaterial>>().and_then(|a| a.get(handle).ok()).cloned()
    else {
        return;
    };
    let mut m = before.clone();
    egui::CollapsingHeader::new("Material").default_open(true).show(ui, |ui| {
        if users > 1 {
            ui.label(format!("shared by {users} objects: edits change them all"));
        }
        ui.horizontal(|ui| {
            ui.label("base colour");
            let mut rgba = m.base_color.to_array();
            if ui.color_edit_button_rgba_unmultiplied(&mut rgba).changed() {
                m.base_color = glam::Vec4::from_array(rgba);
            }
        });
        ui.add(egui::Slider::new(&mut m.metallic, 0.0..=1.0).text("metallic"));
        ui.add(egui::Slider::new(&mut m.roughness, 0.0..=1.0).text("roughness"));
        labelled_color(ui, "emissive", &mut m.emissive);
        ui.add(
            egui::DragValue::new(&mut m.emissive_strength)
                .range(0.0..=f32::MAX)
                .speed(0.05)
                .prefix("emissive strength "),
        );
        if m.normal_texture.is_some() {
            ui.add(egui::Slider::new(&mut m.normal_scale, 0.0..=2.0).text("normal scale"));
        }
        if m.occlusion_texture.is_some() {
            ui.add(egui::Slider::new(&mut m.occlusion_strength, 0.0..=1.0).text("occlusion"));
        }
        ui.checkbox(&mut m.double_sided, "double sided");
        ui.label(format!("alpha: {:?}{}", m.alpha_mode, if m.unlit { ", unlit" } else { "" }));
        extensions(ui, &mut m);
    });
    if m != before
        && let Some(mut assets) = world.get_resource_mut::<Assets<StandardMaterial>>()
        && let Ok(slot) = assets.get_mut(handle)
    {
        *slot = m;
    }
}

/// The glTF material extensions' factors: each one above its neutral value switches its
/// shader feature on for the material (compiled on first use).
fn extensions(ui: &mut egui::Ui, m: &mut StandardMaterial) {
    egui::CollapsingHeader::new("Extensions").default_open(false).show(ui, |ui| {
        let drag = |ui: &mut egui::Ui, v: &mut f32, range: std::ops::RangeInclusive<f32>, label: &str| {
            ui.add(egui::DragValue::new(v).range(range).speed(0.01).prefix(format!("{label} ")));
        };
        ui.label("specular and IOR");
        drag(ui, &mut m.ior, 1.0..=3.0, "IOR");
        ui.add(egui::Slider::new(&mut m.specular, 0.0..=1.0).text("specular"));
        labelled_color(ui, "specular colour", &mut m.specular_color);
        ui.label("clear coat");
        ui.add(egui::Slider::new(&mut m.clearcoat, 0.0..=1.0).text("coat"));
        ui.add(egui::Slider::new(&mut m.clearcoat_roughness, 0.0..=1.0).text("coat roughness"));
        ui.label("sheen");
        labelled_color(ui, "sheen colour", &mut m.sheen_color);
        ui.add(egui::Slider::new(&mut m.sheen_roughness, 0.0..=1.0).text("sheen roughness"));
        ui.label("transmission and volume");
        ui.add(egui::Slider::new(&mut m.transmission, 0.0..=1.0).text("transmission"));
        drag(ui, &mut m.thickness, 0.0..=f32::MAX, "thickness");
        labelled_color(ui, "attenuation colour", &mut m.attenuation_color);
        drag(ui, &mut m.attenuation_distance, 1e-3..=f32::INFINITY, "attenuation distance");
        drag(ui, &mut m.dispersion, 0.0..=10.0, "dispersion");
        ui.label("anisotropy");
        ui.add(egui::Slider::new(&mut m.anisotropy_strength, 0.0..=1.0).text("strength"));
        ui.add(
            egui::Slider::new(&mut m.anisotropy_rotation, -std::f32::consts::PI..=std::f32::consts::PI)
                .text("rotation"),
        );
        ui.label("iridescence");
        ui.add(egui::Slider::new(&mut m.iridescence, 0.0..=1.0).text("film"));
        drag(ui, &mut m.iridescence_ior, 1.0..=3.0, "film IOR");
        drag(ui, &mut m.iridescence_thickness_max, 0.0..=2000.0, "film thickness (nm)");
    });
}
