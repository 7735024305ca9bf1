//! `Transform` (local, authored) and `GlobalTransform` (world, derived), and the propagation
//! system that derives the second from the first down the `ChildOf` hierarchy.
//!
//! Propagation runs in `PostUpdate`. Entities with neither parent nor children are visited only
//! when their `Transform` changed (in parallel), and not even their change ticks are read in a
//! frame in which no table of them was written (`change_summary`). Hierarchies are walked from every root; a
//! subtree is recomputed when its root's `Transform` or parent link changed, or when any
//! ancestor was recomputed, and
//! `GlobalTransform` is only written when it is recomputed, so change detection downstream
//! (extraction) sees exactly the entities that moved.

use bevy_ecs::prelude::*;
use glam::{Affine3A, Mat3, Mat4, Quat, Vec3};

use super::change_summary::any_changed;
use super::draw_changes::{DrawChanges, record_insert};

/// Local placement relative to the parent (or the world for a root). Each table of them keeps a
/// summary tick, so propagation skips a still frame without looking at each entity.
#[derive(Component, Debug, Clone, Copy, PartialEq)]
#[component(summary_tick)]
#[require(GlobalTransform)]
pub struct Transform {
    pub translation: Vec3,
    pub rotation: Quat,
    pub scale: Vec3,
}

impl Default for Transform {
    fn default() -> Self {
        Self::IDENTITY
    }
}

impl Transform {
    pub const IDENTITY: Self = Self { translation: Vec3::ZERO, rotation: Quat::IDENTITY, scale: Vec3::ONE };

    pub fn from_xyz(x: f32, y: f32, z: f32) -> Self {
        Self::from_translation(Vec3::new(x, y, z))
    }
    pub fn from_translation(translation: Vec3) -> Self {
        Self { translation, ..Self::IDENTITY }
    }
    pub fn from_rotation(rotation: Quat) -> Self {
        Self { rotation, ..Self::IDENTITY }
    }
    pub fn from_scale(scale: Vec3) -> Self {
        Self { scale, ..Self::IDENTITY }
    }
    pub fn with_rotation(mut self, rotation: Quat) -> Self {
        self.rotation = rotation;
        self
    }
    pub fn with_scale(mut self, scale: Vec3) -> Self {
        self.scale = scale;
        self
    }

    /// Decomposes a matrix (glTF `node.matrix`). Shear is lost, as the glTF spec allows.
    /// A singular matrix (a zero scale, which glTF allows to hide a node) keeps its translation
    /// and column lengths with no rotation, rather than the NaN rotation decomposition yields.
    pub fn from_matrix(m: Mat4) -> Self {
        let (scale, rotation, translation) = m.to_scale_rotation_translation();
        if rotation.is_finite() && scale.is_finite() {
            return Self { translation, rotation, scale };
        }
        let scale = Vec3::new(m.x_axis.truncate().length(), m.y_axis.truncate().length(), m.z_axis.truncate().length());
        Self { translation: m.w_axis.truncate(), rotation: Quat::IDENTITY, scale }
    }

    /// Turns the transform so local −Z points at `target` (cameras and lights look down −Z).
    pub fn looking_at(mut self, target: Vec3, up: Vec3) -> Self {
        self.look_at(target, up);
        self
    }

    pub fn look_at(&mut self, target: Vec3, up: Vec3) {
        let back = (self.translation - target).normalize_or(Vec3::Z);
        let right = up.cross(back).try_normalize().unwrap_or_else(|| back.any_orthonormal_vector());
        let up = back.cross(right);
        self.rotation = Quat::from_mat3(&Mat3::from_cols(right, up, back));
    }

    /// Turns by `rotation` in the parent's space (applied after the current rotation).
    pub fn rotate(&mut self, rotation: Quat) {
        self.rotation = (rotation * self.rotation).normalize();
    }

    /// Turns `angle` radians about the parent's X axis.
    pub fn rotate_x(&mut self, angle: f32) {
        self.rotate(Quat::from_rotation_x(angle));
    }

    /// Turns `angle` radians about the parent's Y axis.
    pub fn rotate_y(&mut self, angle: f32) {
        self.rotate(Quat::from_rotation_y(angle));
    }

    /// Turns `angle` radians about the parent's Z axis.
    pub fn rotate_z(&mut self, angle: f32) {
        self.rotate(Quat::from_rotation_z(angle));
    }

    pub fn to_affine(&self) -> Affine3A {
        Affine3A::from_scale_rotation_translation(self.scale, self.rotation, self.translation)
    }

    /// Local −Z in the parent's space.
    pub fn forward(&self) -> Vec3 {
        self.rotation * Vec3::NEG_Z
    }
}

/// World placement, derived by propagation. Do not write it; write `Transform`: the renderer
/// learns of new placements from propagation (see [`super::draw_changes`]), so a direct write
/// is not drawn, and propagation would overwrite it anyway. Inserting one is seen.
#[derive(Component, Debug, Clone, Copy, PartialEq, Default)]
#[component(on_insert = record_insert)]
pub struct GlobalTransform(pub Affine3A);

