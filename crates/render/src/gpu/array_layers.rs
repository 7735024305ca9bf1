//! How many layers to allocate for a texture that shaders bind as a 2D array, per backend.
//!
//! wgpu's GL backend has to choose a texture's GL target when the texture is created, before any
//! view of it exists, and it guesses from the shape: one layer is `TEXTURE_2D`, a square with a
//! multiple of six layers a cube map, anything else `TEXTURE_2D_ARRAY`. A `texture_2d_array`
//! (or storage array) binding of a texture it guessed as something else reads or writes nothing
//! there; wgpu-hal only logs "heuristics assumed that the view dimension will be …". So the shadow
//! atlases (which can have one or six layers) and the environment's working cubes ask
//! [`ArrayLayers::allocate`] how many layers to create: on GL a count the guess maps to
//! `TEXTURE_2D_ARRAY` (at most one spare layer, never sampled), elsewhere exactly the count asked
//! for. Owners keep the count they asked for; the spare layer costs memory on GL only.

/// The layer rule of the device's backend (`Capabilities::array_layers`).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ArrayLayers {
    /// The backend guesses texture targets from their shape (GL).
    guesses_targets: bool,
}

impl ArrayLayers {
    pub fn for_backend(backend: wgpu::Backend) -> Self {
        Self { guesses_targets: backend == wgpu::Backend::Gl }
    }

    /// Layers to create for an array texture of `layers` layers of `width × height`, so that every
    /// backend binds it as an array.
    pub fn allocate(&self, layers: u32, width: u32, height: u32) -> u32 {
        if !self.guesses_targets {
            return layers;
        }
        let layers = layers.max(2);
        if width == height && layers.is_multiple_of(6) { layers + 1 } else { layers }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Mirrors wgpu-hal's GL target guess (`Texture::get_info_from_desc`, wgpu-hal 30).
    fn gl_guess_is_array(layers: u32, width: u32, height: u32) -> bool {
        let cube_compatible = layers.is_multiple_of(6) && width == height;
        layers > 1 && !cube_compatible
    }

    #[test]
    fn gl_allocations_are_always_guessed_as_arrays() {
        let gl = ArrayLayers::for_backend(wgpu::Backend::Gl);
        for layers in 1..=40 {
            for (w, h) in [(1, 1), (128, 128), (2048, 2048), (256, 128)] {
                let n = gl.allocate(layers, w, h);
                assert!(n >= layers && n <= layers + 1, "{layers} layers of {w}×{h}: {n}");
                assert!(gl_guess_is_array(n, w, h), "{layers} layers of {w}×{h} allocated as {n}");
            }
        }
    }

    #[test]
    fn other_backends_allocate_what_is_asked() {
        for backend in [wgpu::Backend::Vulkan, wgpu::Backend::Metal, wgpu::Backend::Dx12] {
            let rule = ArrayLayers::for_backend(backend);
            for layers in [1, 6, 7, 12] {
                assert_eq!(rule.allocate(layers, 64, 64), layers);
            }
        }
    }
}
