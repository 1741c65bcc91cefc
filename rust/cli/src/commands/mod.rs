pub mod bench;
pub mod bench_methods;
pub mod demo;
pub mod render;
pub mod serve;
