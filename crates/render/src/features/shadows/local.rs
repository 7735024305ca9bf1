//! Shadow maps of local lights: which lights get maps, where they live in the local atlas, and
//! which of them are re-rendered this frame. Owned by the orchestrator, which renders the layers
//! this module names.
//!
//! Spot lights up to 60° outer cone get one perspective map; point lights and wider spots get
//! six (cube faces, each 90° plus two texels so filtering never reads past a face's edge). Each
//! map is a run of layers of the local atlas. Allocation is stable: a light keeps its layers
//! while it stays among the lights that fit, so its map stays valid across frames. When more
//! lights cast than the atlas holds, the ones that matter least on screen (by the solid angle of
//! their sphere of influence seen from the camera) go unshadowed.
//!
//! A map is stale when its light changed or a caster changed within its light's reach (the
//! draw list's `CasterChanges`; changes it cannot bound count everywhere). Stale maps are
//! re-rendered within `local_updates` layers per frame: half the budget in order of screen
//! contribution, the rest round-robin (the longest waiting first). Until its first render a map
//! reads as unshadowed (its layers are marked invalid).

use std::collections::HashMap;

use glam::{Mat4, Vec3};
use penumbra_engine::bounds::Aabb;

use super::ShadowSettings;
use crate::resources::draw_list::CasterChanges;
use crate::scene::world::{ExtractedLight, LightKey, LightKind};

/// A shadow-casting spot or point light the store holds.
#[derive(Debug, Clone, Copy)]
pub struct LocalCandidate {
    pub key: LightKey,
    pub light: ExtractedLight,
    /// The packed bounding radius (influence range plus extent); 0 lights nothing.
    pub reach: f32,
}

/// One light's map.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Map {
    key: LightKey,
    first_layer: u32,
    faces: u32,
    /// The state the map was last brought up to date for: (caster generation, light, reach).
    current: Option<(u64, ExtractedLight, f32)>,
    /// The light and reach the layers were drawn with, which sampling must use until they are
    /// drawn again (a map waiting for the budget is late, never mismatched); None while they
    /// hold nothing (never drawn, or no caster within reach): read as lit.
    drawn: Option<(ExtractedLight, f32)>,
    last_update: u64,
}

/// One layer as the shaders read it (`LocalShadow` in `shaders/shadows.wgsl`) and the caster
/// pass renders it.
#[derive(Debug, Clone, Copy)]
pub struct LayerView {
    /// Light clip space (reverse-Z, infinite far) from camera-relative positions.
    pub clip_from_rel: Mat4,
    /// World size of a texel per metre of distance from the light.
    pub texel_scale: f32,
    /// The map's faces (1 or 6); the shader picks the face of a cube by direction.
    pub faces: u32,
    /// Rendered at least once for the light as it is now.
    pub valid: bool,
}

/// What the local shadows are this frame.
#[derive(Debug, Clone, Default)]
pub struct LocalFrame {
    /// First layer of each shadowed light (what the light store packs).
    pub first_layers: HashMap<LightKey, u32>,
    /// Every allocated layer's view (index = layer); unallocated layers are `None`.
    pub layers: Vec<Option<LayerView>>,
    /// Layers to render this frame.
    pub render: Vec<u32>,
    /// Shadowed lights left without a map (the atlas is full).
    pub unshadowed: usize,
}

#[derive(Default)]
pub struct LocalShadows {
    maps: Vec<Map>,
    frame: u64,
    /// The caster generation of the last plan.
    seen_generation: u64,
}

/// Outer cone above which a spot light is shadowed like a point light.
const WIDEST_SPOT: f32 = std::f32::consts::FRAC_PI_3;

/// Layers the shadowed lights among `candidates` would take, all of them placed.
pub(super) fn layers_wanted(candidates: &[LocalCandidate]) -> u32 {
    candidates.iter().filter(|c| c.light.shadows && c.reach > 0.0).filter_map(|c| faces_for(&c.light)).sum()
}

