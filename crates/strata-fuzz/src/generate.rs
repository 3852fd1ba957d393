//! Inputs from seeds: a small deterministic generator, byte-level mutations that have broken
//! parsers before (bit flips, truncation, splices of hostile tokens, numbers replaced,
//! repetition, deleted lines), `builtin:` specs and option words from sensible to absurd. The
//! CLI's process-per-input fuzz test (`crates/strata-cli/tests/fuzz.rs`) draws from the same.

/// SplitMix64: one input's randomness, reproducible from the run's seed and the input's index.
pub struct Rng(pub u64);

impl Rng {
    /// The generator of input `index` of a run seeded `seed`.
    pub fn for_input(seed: u64, index: u64) -> Rng {
        let mut rng = Rng(seed ^ index.wrapping_mul(0xD1B5_4A32_D192_ED03));
        rng.next_u64();
        rng
    }

    /// The next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// A number in `0..n` (0 when `n` is 0).
    pub fn below(&mut self, n: usize) -> usize {
        (self.next_u64() % n.max(1) as u64) as usize
    }

    /// One of `items` (not empty).
    pub fn pick<'a, T>(&mut self, items: &'a [T]) -> &'a T {
        &items[self.below(items.len())]
    }
}

/// Tokens that have broken parsers: huge, negative and non-finite numbers, deep nesting,
/// references to devices, counts past any limit.
pub const TOKENS: &[&str] = &[
    "-1",
    "0",
    "nan",
    "inf",
    "1e39",
    "-1e39",
    "4294967295",
    "4294967296",
    "99999999999999999999999",
    "[[[[[[[[[[[[[[[[",
    "{{{{{{{{",
    "\n",
    "\0",
    "\u{ff}",
    "end_header\n",
    "element face 2147483647\n",
    "element vertex 4000000000\n",
    "property list uint int vertex_indices\n",
    "format binary_big_endian 1.0\n",
    "f 1 2 99999999\n",
    "f -9 -8 -7\n",
    "v 1e30 -1e30 nan\n",
    "mtllib /dev/zero\n",
    "\"uri\": \"/dev/zero\"",
    "\"uri\": \"data:application/octet-stream;base64,@@@\"",
    "\"byteLength\": 4294967295",
    "\"byteOffset\": 4294967295",
    "\"count\": 4294967295",
    "\"componentType\": 5126",
    "\"indices\": 99999",
    "mesh = \"/dev/zero.obj\"",
    "mesh = \"builtin:sphere?segments=64\"",
    "segments=99999",
    "[[object]]\n",
    "[[material]]\n",
    "scale = [0, 0, 0]\n",
];

/// `input` with one to three mutations.
pub fn mutate(rng: &mut Rng, input: &[u8]) -> Vec<u8> {
    let mut out = input.to_vec();
    for _ in 0..1 + rng.below(3) {
        let at = rng.below(out.len() + 1);
        match rng.below(7) {
            0 => {
                for _ in 0..1 + rng.below(8) {
                    if !out.is_empty() {
                        let i = rng.below(out.len());
                        out[i] ^= 1 << rng.below(8);
                    }
                }
            }
            1 => out.truncate(at),
            2 => {
                let token = rng.pick(TOKENS).as_bytes();
                out.splice(at..at, token.iter().copied());
            }
            3 => {
                // Replace the number that starts after `at` with a token.
                let start = out[at..]
                    .iter()
                    .position(u8::is_ascii_digit)
                    .map(|i| at + i);
                if let Some(start) = start {
                    let len = out[start..]
                        .iter()
                        .take_while(|b| b.is_ascii_digit() || **b == b'.')
                        .count();
                    let token = rng.pick(TOKENS).as_bytes();
                    out.splice(start..start + len, token.iter().copied());
                }
            }
            4 => {
                let len = rng.below(out.len().saturating_sub(at).min(256) + 1);
                let copy: Vec<u8> = out[at..at + len].to_vec();
                for _ in 0..1 + rng.below(4) {
                    out.splice(at..at, copy.iter().copied());
                }
            }
            5 => {
                // A binary word overwritten with an extreme value (counts, offsets, lengths).
                let word: [u8; 4] = *rng.pick(&[
                    [0xff; 4],
                    [0; 4],
                    [0x7f, 0xff, 0xff, 0xff],
                    [0xff, 0xff, 0xff, 0x7f],
                    [0, 0, 0x80, 0x7f],
                ]);
                for (i, b) in word.iter().enumerate() {
                    if let Some(slot) = out.get_mut(at + i) {
                        *slot = *b;
                    }
                }
            }
            _ => {
                // Delete a line.
                let start = out[..at]
                    .iter()
                    .rposition(|&b| b == b'\n')
                    .map_or(0, |i| i + 1);
                let end = out[at..]
                    .iter()
                    .position(|&b| b == b'\n')
                    .map_or(out.len(), |i| at + i + 1);
                out.drain(start..end);
            }
        }
    }
    out
}

