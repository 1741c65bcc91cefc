//! Arbitrary bytes as a stream from a peer: the incremental decoder (whole and in pieces), the
//! blocking reader, and the daemon's checks of every request decoded must never panic.
//!
//! `cargo fuzz run decode_frame` from `rust/protocol/` (seeds in `corpus/decode_frame`).
//! The same body runs in CI as `rust/protocol/tests/fuzz_corpus.rs`.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    antumbra_protocol::fuzzing::decode_frame(data);
});