fn faces_for(light: &ExtractedLight) -> Option<u32> {
    match light.kind {
        LightKind::Spot { outer_cone_angle, .. } if outer_cone_angle <= WIDEST_SPOT => Some(1),
        // Lights with a size are shadowed from their centre, as point lights.
        LightKind::Spot { .. }
        | LightKind::Point
        | LightKind::Sphere { .. }
        | LightKind::Tube { .. }
        | LightKind::Rect { .. }
        | LightKind::Disk { .. } => Some(6),
        _ => None,
    }
}

/// World from light-view rotation for a light looking along `forward` (unit).
fn look(forward: Vec3) -> Mat4 {
    let up = if forward.y.abs() < 0.99 { Vec3::Y } else { Vec3::Z };
    let right = forward.cross(up).normalize();
    let up = right.cross(forward);
    // Rows: right, up, −forward (the light looks down its −Z).
    Mat4::from_cols(
        glam::Vec4::new(right.x, up.x, -forward.x, 0.0),
        glam::Vec4::new(right.y, up.y, -forward.y, 0.0),
        glam::Vec4::new(right.z, up.z, -forward.z, 0.0),
        glam::Vec4::W,
    )
}

/// Reverse-Z perspective with an infinite far plane: depth `near / distance along the axis`.
fn perspective(tan_half: f32, near: f32) -> Mat4 {
    Mat4::from_cols(
        glam::Vec4::new(1.0 / tan_half, 0.0, 0.0, 0.0),
        glam::Vec4::new(0.0, 1.0 / tan_half, 0.0, 0.0),
        glam::Vec4::new(0.0, 0.0, 0.0, -1.0),
        glam::Vec4::new(0.0, 0.0, near, 0.0),
    )
}

/// The six cube faces' view directions, in the order the shader picks them: +X, −X, +Y, −Y,
/// +Z, −Z.
const CUBE_FACES: [Vec3; 6] = [Vec3::X, Vec3::NEG_X, Vec3::Y, Vec3::NEG_Y, Vec3::Z, Vec3::NEG_Z];

/// The views of a light's map, relative to the camera at `camera`.
fn views(light: &ExtractedLight, reach: f32, faces: u32, size: u32, camera: Vec3) -> Vec<(Mat4, f32)> {
    // Casters closer than the near plane cast nothing, so it sits a millionth of the reach out
    // (1.4 mm for the 1.4 km reach of a bright light with no glTF range). Depth keeps its
    // precision there: reverse-Z float depth `near / distance` is as precise relative to its
    // value at any distance, and stays far above f32's smallest normal number within the reach.
    let near = (reach * 1e-6).max(f32::MIN_POSITIVE * 1e6);
    // The light's position relative to the camera, in f32 once: the same subtraction the
    // shaders make for vertices, so casters and receivers agree.
    let rel = light.position - camera;
    let margin = 1.0 + 4.0 / size as f32;
    if faces == 1 {
        let outer = match light.kind {
            LightKind::Spot { outer_cone_angle, .. } => outer_cone_angle.clamp(1e-3, WIDEST_SPOT),
            _ => WIDEST_SPOT,
        };
        let tan_half = outer.tan() * margin;
        let m = perspective(tan_half, near)
            * look(light.direction.normalize_or(Vec3::NEG_Z))
            * Mat4::from_translation(-rel);
        return vec![(m, 2.0 * tan_half / size as f32)];
    }
    CUBE_FACES
        .iter()
        .map(|f| (perspective(margin, near) * look(*f) * Mat4::from_translation(-rel), 2.0 * margin / size as f32))
        .collect()
}

/// The solid-angle share of the light's sphere of influence seen from `eye` (1 inside it).
fn screen_share(light: &ExtractedLight, reach: f32, eye: Vec3) -> f32 {
    let d = light.position.distance(eye);
    if d <= reach { 1.0 } else { (reach / d).powi(2) }
}

fn sphere_meets_box(centre: Vec3, radius: f32, b: &Aabb) -> bool {
    !b.is_empty() && centre.clamp(b.min, b.max).distance_squared(centre) <= radius * radius
}

