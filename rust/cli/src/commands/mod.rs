pub mod bench;
pub mod demo;
pub mod record;
pub mod render;
pub mod serve;
