//! Input generation: random bytes, or valid seeds changed by bit flips, byte inserts and
//! deletes, truncation, splicing, boundary numbers and very long strings.

use sim::Rng;

/// Longest input generated; longer results are cut.
pub const MAX_INPUT_BYTES: usize = 1 << 20;

/// Numbers at the edges of what parsers and filters handle, spliced over numbers in text.
pub const BOUNDARY_NUMBERS: &[&str] = &[
    "NaN",
    "nan",
    "inf",
    "-inf",
    "Infinity",
    "1e308",
    "-1e308",
    "1.7976931348623157e308",
    "1e309",
    "-0",
    "-0.0",
    "0",
    "5e-324",
    "1e-400",
    "18446744073709551615",
    "18446744073709551616",
    "-9223372036854775808",
    "-9223372036854775809",
    "4294967295",
    "4294967296",
    "2147483648",
    "-1",
    "99999999999999999999999999999999",
    "0x10",
    "1_000",
    "",
];

/// Bytes with meaning in JSON, TOML, XML and key expressions.
const SPECIAL_BYTES: &[u8] = b"\0\xff\x7f\x80\"{}[],:;=\\/\n\r\t <>&*$#.-+ e";

/// Little-endian words at the edges of binary length and number fields.
const BOUNDARY_WORDS: &[u64] = &[
    0,
    1,
    0x7f,
    0xff,
    0xffff,
    0x7fff_ffff,
    0x8000_0000,
    0xffff_ffff,
    0x1_0000_0000,
    u64::MAX,
    0x7ff8_0000_0000_0000, // NaN
    0x7ff0_0000_0000_0000, // +inf
    0x8000_0000_0000_0000, // -0.0
    0x7fef_ffff_ffff_ffff, // f64::MAX
];

/// One input: random bytes (one in ten), else a seed with one to four mutations.
pub fn generate(rng: &mut Rng, seeds: &[Vec<u8>]) -> Vec<u8> {
    if seeds.is_empty() || rng.chance(0.1) {
        let len = rng.index(257);
        return (0..len).map(|_| rng.next_u64() as u8).collect();
    }
    let mut input = seeds[rng.index(seeds.len())].clone();
    for _ in 0..=rng.index(4) {
        mutate(rng, &mut input, seeds);
    }
    input.truncate(MAX_INPUT_BYTES);
    input
}

fn mutate(rng: &mut Rng, input: &mut Vec<u8>, seeds: &[Vec<u8>]) {
    let len = input.len();
    match rng.index(11) {
        0 if len > 0 => {
            let i = rng.index(len);
            input[i] ^= 1 << rng.index(8);
        }
        1 if len > 0 => {
            let i = rng.index(len);
            input[i] = SPECIAL_BYTES[rng.index(SPECIAL_BYTES.len())];
        }
        2 => {
            let at = rng.index(len + 1);
            let n = 1 + rng.index(8);
            let bytes: Vec<u8> = (0..n).map(|_| rng.next_u64() as u8).collect();
            input.splice(at..at, bytes);
        }
        3 if len > 0 => {
            let at = rng.index(len);
            let n = 1 + rng.index((len - at).min(16));
            input.drain(at..at + n);
        }
        4 => input.truncate(rng.index(len + 1)),
        5 => {
            let other = &seeds[rng.index(seeds.len())];
            let cut = rng.index(len + 1);
            let from = rng.index(other.len() + 1);
            input.truncate(cut);
            input.extend_from_slice(&other[from..]);
        }
        6 => replace_number(rng, input),
        7 => {
            let at = rng.index(len + 1);
            let n = 1 + rng.index(100_000);
            let byte = SPECIAL_BYTES[rng.index(SPECIAL_BYTES.len())].max(b'a');
            input.splice(at..at, std::iter::repeat_n(byte, n));
        }
        8 if len > 0 => {
            let at = rng.index(len);
            let n = 1 + rng.index((len - at).min(64));
            let chunk = input[at..at + n].to_vec();
            let to = rng.index(len + 1);
            input.splice(to..to, chunk);
        }
        9 if len > 0 => {
            let word = BOUNDARY_WORDS[rng.index(BOUNDARY_WORDS.len())];
            let width = if rng.chance(0.5) { 4 } else { 8 };
            let at = rng.index(len);
            let bytes = &word.to_le_bytes()[..width];
            let end = (at + width).min(len);
            input[at..end].copy_from_slice(&bytes[..end - at]);
        }
        _ => {
            let at = rng.index(len + 1);
            let n = BOUNDARY_NUMBERS[rng.index(BOUNDARY_NUMBERS.len())];
            input.splice(at..at, n.bytes());
        }
    }
}

/// Replaces one run of number characters (digits, sign, point, exponent) by a boundary
/// number; inserts one when the input holds no digit.
fn replace_number(rng: &mut Rng, input: &mut Vec<u8>) {
    let digits: Vec<usize> = (0..input.len())
        .filter(|&i| input[i].is_ascii_digit())
        .collect();
    let number = BOUNDARY_NUMBERS[rng.index(BOUNDARY_NUMBERS.len())].as_bytes();
    if digits.is_empty() {
        let at = rng.index(input.len() + 1);
        input.splice(at..at, number.iter().copied());
        return;
    }
    let is_num = |b: u8| b.is_ascii_digit() || matches!(b, b'.' | b'-' | b'+' | b'e' | b'E');
    let mid = digits[rng.index(digits.len())];
    let mut start = mid;
    while start > 0 && is_num(input[start - 1]) {
        start -= 1;
    }
    let mut end = mid;
    while end < input.len() && is_num(input[end]) {
        end += 1;
    }
    input.splice(start..end, number.iter().copied());
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_same_seed_gives_the_same_inputs() {
        let seeds = vec![b"{\"x\": 1.5, \"y\": [2, 3]}".to_vec()];
        let run = |seed| {
            let mut rng = Rng::new(seed);
            (0..200)
                .map(|_| generate(&mut rng, &seeds))
                .collect::<Vec<_>>()
        };
        assert_eq!(run(7), run(7));
        assert_ne!(run(7), run(8));
    }

    #[test]
    fn inputs_stay_within_the_cap() {
        let seeds = vec![vec![b'1'; 1000]];
        let mut rng = Rng::new(1);
        for _ in 0..2000 {
            assert!(generate(&mut rng, &seeds).len() <= MAX_INPUT_BYTES);
        }
    }
}