impl LocalShadows {
    /// Allocates, ages and schedules the maps for this frame.
    pub fn plan(
        &mut self,
        settings: &ShadowSettings,
        camera: Vec3,
        candidates: &[LocalCandidate],
        casters: &Aabb,
        caster_generation: u64,
        changes: CasterChanges,
    ) -> LocalFrame {
        self.frame += 1;
        if caster_generation != self.seen_generation {
            // A map up to date at the last generation stays so while nothing that changed, where
            // it was or where it is, lies within its light's reach.
            for m in &mut self.maps {
                if let (Some((generation, light, reach)), CasterChanges::Within(b)) = (m.current, changes)
                    && generation == self.seen_generation
                    && !sphere_meets_box(light.position, reach, &b)
                {
                    m.current = Some((caster_generation, light, reach));
                }
            }
            self.seen_generation = caster_generation;
        }
        let mut lit: Vec<(f32, &LocalCandidate, u32)> = candidates
            .iter()
            .filter(|c| c.light.shadows && c.reach > 0.0)
            .filter_map(|c| faces_for(&c.light).map(|f| (screen_share(&c.light, c.reach, camera), c, f)))
            .collect();
        lit.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.key.cmp(&b.1.key)));
        // Keep the maps of lights that still cast, with the same face count.
        let wanted: HashMap<LightKey, u32> = lit.iter().map(|(_, c, f)| (c.key, *f)).collect();
        self.maps.retain(|m| wanted.get(&m.key) == Some(&m.faces));
        let total = settings.local_layers as usize;
        self.maps.retain(|m| (m.first_layer + m.faces) as usize <= total);
        // Allocate in priority order; a light that does not fit evicts nothing already placed
        // unless it outranks it, so the most visible lights hold maps.
        let mut used = vec![false; total];
        let mut keep: Vec<Map> = Vec::new();
        let mut unshadowed = 0;
        let mut placed: HashMap<LightKey, Map> = self.maps.iter().map(|m| (m.key, *m)).collect();
        for (_, c, faces) in &lit {
            let existing = placed.remove(&c.key);
            let start = match existing {
                Some(m) if (0..m.faces).all(|i| !used[(m.first_layer + i) as usize]) => Some(m.first_layer),
                _ => first_fit(&used, *faces),
            };
            let Some(first) = start else {
                unshadowed += 1;
                continue;
            };
            for i in 0..*faces {
                used[(first + i) as usize] = true;
            }
            let map = match existing {
                Some(m) if m.first_layer == first => m,
                _ => Map { key: c.key, first_layer: first, faces: *faces, current: None, drawn: None, last_update: 0 },
            };
            keep.push(map);
        }
        self.maps = keep;
        let by_key: HashMap<LightKey, (f32, &LocalCandidate)> = lit.iter().map(|(s, c, _)| (c.key, (*s, *c))).collect();
        // Stale maps, then the budget: half by screen share, the rest round-robin.
        let stale: Vec<usize> = (0..self.maps.len())
            .filter(|&i| {
                let m = &self.maps[i];
                let c = by_key[&m.key].1;
                m.current != Some((caster_generation, c.light, c.reach))
            })
            .collect();
        let budget = settings.local_updates;
        let mut chosen: Vec<usize> = Vec::new();
        let mut spent = 0;
        let mut take = |i: usize, chosen: &mut Vec<usize>, limit: u32| {
            let f = self.maps[i].faces;
            if !chosen.contains(&i) && (spent + f <= limit || chosen.is_empty()) {
                spent += f;
                chosen.push(i);
            }
        };
        // `stale` is in priority order already (maps were kept in `lit` order).
        for &i in &stale {
            take(i, &mut chosen, budget.div_ceil(2));
        }
        let mut waiting = stale.clone();
        waiting.sort_by_key(|&i| (self.maps[i].last_update, i));
        for &i in &waiting {
            take(i, &mut chosen, budget);
        }
        let mut frame = LocalFrame { unshadowed, layers: vec![None; total], ..Default::default() };
        let size = settings.local_map_size;
        for (i, m) in self.maps.iter_mut().enumerate() {
            let c = by_key[&m.key].1;
            // Chosen maps are brought up to date: drawn when a caster is within reach, else
            // left empty (nothing to shadow), which reads as lit.
            let render = chosen.contains(&i) && sphere_meets_box(c.light.position, c.reach, casters);
            if chosen.contains(&i) {
                m.current = Some((caster_generation, c.light, c.reach));
                m.drawn = render.then_some((c.light, c.reach));
                m.last_update = self.frame;
            }
            frame.first_layers.insert(m.key, m.first_layer);
            let (light, reach) = m.drawn.unwrap_or((c.light, c.reach));
            for (face, (clip_from_rel, texel_scale)) in
                views(&light, reach, m.faces, size, camera).into_iter().enumerate()
            {
                let layer = m.first_layer + face as u32;
                frame.layers[layer as usize] =
                    Some(LayerView { clip_from_rel, texel_scale, faces: m.faces, valid: m.drawn.is_some() });
                if render {
                    frame.render.push(layer);
                }
            }
        }
        frame
    }
}

