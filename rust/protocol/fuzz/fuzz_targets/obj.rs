//! Arbitrary bytes as an OBJ file: the importer refuses them with an error naming the file or
//! gives a valid framed scene within its limits, never a panic or an allocation it cannot make.
//!
//! `cargo fuzz run obj` from `rust/protocol/` (seeds in `corpus/obj`, words in `obj.dict`). The
//! same body runs in CI as `rust/scenes/tests/fuzz_corpus.rs`.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    antumbra_scenes::fuzzing::obj(data);
});
