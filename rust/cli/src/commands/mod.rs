pub mod bench;
pub mod compare;
pub mod demo;
pub mod record;
pub mod render;
pub mod serve;
pub mod spool;
pub mod trade;
