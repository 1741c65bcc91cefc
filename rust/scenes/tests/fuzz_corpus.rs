//! Bounded fuzzing of the importers in CI: runs each fuzz target's body
//! (`antumbra_scenes::fuzzing`) over its committed seed corpus (`rust/protocol/fuzz/corpus/obj`
//! and `gltf`), 20,000 deterministic mutations of it and some noise, without cargo-fuzz.

use std::path::{Path, PathBuf};

use antumbra_protocol::fuzzing as protocol_fuzzing;
use antumbra_scenes::{fuzzing, load_gltf, load_obj, ImportLimits};

const MUTATIONS: usize = 20_000;

fn fuzz_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../protocol/fuzz")
}

fn corpus(target: &str) -> Vec<(String, Vec<u8>)> {
    protocol_fuzzing::read_corpus(&fuzz_dir(), target)
}

/// A target's dictionary words (`<target>.dict`, one quoted word a line, `\xNN` escapes).
fn words(target: &str) -> Vec<String> {
    let dict = std::fs::read_to_string(fuzz_dir().join(format!("{target}.dict"))).unwrap();
    let words: Vec<String> = dict
        .lines()
        .filter_map(|l| l.strip_prefix('"')?.strip_suffix('"'))
        .map(unescape)
        .collect();
    assert!(words.len() > 5, "{target}.dict is nearly empty");
    words
}

/// A libFuzzer dictionary word's `\xNN` escapes as the bytes they stand for.
fn unescape(word: &str) -> String {
    let mut out = String::new();
    let mut rest = word;
    while let Some(at) = rest.find("\\x") {
        out.push_str(&rest[..at]);
        let byte = u8::from_str_radix(&rest[at + 2..at + 4], 16).unwrap();
        out.push(char::from(byte));
        rest = &rest[at + 4..];
    }
    out.push_str(rest);
    out
}

/// The seeds, then `MUTATIONS` mutations of them and some pure noise, through `body`.
fn fuzz(target: &str, seed: u64, body: fn(&[u8])) {
    let seeds: Vec<Vec<u8>> = corpus(target).into_iter().map(|(_, b)| b).collect();
    let words = words(target);
    let words: Vec<&str> = words.iter().map(String::as_str).collect();
    protocol_fuzzing::replay(&seeds, &words, seed, MUTATIONS, body);
}

#[test]
fn obj_seeds_are_valid_files() {
    for (name, seed) in corpus("obj") {
        let anim = load_obj(&name, &seed[..], 1, &ImportLimits::default())
            .unwrap_or_else(|e| panic!("{e}"));
        assert!(anim.frame(1).triangle_count() > 0, "{name}");
    }
}

#[test]
fn gltf_seeds_are_valid_files() {
    for (name, seed) in corpus("gltf") {
        // The raw buffer is a seed for the fixed document's binary chunk, not a file.
        if name.ends_with(".bin") {
            continue;
        }
        let anim = load_gltf(&name, &seed, None, 1, &ImportLimits::default())
            .unwrap_or_else(|e| panic!("{e}"));
        assert!(anim.frame(1).triangle_count() > 0, "{name}");
    }
}

#[test]
fn obj_importer_survives_mutated_inputs() {
    fuzz("obj", 0x9e37_79b9_7f4a_7c15, fuzzing::obj);
    // A polygon over the triangle limit, and one line of a megabyte.
    let mut big = b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf".to_vec();
    for _ in 0..30_000 {
        big.extend_from_slice(b" 1 2 3");
    }
    fuzzing::obj(&big);
    fuzzing::obj(&vec![b'v'; 1 << 20]);
}

#[test]
fn gltf_importer_survives_mutated_inputs() {
    fuzz("gltf", 0x2545_f491_4f6c_dd1d, fuzzing::gltf);
}
