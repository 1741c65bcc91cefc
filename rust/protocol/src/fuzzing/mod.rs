//! The bodies of the cargo-fuzz targets (`rust/protocol/fuzz`), here so that plain `#[test]`s run
//! the same code over the seed corpora and deterministic mutations without cargo-fuzz.

mod corpus;
mod decode_frame;
mod mutate;
mod recording;
mod settings;

pub use corpus::{read_corpus, replay};
pub use decode_frame::decode_frame;
pub use mutate::{mutate, Rng};
pub use recording::recording;
pub use settings::settings;
