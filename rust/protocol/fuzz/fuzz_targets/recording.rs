//! Arbitrary bytes as a recording (`.antrec`), as given and after a valid header: the reader and
//! the replay refuse them with an error or give scenes that pass the spool's checks, never a panic.
//!
//! `cargo fuzz run recording` from `rust/protocol/` (seeds in `corpus/recording`). The same body
//! runs in CI as `rust/protocol/tests/fuzz_corpus.rs`.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    antumbra_protocol::fuzzing::recording(data);
});
