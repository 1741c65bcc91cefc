//! Bounded fuzzing in CI: runs each fuzz target's body (`antumbra_protocol::fuzzing`) over its
//! committed seed corpus and 20,000 deterministic mutations of it, without cargo-fuzz.

use std::path::Path;

use antumbra_core::settings::{NamedSettings, SCHEMA};
use antumbra_protocol::fuzzing;
use antumbra_protocol::recording::{replay_scenes_from, RECORDING_MAGIC};
use antumbra_protocol::{decode_body, FrameDecoder, Limits, Request};

const MUTATIONS: usize = 20_000;

fn fuzz_dir() -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("fuzz")
}

fn corpus(target: &str) -> Vec<(String, Vec<u8>)> {
    fuzzing::read_corpus(&fuzz_dir(), target)
}

/// The seeds, then `MUTATIONS` mutations of them and some pure noise, through `body`.
fn fuzz(target: &str, words: &[&str], seed: u64, body: fn(&[u8])) {
    let seeds: Vec<Vec<u8>> = corpus(target).into_iter().map(|(_, b)| b).collect();
    fuzzing::replay(&seeds, words, seed, MUTATIONS, body);
}

#[test]
fn decode_frame_seeds_hold_valid_requests() {
    for (name, seed) in corpus("decode_frame") {
        let mut d = FrameDecoder::new(&Limits::default());
        d.push(&seed);
        let mut count = 0;
        while let Some(_r) = d.next_message::<Request>().unwrap() {
            count += 1;
        }
        assert!(count > 0, "{name}");
        assert_eq!(d.buffered(), 0, "{name}");
    }
}

#[test]
fn decoder_survives_mutated_inputs() {
    fuzz(
        "decode_frame",
        &[],
        0x9e37_79b9_7f4a_7c15,
        fuzzing::decode_frame,
    );
}

#[test]
fn recording_seeds_are_real_recordings() {
    for (name, seed) in corpus("recording") {
        assert!(seed.starts_with(RECORDING_MAGIC), "{name}");
        let scenes = replay_scenes_from(&seed[..]).unwrap_or_else(|e| panic!("{name}: {e}"));
        if name == "session.antrec" {
            // Two frames, then an instance array and the same array sent as unchanged, then a
            // frame with alpha materials.
            assert_eq!(scenes.len(), 5, "{name}");
            let alpha = &scenes[4].alpha;
            assert_eq!(
                (alpha.images.len(), alpha.materials.len()),
                (1, 2),
                "{name}"
            );
            assert!(scenes[4].has_alpha(), "{name}");
            assert!(!scenes[4].meshes[1].uv_maps.is_empty(), "{name}");
            let placed = |s: &antumbra_core::scene::Scene| {
                let o = &s.objects;
                (
                    o.len(),
                    o[1..]
                        .iter()
                        .map(|o| o.world_from_object)
                        .collect::<Vec<_>>(),
                )
            };
            assert_eq!(placed(&scenes[2]).0, 4, "{name}");
            assert_eq!(placed(&scenes[2]).1, placed(&scenes[3]).1, "{name}");
        } else {
            assert_eq!(scenes.len(), 2, "{name}");
        }
    }
}

#[test]
fn recording_reader_survives_mutated_inputs() {
    fuzz("recording", &[], 0x2545_f491_4f6c_dd1d, fuzzing::recording);
    // A valid header over garbage, and a header cut short.
    fuzzing::recording(b"");
    fuzzing::recording(&RECORDING_MAGIC[..5]);
    fuzzing::recording(&[0xff; 64]);
}

/// The settings target's words: every setting's name and flag, and the order grammar's words.
fn settings_words() -> Vec<String> {
    let dict = std::fs::read_to_string(fuzz_dir().join("settings.dict")).unwrap();
    let words: Vec<String> = dict
        .lines()
        .filter_map(|l| l.strip_prefix('"')?.strip_suffix('"').map(String::from))
        .collect();
    for s in SCHEMA {
        assert!(
            words.iter().any(|w| w == s.name),
            "{} is not in settings.dict",
            s.name
        );
    }
    words
}

#[test]
fn settings_seeds_resolve() {
    for (name, seed) in corpus("settings") {
        let named: Option<NamedSettings> = if name.ends_with(".json") {
            Some(serde_json::from_slice(&seed).unwrap())
        } else if name.ends_with(".msgpack") {
            Some(decode_body(&seed).unwrap())
        } else {
            None
        };
        if let Some(named) = named {
            named.resolve().unwrap_or_else(|e| panic!("{name}: {e}"));
        }
        fuzzing::settings(&seed);
    }
}

#[test]
fn settings_parsers_survive_mutated_inputs() {
    let words = settings_words();
    let words: Vec<&str> = words.iter().map(String::as_str).collect();
    fuzz("settings", &words, 0xd1b5_4a32_d192_ed03, fuzzing::settings);
}
