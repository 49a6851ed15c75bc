//! Deterministic pseudo-random numbers: the one home of the project's generators.
//!
//! Hand-written instead of the `rand` crate so that the byte-for-byte sequence is
//! fixed by this file alone and can never change under a dependency upgrade:
//! synthetic truth and optimiser results must be reproducible forever, across
//! platforms.
//!
//! - [`SplitMix64`] (Steele, Lea & Flood 2014): tiny, fast, passes BigCrush when
//!   used as a stream; it expands seeds into xoshiro's state and is also used
//!   directly as a stream (synthetic accelerograms, test signals).
//! - [`Rng`]: xoshiro256** (Blackman & Vigna 2018) seeded through SplitMix64.
//!
//! Normal deviates come from the Box–Muller transform.  Each stream keeps the
//! exact variant its callers were written against: [`Rng::normal`] caches the
//! second (sine) deviate of each pair, [`Rng::normal_uncached`] uses the cosine
//! branch only, and [`SplitMix64::next_gaussian`] draws both uniforms in (0, 1].

/// SplitMix64 generator.
#[derive(Debug, Clone)]
pub struct SplitMix64 {
    state: u64,
}

impl SplitMix64 {
    pub fn new(seed: u64) -> Self {
        SplitMix64 { state: seed }
    }

    /// Next raw 64-bit output (Weyl increment, then the MurmurHash3-style finaliser).
    pub fn next_u64(&mut self) -> u64 {
        self.state = self.state.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.state;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in (0, 1] (53 random bits, never 0 so that ln is finite).
    pub fn next_open01(&mut self) -> f64 {
        ((self.next_u64() >> 11) as f64 + 1.0) / (1u64 << 53) as f64
    }

    /// Standard normal deviate (Box–Muller, cosine branch).
    pub fn next_gaussian(&mut self) -> f64 {
        let u1 = self.next_open01();
        let u2 = self.next_open01();
        (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
    }
}

/// xoshiro256** generator with a cached second Box–Muller deviate (used only by
/// [`Rng::normal`]).
#[derive(Debug, Clone)]
pub struct Rng {
    state: [u64; 4],
    spare_normal: Option<f64>,
}

impl Rng {
    /// Generator whose whole sequence is determined by `seed` (four SplitMix64
    /// outputs from `seed` form xoshiro's state).
    pub fn new(seed: u64) -> Self {
        let mut sm = SplitMix64::new(seed);
        let state = [sm.next_u64(), sm.next_u64(), sm.next_u64(), sm.next_u64()];
        Rng {
            state,
            spare_normal: None,
        }
    }

    /// An independent stream derived from this seed and a stream index (for per-solver or
    /// per-particle generators that must not depend on scheduling).
    pub fn derived(seed: u64, stream: u64) -> Self {
        let mut sm = SplitMix64::new(seed ^ stream.wrapping_mul(0xD1B5_4A32_D192_ED03));
        Rng::new(sm.next_u64())
    }

    /// Next raw 64-bit output (xoshiro256** scrambler and state transition).
    pub fn next_u64(&mut self) -> u64 {
        let s = &mut self.state;
        let result = s[1].wrapping_mul(5).rotate_left(7).wrapping_mul(9);
        let t = s[1] << 17;
        s[2] ^= s[0];
        s[3] ^= s[1];
        s[1] ^= s[2];
        s[0] ^= s[3];
        s[2] ^= t;
        s[3] = s[3].rotate_left(45);
        result
    }

    /// Uniform deviate in [0, 1) with 53 random bits.
    pub fn uniform(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }

    /// Uniform in [lo, hi).
    pub fn uniform_in(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.uniform()
    }

    /// Uniform integer in [0, n) (n > 0).
    pub fn below(&mut self, n: usize) -> usize {
        if n == 0 {
            return 0;
        }
        ((self.uniform() * n as f64) as usize).min(n - 1)
    }

    /// Standard normal deviate (Box–Muller; the second value of each pair is cached).
    pub fn normal(&mut self) -> f64 {
        if let Some(z) = self.spare_normal.take() {
            return z;
        }
        // 1 − u lies in (0, 1], so the logarithm is finite.
        let u1 = 1.0 - self.uniform();
        let u2 = self.uniform();
        let radius = (-2.0 * u1.ln()).sqrt();
        let angle = std::f64::consts::TAU * u2;
        self.spare_normal = Some(radius * angle.sin());
        radius * angle.cos()
    }

    /// Standard normal by the Box–Muller transform, cosine branch only: two fresh
    /// uniforms per deviate, nothing cached (u₁ is clamped to the smallest positive
    /// normal so that the logarithm is finite).  The optimisers' stream.
    pub fn normal_uncached(&mut self) -> f64 {
        let u1 = self.uniform().max(f64::MIN_POSITIVE);
        let u2 = self.uniform();
        (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
    }

    /// `n` independent normal deviates ([`Rng::normal`]) with standard deviation `std`.
    pub fn normal_vec(&mut self, n: usize, std: f64) -> Vec<f64> {
        (0..n).map(|_| std * self.normal()).collect()
    }
}