/// The first run of `count` free layers.
fn first_fit(used: &[bool], count: u32) -> Option<u32> {
    let count = count as usize;
    if count > used.len() {
        return None;
    }
    (0..=used.len().saturating_sub(count)).find(|&s| used[s..s + count].iter().all(|u| !u)).map(|s| s as u32)
}

#[cfg(test)]
mod tests {
    use super::*;
    use bevy_ecs::entity::Entity;

    fn spot(i: u32, at: Vec3) -> LocalCandidate {
        LocalCandidate {
            key: LightKey::Spot(Entity::from_raw_u32(i).unwrap()),
            light: ExtractedLight {
                kind: LightKind::Spot { inner_cone_angle: 0.3, outer_cone_angle: 0.5 },
                color: Vec3::ONE,
                position: at,
                direction: Vec3::NEG_Y,
                right: Vec3::X,
                range: Some(5.0),
                shadows: true,
            },
            reach: 5.0,
        }
    }

    fn point(i: u32, at: Vec3) -> LocalCandidate {
        let mut c = spot(i, at);
        c.key = LightKey::Point(Entity::from_raw_u32(i).unwrap());
        c.light.kind = LightKind::Point;
        c
    }

    fn everything() -> Aabb {
        Aabb { min: Vec3::splat(-100.0), max: Vec3::splat(100.0) }
    }

    #[test]
    fn the_most_visible_lights_get_maps_and_keep_their_layers() {
        let settings = ShadowSettings { local_layers: 8, local_updates: 64, ..Default::default() };
        let mut shadows = LocalShadows::default();
        // Two point lights (6 layers each) and two spots: only one cube and both spots fit.
        let near = point(1, Vec3::new(0.0, 2.0, 1.0));
        let far = point(2, Vec3::new(0.0, 2.0, 60.0));
        let lights = [far, near, spot(3, Vec3::new(3.0, 2.0, 0.0)), spot(4, Vec3::new(-3.0, 2.0, 0.0))];
        let frame = shadows.plan(&settings, Vec3::ZERO, &lights, &everything(), 0, CasterChanges::Anywhere);
        assert_eq!(frame.unshadowed, 1);
        assert!(frame.first_layers.contains_key(&near.key) && !frame.first_layers.contains_key(&far.key));
        assert_eq!(frame.render.len(), 8, "every allocated layer renders on the first frame");
        // Nothing changed: nothing renders, the layers stay where they were and valid.
        let again = shadows.plan(&settings, Vec3::ZERO, &lights, &everything(), 0, CasterChanges::Anywhere);
        assert!(again.render.is_empty());
        assert_eq!(again.first_layers, frame.first_layers);
        assert!(again.layers.iter().flatten().all(|l| l.valid));
        // A caster moved: everything is stale again.
        assert_eq!(
            shadows.plan(&settings, Vec3::ZERO, &lights, &everything(), 1, CasterChanges::Anywhere).render.len(),
            8
        );
    }

