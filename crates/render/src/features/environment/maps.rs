//! The environment's maps of one cube size (the source cube, the specular cube and, on GL, the
//! arrays the steps write), with the bind groups of the compute steps that make them, and the
//! upload of an image source.

use super::*;

/// The maps of one cube size, and the bind groups of the steps that make them.
pub(super) struct Maps {
    pub(super) size: u32,
    pub(super) source: wgpu::Texture,
    pub(super) specular: wgpu::Texture,
    /// Where the steps write, when not into the cubes themselves: on GL, where a texture is a
    /// cube map or an array for good (`ArrayLayers`), the steps write 2D arrays that are then
    /// copied face by face into the cubes. `None` elsewhere.
    pub(super) work: Option<WorkArrays>,
    pub(super) specular_view: wgpu::TextureView,
    pub(super) source_params: wgpu::Buffer,
    pub(super) filter_params: wgpu::Buffer,
    pub(super) downsample_groups: Vec<wgpu::BindGroup>,
    pub(super) specular_groups: Vec<wgpu::BindGroup>,
    pub(super) sh_group: wgpu::BindGroup,
    pub(super) sh_face: u32,
    /// Bind group of the source step (it holds the image, so it is made per source).
    pub(super) source_group: Option<wgpu::BindGroup>,
}

/// The arrays the steps write on a backend whose cubes cannot also be bound as arrays.
pub(super) struct WorkArrays {
    /// One single-level array per source level: the downsample step reads one level while it
    /// writes the next, and GL drops image stores to a level outside the range a texture is
    /// being sampled at (wgpu's GL backend sets that range on the texture itself).
    pub(super) source: Vec<wgpu::Texture>,
    pub(super) specular: wgpu::Texture,
}

