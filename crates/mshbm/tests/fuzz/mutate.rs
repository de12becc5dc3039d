//! The mutations of the fuzzer: a deterministic generator per case and the byte-level and
//! token-level changes made to a seed.

/// xorshift64*: a small deterministic generator (Vigna 2016).
pub struct Rng(u64);

impl Rng {
    /// The generator of case `case` of the campaign seeded `seed` (splitmix64 of both, so
    /// neighbouring cases are unrelated).
    pub fn for_case(seed: u64, case: u64) -> Self {
        let mut z = seed ^ case.wrapping_mul(0x9E37_79B9_7F4A_7C15);
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        Rng((z ^ (z >> 31)) | 1)
    }
    /// The generator of case `case` of `target` (each target its own stream of cases).
    pub fn for_target_case(seed: u64, target: &str, case: u64) -> Self {
        // FNV-1a of the target's name
        let t = target.bytes().fold(0xcbf2_9ce4_8422_2325u64, |h, b| {
            (h ^ b as u64).wrapping_mul(0x100_0000_01b3)
        });
        Self::for_case(seed ^ t, case)
    }
    pub fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }
    pub fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
}

/// Replacements for a number (or any token) of a seed.
pub const TOKENS: &[&str] = &[
    "0",
    "-1",
    "1",
    "2",
    "1e308",
    "-1e308",
    "1e-320",
    "1e-300",
    "1e300",
    "18446744073709551615",
    "18446744073709551616",
    "4294967296",
    "4611686018427387904",
    "9223372036854775807",
    "1000000000",
    "100000",
    "nan",
    "inf",
    "-inf",
    "-0.0",
    "\"\u{1b}[31m\"",
    "\"../../etc/passwd\"",
    "\"/dev/zero\"",
    "[]",
    "[[]]",
    "{}",
    "\"\"",
    "true",
    "null",
    "ü",
    "\u{0}",
    "%",
    "\n",
];

/// The bytes of a token-like run around `i`: letters, digits, `.`, `-`, `+`.
fn token_span(s: &[u8], i: usize) -> (usize, usize) {
    let is_num = |b: u8| b.is_ascii_alphanumeric() || b == b'.' || b == b'-' || b == b'+';
    let mut start = i.min(s.len());
    while start > 0 && is_num(s[start - 1]) {
        start -= 1;
    }
    let mut end = start;
    while end < s.len() && is_num(s[end]) {
        end += 1;
    }
    (start, end)
}

/// One to four mutations of `seed`; `other` is a second seed to splice from.
pub fn mutate(seed: &[u8], other: &[u8], rng: &mut Rng) -> Vec<u8> {
    let mut s = seed.to_vec();
    for _ in 0..1 + rng.below(4) {
        let at = rng.below(s.len() + 1);
        match rng.below(7) {
            // flip a bit
            0 if !s.is_empty() => {
                let i = rng.below(s.len());
                s[i] ^= 1 << rng.below(8);
            }
            // insert random bytes
            1 => {
                let bytes: Vec<u8> = (0..1 + rng.below(4)).map(|_| rng.next() as u8).collect();
                s.splice(at..at, bytes);
            }
            // delete a range
            2 if !s.is_empty() => {
                let end = (at + 1 + rng.below(16)).min(s.len());
                let start = at.min(end.saturating_sub(1));
                s.drain(start..end);
            }
            // duplicate a line
            3 => {
                let start = s[..at]
                    .iter()
                    .rposition(|&b| b == b'\n')
                    .map_or(0, |p| p + 1);
                let end = s[at..]
                    .iter()
                    .position(|&b| b == b'\n')
                    .map_or(s.len(), |p| at + p + 1);
                let line = s[start..end].to_vec();
                s.splice(end..end, line);
            }
            // splice: a piece of the other seed replaces the rest from here
            4 if !other.is_empty() => {
                let from = rng.below(other.len());
                let len = 1 + rng.below(other.len() - from);
                let keep = (at + rng.below(64)).min(s.len());
                s.splice(at..keep, other[from..from + len].iter().copied());
            }
            // replace a number (or the token at a random place) by an extreme value
            _ => {
                let digits: Vec<usize> = (0..s.len()).filter(|&i| s[i].is_ascii_digit()).collect();
                let i = if digits.is_empty() {
                    at
                } else {
                    digits[rng.below(digits.len())]
                };
                let (start, end) = token_span(&s, i);
                let token = TOKENS[rng.below(TOKENS.len())].as_bytes().to_vec();
                s.splice(start..end, token);
            }
        }
    }
    s
}
