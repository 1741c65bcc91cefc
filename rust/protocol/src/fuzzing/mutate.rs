//! Deterministic byte mutations of seed inputs, for the bounded fuzzing the tests run in CI
//! (libFuzzer's own mutator does this under cargo-fuzz).

/// xorshift64*: deterministic, no dependency.
pub struct Rng(pub u64);

impl Rng {
    pub fn next_u64(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_f491_4f6c_dd1d)
    }

    pub fn below(&mut self, n: usize) -> usize {
        (self.next_u64() % n.max(1) as u64) as usize
    }
}

/// One to four edits of a random seed: bit flips, boundary bytes and words, inserted, deleted,
/// duplicated or spliced ranges, and `words` (a target's keywords) put in or over its bytes.
pub fn mutate(rng: &mut Rng, seeds: &[Vec<u8>], words: &[&str]) -> Vec<u8> {
    let mut data = seeds[rng.below(seeds.len())].clone();
    for _ in 0..1 + rng.below(4) {
        let len = data.len();
        let at = rng.below(len + 1);
        match rng.below(10) {
            0 if len > 0 => data[at.min(len - 1)] ^= 1 << rng.below(8),
            1 if len > 0 => data[at.min(len - 1)] = rng.next_u64() as u8,
            2 if len > 0 => {
                const INTERESTING: [u8; 8] = [0x00, 0x7f, 0x80, 0xff, 0xc1, 0xdd, 0xc6, 0x90];
                data[at.min(len - 1)] = INTERESTING[rng.below(8)];
            }
            3 => {
                let n = 1 + rng.below(8);
                let bytes: Vec<u8> = (0..n).map(|_| rng.next_u64() as u8).collect();
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
            8 if !words.is_empty() => {
                // A keyword inserted, or written over the bytes at `at`.
                let word = words[rng.below(words.len())].as_bytes();
                if rng.below(2) == 0 {
                    data.splice(at..at, word.iter().copied());
                } else {
                    let end = (at + word.len()).min(len);
                    data.splice(at..end, word.iter().copied());
                }
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
