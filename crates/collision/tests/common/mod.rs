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
    /// SplitMix64's next output ([`toolpath_kernel::rng::SplitMix64`]).
    pub fn next_u64(&mut self) -> u64 {
        let mut g = toolpath_kernel::rng::SplitMix64(self.0);
        let x = g.next_u64();
        self.0 = g.0;
        x
    }
    /// Uniform in [lo, hi).
    pub fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }
    pub fn unit(&mut self) -> Vector3<f64> {
        loop {
            let v = Vector3::new(
                self.range(-1.0, 1.0),
                self.range(-1.0, 1.0),
                self.range(-1.0, 1.0),
            );
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

use std::f64::consts::{PI, TAU};
use std::sync::Arc;
use toolpath_collision::shapes::{Cylinder, Plane, Sphere, Torus, Trimmed, Wave};
use toolpath_collision::Face;

/// An orthonormal pair across `n`.
pub fn across(n: &Vector3<f64>) -> (Vector3<f64>, Vector3<f64>) {
    let e1 = toolpath_collision::assembly::any_perpendicular(n);
    (e1, n.cross(&e1))
}

/// A random scene of `count` faces within about 60 mm of the origin: tilted
/// planes, cylinders, spheres, tori and wavy floors, some trimmed by discs
/// or with holes.
pub fn random_scene(rng: &mut Rng, count: usize) -> Vec<Arc<dyn Face>> {
    (0..count).map(|_| random_face(rng)).collect()
}

fn random_face(rng: &mut Rng) -> Arc<dyn Face> {
    let centre = Vector3::new(
        rng.range(-40.0, 40.0),
        rng.range(-40.0, 40.0),
        rng.range(-20.0, 20.0),
    );
    let kind = rng.next_u64() % 6;
    let trimmed = rng.range(0.0, 1.0) < 0.4;
    let face: Arc<dyn Face> = match kind {
        0 => {
            let (e_u, e_v) = across(&rng.unit());
            let plane = Plane {
                origin: centre,
                e_u,
                e_v,
                u: [-30.0, 30.0],
                v: [-20.0, 20.0],
            };
            if trimmed {
                // A disc with a hole.
                Arc::new(Trimmed {
                    face: plane,
                    keep: Box::new(|u, v| {
                        let r2 = u * u + v * v;
                        (25.0..=400.0).contains(&r2)
                    }),
                })
            } else {
                Arc::new(plane)
            }
        }
        1 => {
            let (x, y) = across(&rng.unit());
            let axis = x.cross(&y);
            Arc::new(Cylinder {
                base: centre,
                x,
                y,
                axis,
                radius: rng.range(3.0, 20.0),
                theta: [0.0, rng.range(1.0, TAU)],
                height: [-15.0, 15.0],
            })
        }
        2 => Arc::new(Sphere {
            centre,
            radius: rng.range(3.0, 20.0),
            theta: [0.0, TAU],
            phi: [-0.5 * PI, rng.range(-0.3, 0.5 * PI)],
        }),
        3 => Arc::new(Torus {
            centre,
            major: rng.range(8.0, 20.0),
            minor: rng.range(1.0, 6.0),
            theta: [0.0, rng.range(1.0, TAU)],
            phi: [0.0, TAU],
        }),
        _ => {
            let wave = Wave {
                base: centre.z,
                amplitude: rng.range(0.5, 5.0),
                wavelength: rng.range(4.0, 15.0),
                u: [centre.x - 30.0, centre.x + 30.0],
                v: [centre.y - 30.0, centre.y + 30.0],
            };
            if trimmed {
                let (cx, cy) = (centre.x, centre.y);
                Arc::new(Trimmed {
                    face: wave,
                    keep: Box::new(move |u, v| (u - cx).hypot(v - cy) <= 25.0),
                })
            } else {
                Arc::new(wave)
            }
        }
    };
    face
}
