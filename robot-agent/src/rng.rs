//! A small seeded pseudo-random generator (SplitMix64) for the deterministic parts of the
//! detector's training and clustering: shuffles, splits and k-means++ seeding. Results must
//! be reproducible from a seed, and the generator's quality needs are modest, so a
//! dependency would buy nothing.

/// SplitMix64 (Steele, Lea and Flood 2014): one 64-bit state, full period, good enough
/// statistics for shuffling and sampling.
#[derive(Debug, Clone)]
pub(crate) struct SplitMix64 {
    state: u64,
}

impl SplitMix64 {
    /// A generator started from `seed`.
    pub(crate) fn new(seed: u64) -> Self {
        Self { state: seed }
    }

    /// The next 64 random bits.
    pub(crate) fn next_u64(&mut self) -> u64 {
        self.state = self.state.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.state;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// A uniform number in [0, 1).
    pub(crate) fn next_f64(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }

    /// A uniform index in `0..n`; `n` must be positive.
    pub(crate) fn below(&mut self, n: usize) -> usize {
        // The modulo bias is below 2^-40 for any n this crate uses.
        (self.next_u64() % n.max(1) as u64) as usize
    }

    /// Shuffles a slice in place (Fisher–Yates).
    pub(crate) fn shuffle<T>(&mut self, items: &mut [T]) {
        for i in (1..items.len()).rev() {
            let j = self.below(i + 1);
            items.swap(i, j);
        }
    }
}

/// xoshiro256** (Blackman and Vigna 2018) seeded per named stream: the draws of the random
/// negative windows of labelled photos. It draws exactly what the simulator's generator
/// draws for the same stream (`sim::rng::Rng::stream`, which those windows were first
/// drawn from), so the shipped classifier's recipe still gives the same model.
#[derive(Debug, Clone)]
pub(crate) struct Xoshiro256 {
    s: [u64; 4],
}

impl Xoshiro256 {
    /// The stream of (`seed`, `label`, `index`).
    pub(crate) fn stream(seed: u64, label: &str, index: u64) -> Self {
        let fnv1a = label.bytes().fold(0xCBF2_9CE4_8422_2325_u64, |h, b| {
            (h ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01B3)
        });
        let a = SplitMix64::new(seed ^ fnv1a.rotate_left(17)).next_u64();
        let b = SplitMix64::new(index.wrapping_add(0x5851_F42D_4C95_7F2D)).next_u64();
        let mut sm = SplitMix64::new(a ^ b);
        let mut s = [0u64; 4];
        for word in &mut s {
            *word = sm.next_u64();
        }
        if s == [0; 4] {
            // The all-zero state is the one xoshiro cannot leave.
            s[0] = 1;
        }
        Xoshiro256 { s }
    }

    /// The next 64 random bits.
    pub(crate) fn next_u64(&mut self) -> u64 {
        let result = self.s[1].wrapping_mul(5).rotate_left(7).wrapping_mul(9);
        let t = self.s[1] << 17;
        self.s[2] ^= self.s[0];
        self.s[3] ^= self.s[1];
        self.s[1] ^= self.s[2];
        self.s[0] ^= self.s[3];
        self.s[2] ^= t;
        self.s[3] = self.s[3].rotate_left(45);
        result
    }

    /// Uniform in [lo, hi).
    pub(crate) fn range(&mut self, lo: f64, hi: f64) -> f64 {
        let uniform = (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64);
        lo + (hi - lo) * uniform
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The first draws of a stream, as the simulator's generator gives them for the same
    /// seed, label and index (values taken from `sim::rng::Rng::stream(1,
    /// "labelled-negatives", 0)`).
    #[test]
    fn streams_draw_what_the_simulators_generator_draws() {
        let mut r = Xoshiro256::stream(1, "labelled-negatives", 0);
        let got: Vec<u64> = (0..3).map(|_| r.next_u64()).collect();
        assert_eq!(
            got,
            [
                0xd1de_d22f_7406_6fc5,
                0x2f11_ae16_6ea6_7bb0,
                0x8b19_279b_f4bb_c944
            ]
        );
    }
}
