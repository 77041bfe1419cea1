//! Seeded random bicubic surfaces (`toolpath sample random --seed N`): a
//! family of parts the planners have never seen, for the strategy suite
//! (`toolpath compare --suite`). The same parameters give the same surface,
//! bit for bit, on every machine: the generator is SplitMix64
//! (`toolpath_kernel::rng`) and the control net is built from its draws in a
//! fixed order.
//!
//! The surface is a clamped uniform bicubic B-spline over `size_x` x
//! `size_y` mm, one span per [`SPAN_MM`] (at least 2 each way). Control
//! point (i, j) sits at the Greville abscissae (x, y linear in u, v, normal
//! towards +z) with height `amplitude * r_ij + anisotropy * amplitude * 4 *
//! (g_j - 1/2)^2`, `r_ij` uniform in [-1, 1], `g_j` the v Greville abscissa:
//! the random part gives mixed curvature and umbilics, the second a concave
//! trough along x whose depth (anisotropy x amplitude) makes one feed
//! direction much better than the other.

use toolpath_kernel::error::{Error, Result};
use toolpath_kernel::geometry::interpolation::{clamped_uniform_knots, greville};
use toolpath_kernel::geometry::NurbsSurface;
use toolpath_kernel::rng::SplitMix64;

/// Control-net span length, mm.
pub(crate) const SPAN_MM: f64 = 40.0;

/// Parameters of one random surface.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RandomSurface {
    pub seed: u64,
    /// Extent along x (u) and y (v), mm.
    pub size: [f64; 2],
    /// Half-range of the random control heights, mm.
    pub amplitude: f64,
    /// Depth of the trough along x, in amplitudes.
    pub anisotropy: f64,
}

impl Default for RandomSurface {
    fn default() -> Self {
        Self {
            seed: 1,
            size: [200.0, 150.0],
            amplitude: 3.0,
            anisotropy: 0.0,
        }
    }
}

impl RandomSurface {
    /// Checks the parameters, naming the one that is wrong.
    pub fn validate(&self) -> Result<()> {
        for (name, v) in [("size x", self.size[0]), ("size y", self.size[1])] {
            if !(v.is_finite() && (10.0..=2000.0).contains(&v)) {
                return Err(Error::invalid(
                    "--size",
                    format!("{name} = {v} mm: must be within 10..=2000 mm"),
                ));
            }
        }
        if !(self.amplitude.is_finite() && (0.0..=50.0).contains(&self.amplitude)) {
            return Err(Error::invalid(
                "--amplitude",
                format!("{} mm: must be within 0..=50 mm", self.amplitude),
            ));
        }
        if !(self.anisotropy.is_finite() && (0.0..=100.0).contains(&self.anisotropy)) {
            return Err(Error::invalid(
                "--anisotropy",
                format!("{}: must be within 0..=100", self.anisotropy),
            ));
        }
        Ok(())
    }

    /// A short name for tables and job ids, e.g. `random_s7_120x90_a3_k2`.
    pub fn name(&self) -> String {
        format!(
            "random_s{}_{}x{}_a{}_k{}",
            self.seed, self.size[0], self.size[1], self.amplitude, self.anisotropy
        )
    }

    pub fn surface(&self) -> Result<NurbsSurface> {
        self.validate()?;
        let spans = |len: f64| ((len / SPAN_MM).round() as usize).max(2);
        let (su, sv) = (spans(self.size[0]), spans(self.size[1]));
        let ku = clamped_uniform_knots(3, su);
        let kv = clamped_uniform_knots(3, sv);
        let gu = greville(3, &ku);
        let gv = greville(3, &kv);
        let mut rng = SplitMix64(self.seed);
        let cps: Vec<Vec<[f64; 3]>> = gu
            .iter()
            .map(|&u| {
                gv.iter()
                    .map(|&v| {
                        let trough = self.anisotropy * self.amplitude * 4.0 * (v - 0.5).powi(2);
                        [
                            self.size[0] * u,
                            self.size[1] * v,
                            self.amplitude * rng.symmetric() + trough,
                        ]
                    })
                    .collect()
            })
            .collect();
        NurbsSurface::new(3, 3, ku, kv, &cps, None)
    }
}

/// The fixed suite of random surfaces `toolpath compare --suite` plans:
/// twenty 120 x 90 mm parts (so the simulator checks every plan in about a
/// second) over five trough depths and three amplitudes, plus two full-size
/// 200 x 150 mm parts. Seeds 17 and 101 are left out: their corners are
/// curved too tightly for the flat end R 2.5 at lead 5 deg (every strategy
/// refuses them), so 21 and 103 take their places.
pub fn suite() -> Vec<RandomSurface> {
    const SEEDS: [u64; 20] = [
        1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15, 16, 21, 18, 19, 20,
    ];
    const ANISOTROPY: [f64; 5] = [0.0, 0.5, 1.0, 2.0, 4.0];
    const AMPLITUDE: [f64; 3] = [2.0, 3.0, 4.0];
    let mut out: Vec<RandomSurface> = SEEDS
        .iter()
        .enumerate()
        .map(|(k, &seed)| RandomSurface {
            seed,
            size: [120.0, 90.0],
            amplitude: AMPLITUDE[k % 3],
            anisotropy: ANISOTROPY[k % 5],
        })
        .collect();
    for (seed, anisotropy) in [(103, 0.0), (102, 2.0)] {
        out.push(RandomSurface {
            seed,
            size: [200.0, 150.0],
            amplitude: 3.0,
            anisotropy,
        });
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn same_seed_same_surface_other_seed_other_surface() {
        let a = RandomSurface::default().surface().unwrap();
        let b = RandomSurface::default().surface().unwrap();
        assert_eq!(a.control_grid(), b.control_grid());
        let c = RandomSurface {
            seed: 2,
            ..Default::default()
        }
        .surface()
        .unwrap();
        assert_ne!(a.control_grid(), c.control_grid());
        // 200 / 40 = 5 spans along u, 150 / 40 -> 4 along v.
        assert_eq!((a.count_u(), a.count_v()), (8, 7));
        let ((u0, u1), (v0, v1)) = a.domain();
        let (p0, p1) = (a.point(u0, v0), a.point(u1, v1));
        assert!((p0.x).abs() < 1e-12 && (p1.x - 200.0).abs() < 1e-9);
        assert!((p0.y).abs() < 1e-12 && (p1.y - 150.0).abs() < 1e-9);
    }

    #[test]
    fn bad_parameters_are_named() {
        let e = RandomSurface {
            size: [5.0, 100.0],
            ..Default::default()
        }
        .surface()
        .unwrap_err()
        .to_string();
        assert!(e.contains("--size") && e.contains("size x"), "{e}");
        let e = RandomSurface {
            amplitude: f64::NAN,
            ..Default::default()
        }
        .surface()
        .unwrap_err()
        .to_string();
        assert!(e.contains("--amplitude"), "{e}");
    }
}
