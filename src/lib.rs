//! Penumbra: a real-time glTF renderer built like a small game engine.
//! `use penumbra::prelude::*;` brings in everything a scene script needs.
pub use penumbra_engine as engine;
pub use penumbra_render as render;

pub mod prelude {
    pub use penumbra_engine::prelude::*;
}
