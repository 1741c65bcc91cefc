pub mod bench;
pub mod bench_methods;
pub mod demo;
pub mod record;
pub mod render;
pub mod serve;
