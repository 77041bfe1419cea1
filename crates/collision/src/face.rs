//! What the collision check needs of a face of the part: a parametric
//! surface S(u, v) over a rectangle, its derivatives to second order, and the
//! trim (which (u, v) lie on the face).

use nalgebra::Vector3;

/// Position and partial derivatives up to second order at one (u, v).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FaceDerivs {
    pub p: Vector3<f64>,
    pub su: Vector3<f64>,
    pub sv: Vector3<f64>,
    pub suu: Vector3<f64>,
    pub suv: Vector3<f64>,
    pub svv: Vector3<f64>,
}

/// A face of the part. Implementations must be deterministic (the same
/// (u, v) gives the same bits) and defined on the whole `domain` rectangle
/// (the trim only says which of it is the face).
pub trait Face: Send + Sync {
    /// The parameter rectangle `([u0, u1], [v0, v1])`, u0 < u1, v0 < v1.
    fn domain(&self) -> ([f64; 2], [f64; 2]);

    /// S(u, v), (u, v) in the domain.
    fn point(&self, u: f64, v: f64) -> Vector3<f64>;

    /// S and its first and second partial derivatives at (u, v).
    fn derivatives(&self, u: f64, v: f64) -> FaceDerivs;

    /// Is (u, v) on the face (inside the outer trim loop, outside the holes)?
    /// Untrimmed faces keep the default: the whole domain.
    fn inside(&self, _u: f64, _v: f64) -> bool {
        true
    }
}
