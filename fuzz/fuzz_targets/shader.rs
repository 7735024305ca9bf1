//! An edited shader file through the composer, as a hot reload sees it: the first byte picks
//! which embedded file the rest replaces, then the forward shader (which imports most modules)
//! and the edited file itself are composed and validated with naga. No GPU is involved.
#![no_main]

use libfuzzer_sys::fuzz_target;
use penumbra_render::pipelines::shader_library::{EMBEDDED, ShaderDefs, ShaderLibrary};

fuzz_target!(|data: &[u8]| {
    let Some((&pick, rest)) = data.split_first() else { return };
    let Ok(source) = std::str::from_utf8(rest) else { return };
    let file = EMBEDDED[pick as usize % EMBEDDED.len()].0;
    let Ok(mut library) = ShaderLibrary::embedded_with(file, source) else { return };
    // The top bits pick a variant, so feature-gated code is composed too.
    let on = |bit: u8| pick & (0x80 >> bit) != 0;
    let defs = ShaderDefs::default()
        .with("NORMAL_MAP", on(0))
        .with("SHADOWS", on(1))
        .with("LOCAL_LIGHTS", on(2))
        .with("CLUSTERED_LIGHTS", on(2))
        .with("IBL", on(3));
    let _ = library.compose("forward.wgsl", &defs);
    let _ = library.compose(file, &defs);
});
