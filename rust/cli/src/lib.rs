//! The antumbra command line's pieces: the commands the `antumbra` binary runs, and the argument
//! types and frame set-up the example programs share with them.

pub mod admission_args;
pub mod commands;
pub mod example_args;
pub mod frames;
pub mod method_args;
pub mod scene_args;
pub mod scene_source;
pub mod shadow_lights;
pub mod write;