impl Maps {
    pub(super) fn new(
        device: &wgpu::Device,
        pipelines: &PipelineCache,
        sh: &wgpu::Buffer,
        size: u32,
        array_layers: ArrayLayers,
    ) -> Self {
        let levels = size.ilog2() + 1;
        let specular_levels = SPECULAR_LEVELS.min(levels);
        let texture_of = |label, side: u32, layers, mips, usage| {
            device.create_texture(&wgpu::TextureDescriptor {
                label: Some(label),
                size: wgpu::Extent3d { width: side, height: side, depth_or_array_layers: layers },
                mip_level_count: mips,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format: ENVIRONMENT_FORMAT,
                usage,
                view_formats: &[],
            })
        };
        let texture = |label, layers, mips, usage| texture_of(label, size, layers, mips, usage);
        use wgpu::TextureUsages as U;
        let written = U::TEXTURE_BINDING | U::STORAGE_BINDING;
        let work_layers = array_layers.allocate(6, size, size);
        let (source, specular, work) = if work_layers == 6 {
            let source = texture("environment source", 6, levels, written | U::COPY_SRC);
            let specular = texture("environment specular", 6, specular_levels, written | U::COPY_DST);
            (source, specular, None)
        } else {
            let work = WorkArrays {
                source: (0..levels)
                    .map(|level| {
                        let side = (size >> level).max(1);
                        texture_of("environment source level (written)", side, work_layers, 1, written | U::COPY_SRC)
                    })
                    .collect(),
                specular: texture(
                    "environment specular (written)",
                    work_layers,
                    specular_levels,
                    written | U::COPY_SRC,
                ),
            };
            let source = texture("environment source", 6, levels, U::TEXTURE_BINDING | U::COPY_DST);
            let specular = texture("environment specular", 6, specular_levels, U::TEXTURE_BINDING | U::COPY_DST);
            (source, specular, Some(work))
        };
        let specular_writes = work.as_ref().map_or(&specular, |w| &w.specular);
        let level_view = |t: &wgpu::Texture, level: u32| {
            t.create_view(&wgpu::TextureViewDescriptor {
                dimension: Some(wgpu::TextureViewDimension::D2Array),
                base_mip_level: level,
                mip_level_count: Some(1),
                base_array_layer: 0,
                array_layer_count: Some(6),
                ..Default::default()
            })
        };
        // The source step and the downsample write these; the harmonics read one.
        let source_level = |level: u32| match &work {
            Some(w) => level_view(&w.source[level as usize], 0),
            None => level_view(&source, level),
        };
        let buffer = |label, size| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size,
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            })
        };
        let source_params = buffer("environment source", std::mem::size_of::<GpuSourceParams>() as u64);
        let filter_params = buffer("environment filter", PARAMS_STRIDE * (SPECULAR_LEVELS as u64 + 1));
        let params_at = |level: u32| wgpu::BindGroupEntry {
            binding: 0,
            resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                buffer: &filter_params,
                offset: level as u64 * PARAMS_STRIDE,
                size: std::num::NonZeroU64::new(std::mem::size_of::<GpuFilterParams>() as u64),
            }),
        };
        let downsample_groups = (1..levels)
            .map(|level| {
                device.create_bind_group(&wgpu::BindGroupDescriptor {
                    label: Some("environment downsample"),
                    layout: pipelines.family::<EnvStepFamily>().layout(EnvStep::Downsample),
                    entries: &[tex(0, &source_level(level - 1)), tex(1, &source_level(level))],
                })
            })
            .collect();
        let source_cube = source.create_view(&wgpu::TextureViewDescriptor {
            dimension: Some(wgpu::TextureViewDimension::Cube),
            ..Default::default()
        });
        let filter_sampler = device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("environment prefilter"),
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            mipmap_filter: wgpu::MipmapFilterMode::Linear,
            ..Default::default()
        });
        let specular_groups = (1..specular.mip_level_count())
            .map(|level| {
                device.create_bind_group(&wgpu::BindGroupDescriptor {
                    label: Some("environment specular"),
                    layout: pipelines.family::<EnvStepFamily>().layout(EnvStep::Specular),
                    entries: &[
                        params_at(level),
                        tex(1, &source_cube),
                        wgpu::BindGroupEntry { binding: 2, resource: wgpu::BindingResource::Sampler(&filter_sampler) },
                        tex(3, &level_view(specular_writes, level)),
                    ],
                })
            })
            .collect();
        let sh_level = size.ilog2().saturating_sub(SH_FACE_MAX.ilog2());
        let sh_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("environment irradiance"),
            layout: pipelines.family::<EnvStepFamily>().layout(EnvStep::IrradianceSh),
            entries: &[
                params_at(SPECULAR_LEVELS),
                tex(1, &source_level(sh_level)),
                wgpu::BindGroupEntry { binding: 2, resource: sh.as_entire_binding() },
            ],
        });
        let specular_view = specular.create_view(&wgpu::TextureViewDescriptor {
            dimension: Some(wgpu::TextureViewDimension::Cube),
            ..Default::default()
        });
        Self {
            size,
            sh_face: (size >> sh_level).max(1),
            source,
            specular,
            work,
            specular_view,
            source_params,
            filter_params,
            downsample_groups,
            specular_groups,
            sh_group,
            source_group: None,
        }
    }

    /// The texture whose first level the source step writes (the source cube, or the work
    /// array of its level 0).
    pub(super) fn written_source(&self) -> &wgpu::Texture {
        self.work.as_ref().map_or(&self.source, |w| &w.source[0])
    }

    /// Writes the source step's parameters and, for an image, uploads it; makes the source
    /// step's bind group.
    pub(super) fn upload_source(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        pipelines: &PipelineCache,
        key: &MapsKey,
    ) {
        let mut p = GpuSourceParams::zeroed();
        p.face_size = self.size;
        p.studio = [STUDIO_RADIANCE[0], STUDIO_RADIANCE[1], STUDIO_RADIANCE[2], 0.0];
        let mut image = None;
        match &key.source {
            Source::Sky(s) => {
                p.mode = 0;
                p.perez_lum = s.perez_lum.to_array();
                p.perez_x = s.perez_x.to_array();
                p.perez_y = s.perez_y.to_array();
                p.perez_e = s.perez_e.extend(0.0).to_array();
                p.zenith = s.zenith.extend(0.0).to_array();
                p.sun = s.sun.extend(s.ground).to_array();
            }
            Source::Studio => p.mode = 1,
            Source::Image(img) => {
                p.mode = 2;
                image = Some(upload_equirect(device, queue, img, self.size));
            }
        }
        queue.write_buffer(&self.source_params, 0, bytemuck::bytes_of(&p));
        let placeholder;
        let equirect_view = match &image {
            Some(t) => t.create_view(&Default::default()),
            None => {
                placeholder = device.create_texture(&wgpu::TextureDescriptor {
                    label: Some("no equirectangular image"),
                    size: wgpu::Extent3d { width: 1, height: 1, depth_or_array_layers: 1 },
                    mip_level_count: 1,
                    sample_count: 1,
                    dimension: wgpu::TextureDimension::D2,
                    format: EQUIRECT_FORMAT,
                    usage: wgpu::TextureUsages::TEXTURE_BINDING,
                    view_formats: &[],
                });
                placeholder.create_view(&Default::default())
            }
        };
        let level0 = self.written_source().create_view(&wgpu::TextureViewDescriptor {
            dimension: Some(wgpu::TextureViewDimension::D2Array),
            base_mip_level: 0,
            mip_level_count: Some(1),
            base_array_layer: 0,
            array_layer_count: Some(6),
            ..Default::default()
        });
        self.source_group = Some(device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("environment source"),
            layout: pipelines.family::<EnvStepFamily>().layout(EnvStep::Source),
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: self.source_params.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 1, resource: wgpu::BindingResource::TextureView(&level0) },
                wgpu::BindGroupEntry { binding: 2, resource: wgpu::BindingResource::TextureView(&equirect_view) },
            ],
        }));
    }
}

/// Uploads `img` reduced to 4 × the face size (box-filtered: energy kept), divided by its
/// storage scale. The texture lives only until the source step has read it.
fn upload_equirect(device: &wgpu::Device, queue: &wgpu::Queue, img: &EnvironmentImage, face: u32) -> wgpu::Texture {
    let scale = 1.0 / image_scale(img);
    let reduced = img.reduced(4 * face);
    let texels: Vec<[f32; 4]> =
        reduced.texels.iter().map(|t| [t[0] * scale, t[1] * scale, t[2] * scale, 1.0]).collect();
    let texture = device.create_texture(&wgpu::TextureDescriptor {
        label: Some("environment image"),
        size: wgpu::Extent3d { width: reduced.width, height: reduced.height, depth_or_array_layers: 1 },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format: EQUIRECT_FORMAT,
        usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
        view_formats: &[],
    });
    queue.write_texture(
        texture.as_image_copy(),
        bytemuck::cast_slice(&texels),
        wgpu::TexelCopyBufferLayout { offset: 0, bytes_per_row: Some(reduced.width * 16), rows_per_image: None },
        wgpu::Extent3d { width: reduced.width, height: reduced.height, depth_or_array_layers: 1 },
    );
    texture
}
