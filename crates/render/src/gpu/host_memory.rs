//! Buffers over host memory in place (Vulkan's VK_EXT_external_memory_host): the one owner of
//! that extension. On a CPU rasteriser whose Vulkan driver has it (lavapipe), [`open_device`]
//! enables it when the device is made, and [`import`] wraps bytes the process already holds
//! (decoded texels) in a buffer the driver copies from, instead of staging a copy first.
//!
//! Why: `Queue::write_texture` copies texels into fresh staging memory, and the driver then
//! copies them again into the texture. On lavapipe that first copy of a scene's textures was
//! the render thread's longest step before the first frame: DamagedHelmet's five 2048²
//! textures are 116 MB, about 30 000 freshly faulted pages. Imported, the driver reads the
//! decoded image where it lies. GPUs keep staging copies: there the copy is a DMA either way,
//! and importing pins memory, which was not measured to pay.
//!
//! An import covers whole blocks of the driver's import alignment around the bytes (the bytes
//! need not be aligned); the GPU only reads it. The buffer keeps what owns the bytes alive, and
//! frees its Vulkan buffer and memory when wgpu destroys it, after the last submission that
//! reads it has finished.

use std::ffi::c_void;
use std::sync::Arc;

use ash::vk;
use wgpu::hal::api::Vulkan;

/// The driver's import alignment, if the adapter is a CPU rasteriser through Vulkan with the
/// extension.
pub fn import_alignment(adapter: &wgpu::Adapter) -> Option<u64> {
    if adapter.get_info().device_type != wgpu::DeviceType::Cpu {
        return None;
    }
    // SAFETY: only properties are read from the adapter's handles.
    unsafe {
        let hal = adapter.as_hal::<Vulkan>()?;
        let instance = hal.shared_instance().raw_instance();
        let phd = hal.raw_physical_device();
        let extensions = instance.enumerate_device_extension_properties(phd).ok()?;
        let has = extensions.iter().any(|e| e.extension_name_as_c_str() == Ok(ash::ext::external_memory_host::NAME));
        if !has {
            return None;
        }
        let mut host = vk::PhysicalDeviceExternalMemoryHostPropertiesEXT::default();
        let mut props = vk::PhysicalDeviceProperties2::default().push_next(&mut host);
        instance.get_physical_device_properties2(phd, &mut props);
        let alignment = host.min_imported_host_pointer_alignment;
        // An import covers whole alignment blocks around the bytes: within the bytes' own pages
        // only while a block is no larger than the smallest page (4 KiB).
        (alignment.is_power_of_two() && alignment <= 4096).then_some(alignment)
    }
}

/// A device with the extension enabled, as `Adapter::request_device` would make it otherwise.
///
/// # Safety
/// `adapter` must be a Vulkan adapter for which [`import_alignment`] returned `Some`.
pub unsafe fn open_device(
    adapter: &wgpu::Adapter,
    desc: &wgpu::DeviceDescriptor<'_>,
) -> Result<(wgpu::Device, wgpu::Queue), String> {
    // SAFETY: the caller guarantees a Vulkan adapter with the extension; the callback only adds
    // it to the extensions wgpu enables.
    unsafe {
        let hal = adapter.as_hal::<Vulkan>().ok_or("not a Vulkan adapter")?;
        let open = hal
            .open_with_callback(
                desc.required_features,
                &desc.required_limits,
                &desc.memory_hints,
                Some(Box::new(|args: wgpu::hal::vulkan::CreateDeviceCallbackArgs<'_, '_, '_>| {
                    args.extensions.push(ash::ext::external_memory_host::NAME);
                })),
            )
            .map_err(|e| format!("{e}"))?;
        drop(hal);
        adapter.create_device_from_hal::<Vulkan>(open, desc).map_err(|e| format!("{e}"))
    }
}

/// A `COPY_SRC` buffer over `bytes` where they lie, and the offset of `bytes` in it; `None`
/// where the driver refuses the import (the caller then uploads a copy). `owner` (what keeps
/// `bytes` alive and in place) is held until the GPU is done with the buffer.
///
/// # Safety
/// - `device` was made by [`open_device`], and `alignment` is its [`import_alignment`];
/// - `bytes` lie inside `owner`, which neither frees, moves nor writes them while it lives.
pub unsafe fn import(
    device: &wgpu::Device,
    alignment: u64,
    bytes: &[u8],
    owner: Arc<dyn Send + Sync>,
) -> Option<(wgpu::Buffer, u64)> {
    let start = bytes.as_ptr() as u64;
    let base = start & !(alignment - 1);
    let size = (start + bytes.len() as u64).next_multiple_of(alignment) - base;
    let handle_type = vk::ExternalMemoryHandleTypeFlags::HOST_ALLOCATION_EXT;
    // SAFETY: `base..base + size` lies within the pages that hold `bytes` (the alignment is at
    // most the smallest page size, `import_alignment`), so it is mapped memory of this process;
    // the GPU only reads it, and `owner` keeps it in place until the buffer is destroyed (the
    // caller's contract). The device has the extension (the contract). Every Vulkan object made
    // here is destroyed on every path, by the drop callback once wgpu owns the buffer.
    unsafe {
        let hal = device.as_hal::<Vulkan>()?;
        let raw = hal.raw_device().clone();
        let ext = ash::ext::external_memory_host::Device::new(hal.shared_instance().raw_instance(), &raw);
        let mut host = vk::MemoryHostPointerPropertiesEXT::default();
        let properties = ext.fp().get_memory_host_pointer_properties_ext;
        if properties(raw.handle(), handle_type, base as *const c_void, &mut host) != vk::Result::SUCCESS {
            return None;
        }
        let mut external = vk::ExternalMemoryBufferCreateInfo::default().handle_types(handle_type);
        let info = vk::BufferCreateInfo::default()
            .size(size)
            .usage(vk::BufferUsageFlags::TRANSFER_SRC)
            .sharing_mode(vk::SharingMode::EXCLUSIVE)
            .push_next(&mut external);
        let buffer = raw.create_buffer(&info, None).ok()?;
        let types = host.memory_type_bits & raw.get_buffer_memory_requirements(buffer).memory_type_bits;
        if types == 0 {
            raw.destroy_buffer(buffer, None);
            return None;
        }
        let mut import =
            vk::ImportMemoryHostPointerInfoEXT::default().handle_type(handle_type).host_pointer(base as *mut c_void);
        let alloc = vk::MemoryAllocateInfo::default()
            .allocation_size(size)
            .memory_type_index(types.trailing_zeros())
            .push_next(&mut import);
        let Ok(memory) = raw.allocate_memory(&alloc, None) else {
            raw.destroy_buffer(buffer, None);
            return None;
        };
        if raw.bind_buffer_memory(buffer, memory, 0).is_err() {
            raw.destroy_buffer(buffer, None);
            raw.free_memory(memory, None);
            return None;
        }
        let cleanup = raw.clone();
        let hal_buffer = wgpu::hal::vulkan::Buffer::from_raw_externally_owned(
            buffer,
            Box::new(move || {
                cleanup.destroy_buffer(buffer, None);
                cleanup.free_memory(memory, None);
                drop(owner);
            }),
        );
        drop(hal);
        let wgpu_buffer = device.create_buffer_from_hal::<Vulkan>(
            hal_buffer,
            &wgpu::BufferDescriptor {
                label: Some("texels in place"),
                size,
                usage: wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            },
        );
        Some((wgpu_buffer, start - base))
    }
}
