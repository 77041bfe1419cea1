//! Closed-form faces: planes, cylinders, spheres, tori and a wavy height
//! field, with an optional trim. The tests and the benchmark build parts from
//! them, where every distance has an exact answer; callers may use them for
//! the analytic faces of a STEP part too.

use crate::face::{Face, FaceDerivs};
use nalgebra::Vector3;
use std::sync::Arc;

fn derivs(p: Vector3<f64>, su: Vector3<f64>, sv: Vector3<f64>) -> FaceDerivs {
    FaceDerivs {
        p,
        su,
        sv,
        suu: Vector3::zeros(),
        suv: Vector3::zeros(),
        svv: Vector3::zeros(),
    }
}

/// S(u, v) = origin + u e_u + v e_v over a rectangle.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Plane {
    pub origin: Vector3<f64>,
    pub e_u: Vector3<f64>,
    pub e_v: Vector3<f64>,
    pub u: [f64; 2],
    pub v: [f64; 2],
}

impl Face for Plane {
    fn domain(&self) -> ([f64; 2], [f64; 2]) {
        (self.u, self.v)
    }
    fn point(&self, u: f64, v: f64) -> Vector3<f64> {
        self.origin + self.e_u * u + self.e_v * v
    }
    fn derivatives(&self, u: f64, v: f64) -> FaceDerivs {
        derivs(self.point(u, v), self.e_u, self.e_v)
    }
}

/// An axis-aligned rectangle at height z: [x0, x1] x [y0, y1].
pub fn horizontal_rectangle(z: f64, x: [f64; 2], y: [f64; 2]) -> Plane {
    Plane {
        origin: Vector3::new(0.0, 0.0, z),
        e_u: Vector3::x(),
        e_v: Vector3::y(),
        u: x,
        v: y,
    }
}

/// The six faces of the box [lo, hi].
pub fn box_faces(lo: Vector3<f64>, hi: Vector3<f64>) -> Vec<Arc<dyn Face>> {
    let mut faces: Vec<Arc<dyn Face>> = Vec::new();
    for axis in 0..3 {
        let (a, b) = ((axis + 1) % 3, (axis + 2) % 3);
        let (ea, eb) = (unit(a), unit(b));
        for side in [lo[axis], hi[axis]] {
            let mut origin = Vector3::zeros();
            origin[axis] = side;
            faces.push(Arc::new(Plane {
                origin,
                e_u: ea,
                e_v: eb,
                u: [lo[a], hi[a]],
                v: [lo[b], hi[b]],
            }));
        }
    }
    faces
}

fn unit(i: usize) -> Vector3<f64> {
    let mut e = Vector3::zeros();
    e[i] = 1.0;
    e
}

/// A circular cylinder: S(theta, h) = base + radius (cos theta x + sin theta
/// y) + h axis, with (x, y, axis) orthonormal.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cylinder {
    pub base: Vector3<f64>,
    pub x: Vector3<f64>,
    pub y: Vector3<f64>,
    pub axis: Vector3<f64>,
    pub radius: f64,
    pub theta: [f64; 2],
    pub height: [f64; 2],
}

impl Face for Cylinder {
    fn domain(&self) -> ([f64; 2], [f64; 2]) {
        (self.theta, self.height)
    }
    fn point(&self, t: f64, h: f64) -> Vector3<f64> {
        self.base + (self.x * t.cos() + self.y * t.sin()) * self.radius + self.axis * h
    }
    fn derivatives(&self, t: f64, h: f64) -> FaceDerivs {
        let (c, s) = (t.cos(), t.sin());
        let radial = (self.x * c + self.y * s) * self.radius;
        let mut d = derivs(
            self.base + radial + self.axis * h,
            (self.y * c - self.x * s) * self.radius,
            self.axis,
        );
        d.suu = -radial;
        d
    }
}

/// A sphere: S(theta, phi) = centre + radius (cos phi cos theta, cos phi
/// sin theta, sin phi); phi in [-pi/2, pi/2] has collapsed boundaries.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sphere {
    pub centre: Vector3<f64>,
    pub radius: f64,
    pub theta: [f64; 2],
    pub phi: [f64; 2],
}

impl Face for Sphere {
    fn domain(&self) -> ([f64; 2], [f64; 2]) {
        (self.theta, self.phi)
    }
    fn point(&self, t: f64, p: f64) -> Vector3<f64> {
        let (ct, st, cp, sp) = (t.cos(), t.sin(), p.cos(), p.sin());
        self.centre + Vector3::new(cp * ct, cp * st, sp) * self.radius
    }
    fn derivatives(&self, t: f64, p: f64) -> FaceDerivs {
        let (ct, st, cp, sp) = (t.cos(), t.sin(), p.cos(), p.sin());
        let r = self.radius;
        FaceDerivs {
            p: self.centre + Vector3::new(cp * ct, cp * st, sp) * r,
            su: Vector3::new(-cp * st, cp * ct, 0.0) * r,
            sv: Vector3::new(-sp * ct, -sp * st, cp) * r,
            suu: Vector3::new(-cp * ct, -cp * st, 0.0) * r,
            suv: Vector3::new(sp * st, -sp * ct, 0.0) * r,
            svv: Vector3::new(-cp * ct, -cp * st, -sp) * r,
        }
    }
}

/// A torus about the z axis through `centre`: S(theta, phi) = centre +
/// (major + minor cos phi)(cos theta, sin theta, 0) + minor sin phi z.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Torus {
    pub centre: Vector3<f64>,
    pub major: f64,
    pub minor: f64,
    pub theta: [f64; 2],
    pub phi: [f64; 2],
}

