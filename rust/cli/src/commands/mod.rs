pub mod bench;
pub mod demo;
pub mod render;
pub mod serve;
