//! Arbitrary bytes as a settings map (JSON, MessagePack) and as command-line flags and values:
//! every settings parser answers with settings or an error naming the setting, never a panic.
//!
//! `cargo fuzz run settings` from `rust/protocol/` (seeds in `corpus/settings`, words in
//! `settings.dict`). The same body runs in CI as `rust/protocol/tests/fuzz_corpus.rs`.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    antumbra_protocol::fuzzing::settings(data);
});
