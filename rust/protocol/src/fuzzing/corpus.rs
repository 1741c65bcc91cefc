//! What the plain-test replays of every fuzz target share: the committed seed corpus of a
//! target, and the run of its body over the seeds, deterministic mutations of them and noise.

use std::path::Path;

use super::mutate::{mutate, Rng};

/// The seeds of `target` under `fuzz_dir/corpus/<target>/`, as (file name, bytes), by name.
/// Panics (a test's failure) when the folder is missing or holds fewer than two seeds.
pub fn read_corpus(fuzz_dir: &Path, target: &str) -> Vec<(String, Vec<u8>)> {
    let dir = fuzz_dir.join("corpus").join(target);
    let mut files: Vec<_> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.unwrap().path())
        .collect();
    files.sort();
    assert!(files.len() >= 2, "the {target} seed corpus is missing");
    files
        .iter()
        .map(|p| {
            let name = p.file_name().unwrap().to_string_lossy().into_owned();
            (name, std::fs::read(p).unwrap())
        })
        .collect()
}

/// `body` over the seeds, then `mutations` mutations of them (with dictionary `words`) drawn
/// from `seed`, then 512 inputs of noise of growing length.
pub fn replay(seeds: &[Vec<u8>], words: &[&str], seed: u64, mutations: usize, body: fn(&[u8])) {
    for s in seeds {
        body(s);
    }
    let mut rng = Rng(seed);
    for _ in 0..mutations {
        body(&mutate(&mut rng, seeds, words));
    }
    for n in 0..512 {
        let noise: Vec<u8> = (0..n).map(|_| rng.next_u64() as u8).collect();
        body(&noise);
    }
}
