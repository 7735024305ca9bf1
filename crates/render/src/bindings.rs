//! Shared bind groups, declared once. A group that several features read (the view group every
//! lit shader binds as group 0) is assembled from what each owner contributes: the owner
//! declares its bindings by their WGSL names ([`GroupBuilder::add`]) and later hands over its
//! resources under the same names ([`GroupResources::add`]). The builder numbers the bindings
//! in declaration order, so the layout and every bind group made for it agree by construction,
//! and a test holds each shader's `@group(0) @binding(N) var name` to the number the builder
//! gave `name` (`view::tests`).

/// A group's bindings in declaration order, numbered from 0.
#[derive(Default)]
pub struct GroupBuilder {
    entries: Vec<(&'static str, wgpu::BindGroupLayoutEntry)>,
}

impl GroupBuilder {
    /// Declares the next binding: the WGSL variable `name`, the stages that read it, its type.
    pub fn add(&mut self, name: &'static str, visibility: wgpu::ShaderStages, ty: wgpu::BindingType) -> &mut Self {
        assert!(self.binding(name).is_none(), "binding {name} declared twice");
        let binding = self.entries.len() as u32;
        self.entries.push((name, wgpu::BindGroupLayoutEntry { binding, visibility, ty, count: None }));
        self
    }

    /// A buffer binding (no dynamic offset).
    pub fn buffer(
        &mut self,
        name: &'static str,
        visibility: wgpu::ShaderStages,
        ty: wgpu::BufferBindingType,
    ) -> &mut Self {
        self.add(name, visibility, wgpu::BindingType::Buffer { ty, has_dynamic_offset: false, min_binding_size: None })
    }

    /// The number `name` was given.
    pub fn binding(&self, name: &str) -> Option<u32> {
        self.entries.iter().position(|(n, _)| *n == name).map(|i| i as u32)
    }

    /// The names in binding order.
    pub fn names(&self) -> impl Iterator<Item = &'static str> + '_ {
        self.entries.iter().map(|(n, _)| *n)
    }

    pub fn build(self, device: &wgpu::Device, label: &'static str) -> SharedGroup {
        let entries: Vec<wgpu::BindGroupLayoutEntry> = self.entries.iter().map(|(_, e)| *e).collect();
        let layout =
            device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor { label: Some(label), entries: &entries });
        let fragment_textures = entries
            .iter()
            .filter(|e| {
                e.visibility.contains(wgpu::ShaderStages::FRAGMENT) && matches!(e.ty, wgpu::BindingType::Texture { .. })
            })
            .count() as u32;
        SharedGroup { label, names: self.entries.into_iter().map(|(n, _)| n).collect(), layout, fragment_textures }
    }
}

/// A built group: its layout, and the names its bind groups must bind, in order.
pub struct SharedGroup {
    label: &'static str,
    names: Vec<&'static str>,
    layout: wgpu::BindGroupLayout,
    fragment_textures: u32,
}

/// The resources of one bind group, collected from the owners in declaration order.
#[derive(Default)]
pub struct GroupResources<'a> {
    resources: Vec<(&'static str, wgpu::BindingResource<'a>)>,
}

impl<'a> GroupResources<'a> {
    pub fn add(&mut self, name: &'static str, resource: wgpu::BindingResource<'a>) -> &mut Self {
        self.resources.push((name, resource));
        self
    }

    /// A whole buffer.
    pub fn buffer(&mut self, name: &'static str, buffer: &'a wgpu::Buffer) -> &mut Self {
        self.add(name, buffer.as_entire_binding())
    }
}

impl SharedGroup {
    pub fn layout(&self) -> &wgpu::BindGroupLayout {
        &self.layout
    }

    /// How many textures the fragment stage samples from this group (against the device's
    /// per-stage limit).
    pub fn fragment_textures(&self) -> u32 {
        self.fragment_textures
    }

    /// A bind group of `resources`, which must name the declared bindings in their order (an
    /// owner that declares a binding and hands over another is a bug, caught here).
    pub fn bind_group(&self, device: &wgpu::Device, resources: GroupResources) -> wgpu::BindGroup {
        let given: Vec<&str> = resources.resources.iter().map(|(n, _)| *n).collect();
        assert_eq!(given, self.names, "the {} group's resources against its declared bindings", self.label);
        let entries: Vec<wgpu::BindGroupEntry> = resources
            .resources
            .into_iter()
            .enumerate()
            .map(|(i, (_, resource))| wgpu::BindGroupEntry { binding: i as u32, resource })
            .collect();
        device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some(self.label),
            layout: &self.layout,
            entries: &entries,
        })
    }
}
