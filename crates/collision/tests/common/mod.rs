//! Shared by the integration tests: a seeded generator and tools.
#![allow(dead_code)]

use nalgebra::Vector3;
use toolpath_collision::{Cutter, HolderSegment, ToolAssembly};

/// SplitMix64: a small seeded generator, the same numbers on every machine.
pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Self {
        Self(seed)
    }
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// Uniform in [lo, hi).
    pub fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }
    pub fn unit(&mut self) -> Vector3<f64> {
        loop {
            let v = Vector3::new(self.range(-1.0, 1.0), self.range(-1.0, 1.0), self.range(-1.0, 1.0));
            let n = v.norm();
            if n > 0.1 && n <= 1.0 {
                return v / n;
            }
        }
    }
    /// A unit vector within `max_angle` of +z.
    pub fn axis_near_z(&mut self, max_angle: f64) -> Vector3<f64> {
        let a = self.range(0.0, max_angle);
        let phi = self.range(0.0, std::f64::consts::TAU);
        Vector3::new(a.sin() * phi.cos(), a.sin() * phi.sin(), a.cos())
    }
}

/// The tools the tests use: flat end, ball and torus with a shank and a
/// conical holder.
pub fn tools() -> Vec<ToolAssembly> {
    let holder = vec![
        HolderSegment::cylinder(25.0, 3.0),
        HolderSegment::cone(30.0, 8.0, 12.0),
    ];
    [
        Cutter::flat_end(5.0, 20.0),
        Cutter::ball(4.0, 15.0),
        Cutter::torus(6.0, 1.5, 18.0),
    ]
    .into_iter()
    .map(|c| ToolAssembly::new(c, holder.clone()).unwrap())
    .collect()
}