/// Numbers for parameters, from sensible to absurd. Valid ones stay small: a large valid scene
/// takes its time legitimately (it is costed by its estimate), which is not what fuzzing is for.
const NUMBERS: &[&str] = &[
    "-1",
    "0",
    "1",
    "2",
    "3",
    "4",
    "7",
    "16",
    "0.5",
    "1e9",
    "99999999999999999999",
    "x",
    "nan",
    "inf",
    "",
    "+3",
    "0x10",
    "3.5",
    "-0",
];

/// A `builtin:` spec with parameters from sensible to absurd: scenes, keys and values
/// scrambled, repeated and missing. `heavy` allows the built-in models (about 0.1 s each).
pub fn builtin_spec(rng: &mut Rng, heavy: bool) -> String {
    let mut n = || *rng.pick(NUMBERS);
    let (a, b, c) = (n(), n(), n());
    let spec = match rng.below(12) {
        0 => format!("nvpro?objects={a}&subdiv={b}&seed={c}"),
        1 => format!("spheres?layers={a}&segments={b}"),
        2 => format!("layers?n={a}&coverage={b}&order=random&seed={c}"),
        3 => format!("layers?n={a}&coverage={b}&order={c}"),
        4 => format!("balls?count={a}&frame={b}&radius={c}"),
        5 => format!("stack?layers={a}&columns={b}&segments={c}"),
        6 => format!("layers?n={a}&n={b}"),
        7 => format!("layers?n={a}&&=&{b}=={c}"),
        8 => format!("nvpro?objects={a}&subdiv"),
        9 => "demo".to_string(),
        10 if heavy => format!(
            "{}?subdivide={a}",
            rng.pick(&["dragon", "bunny", "suzanne", "spot", "teapot"])
        ),
        _ => format!(
            "{}?{a}={b}",
            rng.pick(&["nope", "", "layers", "demo", "dragon", "?"])
        ),
    };
    format!("builtin:{spec}")
}

/// Words for the library's keyword options: every valid word of each, and near misses.
pub fn word(rng: &mut Rng, valid: &[&str]) -> String {
    let base = rng.pick(valid).to_string();
    match rng.below(12) {
        0 => base.to_uppercase(),
        1 => format!("{base} "),
        2 => base[..rng.below(base.len() + 1)].to_string(),
        3 => String::from_utf8_lossy(&mutate(rng, base.as_bytes())).into_owned(),
        _ => base,
    }
}

/// A number for an option, from sensible to absurd.
pub fn number(rng: &mut Rng) -> f64 {
    *rng.pick(&[
        -1.0,
        0.0,
        1e-9,
        0.5,
        1.0,
        4.0,
        16.0,
        300.0,
        65535.0,
        1e12,
        f64::NAN,
        f64::INFINITY,
        -f64::INFINITY,
        f64::MAX,
    ])
}

/// A count for an option, from sensible to absurd.
pub fn count(rng: &mut Rng) -> u32 {
    *rng.pick(&[
        0,
        1,
        2,
        3,
        4,
        8,
        16,
        64,
        257,
        4096,
        16384,
        16385,
        65535,
        u32::MAX,
    ])
}
