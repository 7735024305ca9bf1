//! Rendering features, one folder each: its settings, GPU resources, pipeline families, share of
//! the shared bind groups and the passes it encodes. A feature reads the shared resources and
//! the frame's targets; nothing outside its folder creates or binds what it owns.
pub mod bloom;
pub mod clusters;
pub mod culling;
pub mod deferred_lights;
pub mod deform;
pub mod environment;
pub mod exposure;
pub mod forward;
pub mod fxaa;
pub mod gizmos;
pub mod post;
pub mod resolve;
pub mod shadows;
pub mod tonemap;
pub mod transmission;
pub mod visibility;