impl GlobalTransform {
    pub fn translation(&self) -> Vec3 {
        self.0.translation.into()
    }
    pub fn matrix(&self) -> Mat4 {
        Mat4::from(self.0)
    }
    /// Local −Z in world space, normalised.
    pub fn forward(&self) -> Vec3 {
        self.0.matrix3.mul_vec3(Vec3::NEG_Z).normalize_or(Vec3::NEG_Z)
    }
    /// Local +X in world space, normalised.
    pub fn right(&self) -> Vec3 {
        self.0.matrix3.mul_vec3(Vec3::X).normalize_or(Vec3::X)
    }
    /// The rotation with scale (and shear) taken out: the frame a camera looks along. Defined for
    /// every transform: an axis scaled to zero (glTF allows zero scale) is rebuilt from the other
    /// two, and with fewer than two usable axes the view keeps what it can (−Z, else identity).
    /// A mirroring transform gives the rotation of its unmirrored twin, as
    /// `to_scale_rotation_translation` does.
    pub fn rotation(&self) -> Quat {
        // glam's decomposition where it is defined, so that ordinary cameras keep exactly the
        // view they always had.
        let (_, rotation, _) = self.0.to_scale_rotation_translation();
        if rotation.is_finite() && (rotation.length() - 1.0).abs() < 1e-3 {
            return rotation;
        }
        let m = self.0.matrix3;
        let axis = |v: glam::Vec3A| Vec3::from(v).try_normalize();
        let (x, y, z) = (axis(m.x_axis), axis(m.y_axis), axis(m.z_axis));
        let Some(z) = z.or_else(|| x?.cross(y?).try_normalize()) else {
            return Quat::IDENTITY;
        };
        let y = y
            .and_then(|y| (y - z * y.dot(z)).try_normalize())
            .or_else(|| x.and_then(|x| z.cross(x).try_normalize()))
            .unwrap_or_else(|| z.any_orthonormal_vector());
        Quat::from_mat3(&glam::Mat3::from_cols(y.cross(z), y, z)).normalize()
    }
    /// Whether the transform mirrors space (negative determinant), which flips triangle winding.
    pub fn is_mirrored(&self) -> bool {
        self.0.matrix3.determinant() < 0.0
    }
}

/// Parentless, childless entities whose `Transform` changed: most of a large scene.
type ChangedLeaves<'w, 's> = Query<
    'w,
    's,
    (Entity, &'static Transform, &'static mut GlobalTransform),
    (Changed<Transform>, Without<ChildOf>, Without<Children>),
>;

/// Every standalone entity's `Transform`, for its tables' summary ticks.
type StandaloneProbe<'w, 's> = Query<'w, 's, Ref<'static, Transform>, (Without<ChildOf>, Without<Children>)>;

/// Derives `GlobalTransform` for every entity with a `Transform`, and records each entity whose
/// `GlobalTransform` it writes in the [`DrawChanges`] feed (when the renderer keeps one).
pub fn propagate_transforms(
    mut globals: ParamSet<(ChangedLeaves, Query<&mut GlobalTransform>, StandaloneProbe)>,
    // A root without Transform (a bare grouping entity) places its children as the identity.
    roots: Query<(Entity, Option<Ref<Transform>>, &Children), Without<ChildOf>>,
    parentless: Query<&Transform, Without<ChildOf>>,
    nodes: Query<(Ref<Transform>, Ref<ChildOf>, Option<&Children>)>,
    mut unparented: RemovedComponents<ChildOf>,
    mut feed: Option<ResMut<DrawChanges>>,
) {
    // Standalone entities need no walk: only the changed ones are visited, on all cores; and
    // when no table of them saw a write since the last frame (a still scene), none is.
    if any_changed(&globals.p2()) {
        let pass = feed.as_mut().map(|f| f.begin_pass());
        globals.p0().par_iter_mut().for_each_init(
            || pass.map(|p| p.task_recorder()),
            |recorder, (entity, transform, mut global)| {
                global.0 = transform.to_affine();
                if let Some(r) = recorder {
                    r.record(entity);
                }
            },
        );
    }
    let mut record = |entity: Entity| {
        if let Some(f) = feed.as_mut() {
            f.record(entity);
        }
    };
    // An entity that lost its parent is a root whose world transform changed although its
    // `Transform` did not.
    let unparented: std::collections::HashSet<Entity> = unparented.read().collect();
    let mut globals = globals.p1();
    for &entity in &unparented {
        if let (Ok(transform), Ok(mut g)) = (parentless.get(entity), globals.get_mut(entity)) {
            g.0 = transform.to_affine();
            record(entity);
        }
    }
    for (entity, transform, children) in &roots {
        let dirty = transform.as_ref().is_some_and(|t| t.is_changed()) || unparented.contains(&entity);
        let world = transform.map_or(Affine3A::IDENTITY, |t| t.to_affine());
        if dirty && let Ok(mut g) = globals.get_mut(entity) {
            g.0 = world;
            record(entity);
        }
        for &child in children {
            propagate_recursive(child, world, dirty, &nodes, &mut globals, &mut record, 0);
        }
    }
}