impl Face for Torus {
    fn domain(&self) -> ([f64; 2], [f64; 2]) {
        (self.theta, self.phi)
    }
    fn point(&self, t: f64, p: f64) -> Vector3<f64> {
        self.derivatives(t, p).p
    }
    fn derivatives(&self, t: f64, p: f64) -> FaceDerivs {
        let (ct, st, cp, sp) = (t.cos(), t.sin(), p.cos(), p.sin());
        let (a, b) = (self.major, self.minor);
        let w = a + b * cp;
        let radial = Vector3::new(ct, st, 0.0);
        let tangent = Vector3::new(-st, ct, 0.0);
        let z = Vector3::z();
        FaceDerivs {
            p: self.centre + radial * w + z * (b * sp),
            su: tangent * w,
            sv: radial * (-b * sp) + z * (b * cp),
            suu: -radial * w,
            suv: tangent * (-b * sp),
            svv: radial * (-b * cp) + z * (-b * sp),
        }
    }
}

/// The height field z = base + amplitude sin(u / wavelength) cos(v /
/// wavelength) over a rectangle: a freeform floor.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Wave {
    pub base: f64,
    pub amplitude: f64,
    pub wavelength: f64,
    pub u: [f64; 2],
    pub v: [f64; 2],
}

impl Face for Wave {
    fn domain(&self) -> ([f64; 2], [f64; 2]) {
        (self.u, self.v)
    }
    fn point(&self, u: f64, v: f64) -> Vector3<f64> {
        let (a, l) = (self.amplitude, self.wavelength);
        Vector3::new(u, v, self.base + a * (u / l).sin() * (v / l).cos())
    }
    fn derivatives(&self, u: f64, v: f64) -> FaceDerivs {
        let (a, l) = (self.amplitude, self.wavelength);
        let (su_, cu) = ((u / l).sin(), (u / l).cos());
        let (sv_, cv) = ((v / l).sin(), (v / l).cos());
        let k = a / (l * l);
        FaceDerivs {
            p: Vector3::new(u, v, self.base + a * su_ * cv),
            su: Vector3::new(1.0, 0.0, a / l * cu * cv),
            sv: Vector3::new(0.0, 1.0, -a / l * su_ * sv_),
            suu: Vector3::new(0.0, 0.0, -k * su_ * cv),
            suv: Vector3::new(0.0, 0.0, -k * cu * sv_),
            svv: Vector3::new(0.0, 0.0, -k * su_ * cv),
        }
    }
}

/// A face trimmed by a predicate on (u, v).
pub struct Trimmed<F> {
    pub face: F,
    pub keep: Box<dyn Fn(f64, f64) -> bool + Send + Sync>,
}

impl<F: Face> Face for Trimmed<F> {
    fn domain(&self) -> ([f64; 2], [f64; 2]) {
        self.face.domain()
    }
    fn point(&self, u: f64, v: f64) -> Vector3<f64> {
        self.face.point(u, v)
    }
    fn derivatives(&self, u: f64, v: f64) -> FaceDerivs {
        self.face.derivatives(u, v)
    }
    fn inside(&self, u: f64, v: f64) -> bool {
        (self.keep)(u, v)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Central differences of `point` against the closed-form derivatives.
    fn check(face: &dyn Face, u: f64, v: f64) {
        let h = 1e-5;
        let d = face.derivatives(u, v);
        let fu = (face.point(u + h, v) - face.point(u - h, v)) / (2.0 * h);
        let fv = (face.point(u, v + h) - face.point(u, v - h)) / (2.0 * h);
        let du = face.derivatives(u + h, v);
        let dm = face.derivatives(u - h, v);
        let dvp = face.derivatives(u, v + h);
        let dvm = face.derivatives(u, v - h);
        let tol = 1e-6 * (1.0 + d.p.norm());
        assert!((d.p - face.point(u, v)).norm() < 1e-12);
        assert!((fu - d.su).norm() < tol, "su");
        assert!((fv - d.sv).norm() < tol, "sv");
        assert!(((du.su - dm.su) / (2.0 * h) - d.suu).norm() < tol, "suu");
        assert!(((dvp.su - dvm.su) / (2.0 * h) - d.suv).norm() < tol, "suv");
        assert!(((dvp.sv - dvm.sv) / (2.0 * h) - d.svv).norm() < tol, "svv");
    }

    #[test]
    fn closed_form_derivatives_match_differences() {
        let cyl = Cylinder {
            base: Vector3::new(1.0, 2.0, 3.0),
            x: Vector3::x(),
            y: Vector3::y(),
            axis: Vector3::z(),
            radius: 7.0,
            theta: [0.0, 6.0],
            height: [0.0, 5.0],
        };
        let sph = Sphere {
            centre: Vector3::new(-1.0, 0.5, 2.0),
            radius: 4.0,
            theta: [0.0, 6.2],
            phi: [-1.5, 1.5],
        };
        let tor = Torus {
            centre: Vector3::zeros(),
            major: 10.0,
            minor: 3.0,
            theta: [0.0, 6.2],
            phi: [0.0, 6.2],
        };
        let wave = Wave {
            base: 1.0,
            amplitude: 2.0,
            wavelength: 7.0,
            u: [0.0, 50.0],
            v: [0.0, 50.0],
        };
        for (u, v) in [(0.3, 0.7), (2.1, -0.4), (4.0, 1.2)] {
            check(&cyl, u, v);
            check(&sph, u, v);
            check(&tor, u, v);
            check(&wave, 10.0 * u, 7.0 * v);
        }
    }
}
