//! Seeded pseudo-random numbers: the same seed gives the same sequence on
//! every machine. Each generator is a fixed, published algorithm, so a
//! sample or a seeded test case built from its draws never changes:
//! - [`XorShift`]: xorshift64 (Marsaglia 2003, shifts 13, 7, 17), the test
//!   cases' generator.
//! - [`SplitMix64`]: SplitMix64 (Steele, Lea, Flood 2014), the random sample
//!   surfaces' generator (docs/formats.md); any seed, 0 included.
//! - [`XorShiftStar`]: xorshift64* (Vigna 2016, shifts 12, 25, 27).
//! - [`Lcg64`]: the 64-bit linear congruential generator with Knuth's MMIX
//!   constants.
//!
//! Every `unit` draw is the top 53 bits of the next output over 2^53, in [0, 1).

/// The top 53 bits of `bits` as a number in [0, 1).
fn unit_of(bits: u64) -> f64 {
    (bits >> 11) as f64 / (1u64 << 53) as f64
}

/// One xorshift64 sequence from a non-zero seed.
pub struct XorShift(pub u64);

impl XorShift {
    /// The next state.
    pub fn next_u64(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }

    /// The next number in [0, 1).
    pub fn unit(&mut self) -> f64 {
        unit_of(self.next_u64())
    }
}

/// One SplitMix64 sequence from any seed.
pub struct SplitMix64(pub u64);

impl SplitMix64 {
    /// The next output: the state advanced by the golden-ratio increment,
    /// mixed.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// The next number in [0, 1).
    pub fn unit(&mut self) -> f64 {
        unit_of(self.next_u64())
    }

    /// The next number in [-1, 1): `2 unit - 1`.
    pub fn symmetric(&mut self) -> f64 {
        self.unit() * 2.0 - 1.0
    }
}

/// One xorshift64* sequence from a non-zero seed.
pub struct XorShiftStar(pub u64);

impl XorShiftStar {
    /// The next output: the xorshift state times the multiplier.
    pub fn next_u64(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }

    /// The next number in [0, 1).
    pub fn unit(&mut self) -> f64 {
        unit_of(self.next_u64())
    }
}

/// One MMIX linear congruential sequence from any seed: state times
/// 6364136223846793005 plus 1442695040888963407, the state the output.
pub struct Lcg64(pub u64);

impl Lcg64 {
    /// The next state.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self
            .0
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        self.0
    }

    /// The next number in [0, 1).
    pub fn unit(&mut self) -> f64 {
        unit_of(self.next_u64())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn splitmix_matches_the_reference_sequence() {
        // First outputs of the reference C implementation (Vigna's
        // splitmix64.c) for seed 1234567.
        let mut r = SplitMix64(1234567);
        assert_eq!(r.next_u64(), 6457827717110365317);
        assert_eq!(r.next_u64(), 3203168211198807973);
        assert_eq!(r.next_u64(), 9817491932198370423);
    }

    /// The generators written out from their definitions with u128
    /// arithmetic (no wrapping helpers), over many steps.
    #[test]
    fn each_generator_follows_its_definition() {
        const M: u128 = 1 << 64;
        let mut x = XorShift(88172645463325252);
        let mut s = 88172645463325252u64;
        let mut star = XorShiftStar(1);
        let mut t = 1u64;
        let mut lcg = Lcg64(42);
        let mut l = 42u128;
        for _ in 0..1000 {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            assert_eq!(x.next_u64(), s);
            t ^= t >> 12;
            t ^= t << 25;
            t ^= t >> 27;
            let out = (u128::from(t) * 0x2545_F491_4F6C_DD1D) % M;
            assert_eq!(u128::from(star.next_u64()), out);
            l = (l * 6364136223846793005 + 1442695040888963407) % M;
            assert_eq!(u128::from(lcg.next_u64()), l);
        }
        // Marsaglia's paper: the first xorshift64 output from this seed.
        assert_eq!(XorShift(88172645463325252).next_u64(), 8748534153485358512);
    }

    #[test]
    fn unit_draws_lie_in_the_unit_interval_and_fill_it() {
        let mut r = SplitMix64(7);
        let draws: Vec<f64> = (0..10_000).map(|_| r.unit()).collect();
        assert!(draws.iter().all(|d| (0.0..1.0).contains(d)));
        let mean = draws.iter().sum::<f64>() / draws.len() as f64;
        assert!((mean - 0.5).abs() < 0.01, "{mean}");
        let mut r = SplitMix64(7);
        let sym: Vec<f64> = (0..10_000).map(|_| r.symmetric()).collect();
        assert!(sym.iter().all(|d| (-1.0..1.0).contains(d)));
        assert!(sym.iter().zip(&draws).all(|(s, d)| *s == 2.0 * d - 1.0));
        assert_eq!(unit_of(u64::MAX), 1.0 - 2f64.powi(-53));
        assert_eq!(unit_of(0), 0.0);
    }
}
