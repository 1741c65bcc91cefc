//! Runs the `decode_frame` fuzz target's body over the committed seed corpus and 20,000
//! deterministic mutations of it, so CI exercises the decoder without cargo-fuzz.

use std::path::Path;

use antumbra_protocol::fuzzing::decode_frame;
use antumbra_protocol::{FrameDecoder, Limits, Request};

fn corpus() -> Vec<Vec<u8>> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("fuzz/corpus/decode_frame");
    let mut files: Vec<_> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.unwrap().path())
        .collect();
    files.sort();
    files.iter().map(|p| std::fs::read(p).unwrap()).collect()
}

/// xorshift64*: deterministic, no dependency.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_f491_4f6c_dd1d)
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
}

fn mutate(rng: &mut Rng, seeds: &[Vec<u8>]) -> Vec<u8> {
    let mut data = seeds[rng.below(seeds.len())].clone();
    for _ in 0..1 + rng.below(4) {
        let len = data.len();
        let at = rng.below(len + 1);
        match rng.below(9) {
            0 if len > 0 => data[at.min(len - 1)] ^= 1 << rng.below(8),
            1 if len > 0 => data[at.min(len - 1)] = rng.next() as u8,
            2 if len > 0 => {
                const INTERESTING: [u8; 8] = [0x00, 0x7f, 0x80, 0xff, 0xc1, 0xdd, 0xc6, 0x90];
                data[at.min(len - 1)] = INTERESTING[rng.below(8)];
            }
            3 => {
                let n = 1 + rng.below(8);
                let bytes: Vec<u8> = (0..n).map(|_| rng.next() as u8).collect();
                data.splice(at..at, bytes);
            }
            4 => {
                let end = (at + 1 + rng.below(16)).min(len);
                data.drain(at.min(end)..end);
            }
            5 => data.truncate(at),
            6 if len > 0 => {
                // Duplicate a range (repeated frames, repeated fields).
                let end = (at + 1 + rng.below(64)).min(len);
                let piece = data[at.min(end)..end].to_vec();
                let to = rng.below(data.len() + 1);
                data.splice(to..to, piece);
            }
            7 => {
                // Splice in part of another seed.
                let other = &seeds[rng.below(seeds.len())];
                let from = rng.below(other.len());
                let end = (from + rng.below(128)).min(other.len());
                data.splice(at..at, other[from..end].iter().copied());
            }
            _ if len >= 4 => {
                // Rewrite a length prefix-sized word with a boundary value.
                let at = at.min(len - 4);
                let v: u32 =
                    [0, 1, 0x7fff_ffff, u32::MAX, (len as u32).wrapping_sub(3)][rng.below(5)];
                data[at..at + 4].copy_from_slice(&v.to_le_bytes());
            }
            _ => {}
        }
    }
    data
}

#[test]
fn seed_corpus_holds_valid_requests() {
    let seeds = corpus();
    assert!(seeds.len() >= 5, "the seed corpus is missing");
    for seed in &seeds {
        let mut d = FrameDecoder::new(&Limits::default());
        d.push(seed);
        let mut count = 0;
        while let Some(_r) = d.next_message::<Request>().unwrap() {
            count += 1;
        }
        assert!(count > 0);
        assert_eq!(d.buffered(), 0);
        decode_frame(seed);
    }
}

#[test]
fn decoder_survives_mutated_inputs() {
    let seeds = corpus();
    let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
    for _ in 0..20_000 {
        let input = mutate(&mut rng, &seeds);
        decode_frame(&input);
    }
    // Pure noise too.
    for n in 0..512 {
        let input: Vec<u8> = (0..n).map(|_| rng.next() as u8).collect();
        decode_frame(&input);
    }
}