    #[test]
    fn a_cube_does_not_fit_in_fewer_than_six_layers_and_a_late_map_keeps_its_old_light() {
        let settings = ShadowSettings { local_layers: 5, ..Default::default() };
        let mut shadows = LocalShadows::default();
        let frame =
            shadows.plan(&settings, Vec3::ZERO, &[point(1, Vec3::Y)], &everything(), 0, CasterChanges::Anywhere);
        assert_eq!((frame.unshadowed, frame.first_layers.len()), (1, 0));
        // Budget for one spot map per frame: a moved light waits, read with the light it was
        // drawn with.
        let settings = ShadowSettings { local_layers: 4, local_updates: 1, ..Default::default() };
        let mut shadows = LocalShadows::default();
        let mut lights = [spot(1, Vec3::new(0.0, 2.0, 0.0)), spot(2, Vec3::new(1.0, 2.0, 0.0))];
        shadows.plan(&settings, Vec3::ZERO, &lights, &everything(), 0, CasterChanges::Anywhere);
        shadows.plan(&settings, Vec3::ZERO, &lights, &everything(), 0, CasterChanges::Anywhere);
        let before = shadows.plan(&settings, Vec3::ZERO, &lights, &everything(), 0, CasterChanges::Anywhere);
        lights[0].light.position.x += 0.5;
        lights[1].light.position.x += 0.5;
        let after = shadows.plan(&settings, Vec3::ZERO, &lights, &everything(), 0, CasterChanges::Anywhere);
        assert_eq!(after.render.len(), 1);
        let waiting = (0..2u32).find(|l| !after.render.contains(l)).unwrap() as usize;
        let (b, a) = (before.layers[waiting].unwrap(), after.layers[waiting].unwrap());
        assert!(a.valid && a.clip_from_rel == b.clip_from_rel, "the waiting map is read as it was drawn");
    }

    #[test]
    fn the_update_budget_is_shared_by_priority_and_round_robin() {
        let settings = ShadowSettings { local_layers: 16, local_updates: 4, ..Default::default() };
        let mut shadows = LocalShadows::default();
        let lights: Vec<LocalCandidate> = (0..16).map(|i| spot(i, Vec3::new(i as f32 * 3.0, 2.0, 0.0))).collect();
        let mut rendered_at: HashMap<u32, Vec<u64>> = HashMap::new();
        for frame in 0..8 {
            let f = shadows.plan(&settings, Vec3::ZERO, &lights, &everything(), frame / 4, CasterChanges::Anywhere);
            assert_eq!(f.render.len(), 4, "frame {frame}: the budget, no more");
            for l in f.render {
                rendered_at.entry(l).or_default().push(frame);
            }
        }
        // Casters changed at frame 4: by then (frames 0-3) all 16 maps had rendered once.
        assert_eq!(rendered_at.len(), 16, "{rendered_at:?}");
        // The nearest light (layer of spot 0) is refreshed first after the change.
        let nearest = shadows.plan(&settings, Vec3::ZERO, &lights, &everything(), 9, CasterChanges::Anywhere);
        assert!(nearest.render.contains(&0), "{:?}", nearest.render);
    }

    #[test]
    fn a_cube_face_sees_what_lies_along_its_axis() {
        let light = point(1, Vec3::new(1.0, 2.0, 3.0)).light;
        let camera = Vec3::new(-4.0, 0.5, 2.0);
        let faces = views(&light, 5.0, 6, 512, camera);
        for (face, axis) in CUBE_FACES.iter().enumerate() {
            let p = light.position + *axis * 2.0 + axis.any_orthonormal_vector() * 0.5;
            let clip = faces[face].0 * (p - camera).extend(1.0);
            let ndc = clip.truncate() / clip.w;
            assert!(clip.w > 0.0 && ndc.x.abs() < 1.0 && ndc.y.abs() < 1.0, "face {face}: {ndc}");
            // Reverse-Z, infinite far: depth is near / distance along the axis.
            assert!((ndc.z / (5e-6 / 2.0) - 1.0).abs() < 1e-4, "face {face}: depth {}", ndc.z);
        }
    }
}
