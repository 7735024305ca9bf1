//! Passes: each encodes GPU work from what prepare made. Nothing here reads the ECS.
pub mod clusters;
pub mod culling;
pub mod deferred_lights;
pub mod forward;
pub mod gizmos;
pub mod occlusion_feedback;
pub mod post;
pub mod resolve;
pub mod shadows;
pub mod tonemap;