/// Deeper than any authored scene; a cycle slipping past the importer's check stops here
/// instead of overflowing the stack.
const MAX_HIERARCHY_DEPTH: u32 = 4096;

fn propagate_recursive(
    entity: Entity,
    parent_world: Affine3A,
    parent_dirty: bool,
    nodes: &Query<(Ref<Transform>, Ref<ChildOf>, Option<&Children>)>,
    globals: &mut Query<&mut GlobalTransform>,
    record: &mut impl FnMut(Entity),
    depth: u32,
) {
    if depth > MAX_HIERARCHY_DEPTH {
        tracing::error!("hierarchy deeper than {MAX_HIERARCHY_DEPTH} at {entity}; not propagating further");
        return;
    }
    let Ok((transform, child_of, children)) = nodes.get(entity) else {
        return; // a child without Transform takes no part in placement
    };
    let dirty = parent_dirty || transform.is_changed() || child_of.is_changed();
    let world = parent_world * transform.to_affine();
    if dirty && let Ok(mut g) = globals.get_mut(entity) {
        g.0 = world;
        record(entity);
    }
    if let Some(children) = children {
        for &child in children {
            propagate_recursive(child, world, dirty, nodes, globals, record, depth + 1);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::App;
    use crate::CorePlugin;

    #[test]
    fn unparenting_recomputes_the_world_transform() {
        let mut app = App::new();
        app.add_plugins(CorePlugin);
        let parent = app.world.spawn(Transform::from_xyz(10.0, 0.0, 0.0)).id();
        let child = app.world.spawn((Transform::from_xyz(1.0, 0.0, 0.0), ChildOf(parent))).id();
        app.update();
        assert_eq!(app.world.get::<GlobalTransform>(child).unwrap().translation(), Vec3::new(11.0, 0.0, 0.0));
        app.world.entity_mut(child).remove::<ChildOf>();
        app.update();
        assert_eq!(app.world.get::<GlobalTransform>(child).unwrap().translation(), Vec3::new(1.0, 0.0, 0.0));
    }

    #[test]
    fn children_of_a_root_without_transform_are_placed() {
        let mut app = App::new();
        app.add_plugins(CorePlugin);
        let group = app.world.spawn_empty().id();
        let child = app.world.spawn((Transform::from_xyz(0.0, 2.0, 0.0), ChildOf(group))).id();
        let grandchild = app.world.spawn((Transform::from_xyz(1.0, 0.0, 0.0), ChildOf(child))).id();
        app.update();
        assert_eq!(app.world.get::<GlobalTransform>(grandchild).unwrap().translation(), Vec3::new(1.0, 2.0, 0.0));
        app.world.get_mut::<Transform>(child).unwrap().translation.y = 3.0;
        app.update();
        assert_eq!(app.world.get::<GlobalTransform>(grandchild).unwrap().translation(), Vec3::new(1.0, 3.0, 0.0));
    }

    #[test]
    fn rotation_ignores_scale_even_zero_scale() {
        let r = Quat::from_euler(glam::EulerRot::YXZ, 0.7, -0.3, 0.2);
        for scale in [Vec3::ONE, Vec3::new(2.0, 0.5, 3.0), Vec3::new(0.0, 1.0, 1.0), Vec3::new(1.0, 1.0, 0.0)] {
            let g = GlobalTransform(Affine3A::from_scale_rotation_translation(scale, r, Vec3::new(1e6, 2.0, 3.0)));
            assert!(g.rotation().angle_between(r) < 1e-4, "scale {scale}: {:?} vs {r:?}", g.rotation());
        }
        // Only the view direction survives: it is kept.
        let g = GlobalTransform(Affine3A::from_scale_rotation_translation(Vec3::new(0.0, 0.0, 1.0), r, Vec3::ZERO));
        assert!((g.rotation() * Vec3::NEG_Z).distance(r * Vec3::NEG_Z) < 1e-5);
        let g = GlobalTransform(Affine3A::from_scale_rotation_translation(Vec3::ZERO, r, Vec3::ZERO));
        assert!(g.rotation().is_finite());
    }

    #[test]
    fn a_zero_scale_matrix_decomposes_without_nan() {
        let m = Mat4::from_scale_rotation_translation(Vec3::ZERO, Quat::from_rotation_y(1.0), Vec3::new(1.0, 2.0, 3.0));
        let t = Transform::from_matrix(m);
        assert!(t.rotation.is_finite() && t.scale == Vec3::ZERO && t.translation == Vec3::new(1.0, 2.0, 3.0));
    }
}
