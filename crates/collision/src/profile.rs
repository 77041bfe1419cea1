//! Convex regions of the meridian half-plane and their exact signed distance.
//!
//! A solid of revolution about an axis is its meridian region revolved: the
//! region lies in the half-plane (r, z), r >= 0 the radial distance from the
//! axis and z the height along it. Its boundary, without the axis, is an open
//! chain of line segments and circular arcs from a point of the axis round to
//! another, counter-clockwise (the region on the left of every element). For
//! a point at (r, z), r >= 0, the distance to the revolved solid's surface is
//! the 2-D distance to that chain (the axis is inside the solid, not on its
//! surface), so the signed distance is the distance to the nearest element,
//! negative inside (docs/methods.md, "Cutter solids").
//!
//! Every region here is convex, so the inside test is closed form: the point
//! is on the inner side of every line, and for every arc inside its circle or
//! on the inner side of its chord (the region is the polygon of lines and
//! chords plus the circular segments the arcs add to it).

use crate::error::{Error, Result};

/// A point (r, z) of the meridian half-plane.
pub type Rz = [f64; 2];

/// One boundary element, directed counter-clockwise round the region.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Element {
    /// The segment from `a` to `b`.
    Line { a: Rz, b: Rz },
    /// The arc of the circle (`centre`, `radius`) counter-clockwise from the
    /// point at angle `from` to the one at `to` (radians, `to - from` in
    /// (0, pi]), bulging outwards.
    Arc {
        centre: Rz,
        radius: f64,
        from: f64,
        to: f64,
    },
}

/// The nearest boundary point of a region to a query point, with what the
/// exact refinement needs of the signed distance there.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Nearest {
    /// Signed distance, negative inside.
    pub distance: f64,
    /// The nearest boundary point.
    pub foot: Rz,
    /// Unit gradient of the signed distance at the query point (points away
    /// from the region outside, towards the boundary inside).
    pub normal: Rz,
    /// Curvature of the level set of the signed distance through the query
    /// point, in the meridian plane: 0 next to a line, 1/|p - centre| next to
    /// an arc, 1/|p - vertex| outside a corner (where the level set is a circle
    /// round the vertex).
    pub curvature: f64,
}

/// A segment or arc with the constants its distance needs.
#[derive(Clone, Copy, Debug)]
enum Piece {
    Line {
        a: Rz,
        d: Rz,
        len2: f64,
    },
    Arc {
        c: Rz,
        radius: f64,
        /// Unit vectors from the centre to the arc's two ends.
        ea: Rz,
        eb: Rz,
    },
}

/// A convex meridian region: the exact signed distance of its solid of
/// revolution.
#[derive(Clone, Debug)]
pub struct Profile {
    elements: Vec<Element>,
    pieces: Vec<Piece>,
    /// Largest distance of a boundary point from the origin (the tip), for
    /// bounds on how far the solid's points move when it turns about the tip.
    reach: f64,
    /// Largest radius and the z range of the region.
    r_max: f64,
    z_min: f64,
    z_max: f64,
}

fn sub(a: Rz, b: Rz) -> Rz {
    [a[0] - b[0], a[1] - b[1]]
}

fn cross(a: Rz, b: Rz) -> f64 {
    a[0] * b[1] - a[1] * b[0]
}

fn dot(a: Rz, b: Rz) -> f64 {
    a[0] * b[0] + a[1] * b[1]
}

fn norm(a: Rz) -> f64 {
    (a[0] * a[0] + a[1] * a[1]).sqrt()
}

impl Profile {
    /// A region from its boundary chain. Refuses non-finite values, an arc
    /// of zero radius or a sweep outside (0, pi], and a chain that does not
    /// run from the axis back to the axis with each element starting where
    /// the previous one ends (to 1e-9 of the region's size). Zero-length
    /// segments are dropped. Convexity is the caller's (the crate builds only
    /// convex regions: cutters and frustums).
    pub fn new(elements: &[Element]) -> Result<Self> {
        let mut kept = Vec::new();
        let mut pieces = Vec::new();
        for (k, e) in elements.iter().enumerate() {
            let field = format!("[{k}]");
            match *e {
                Element::Line { a, b } => {
                    if !a.iter().chain(b.iter()).all(|x| x.is_finite()) {
                        return Err(Error::invalid(field, "segment end is not finite"));
                    }
                    let d = sub(b, a);
                    let len2 = dot(d, d);
                    if len2 > 0.0 {
                        kept.push(*e);
                        pieces.push(Piece::Line { a, d, len2 });
                    }
                }
                Element::Arc {
                    centre,
                    radius,
                    from,
                    to,
                } => {
                    let sweep = to - from;
                    let finite = centre[0].is_finite() && centre[1].is_finite();
                    if !finite || !radius.is_finite() || radius <= 0.0 {
                        return Err(Error::invalid(
                            field,
                            "arc needs a finite centre and radius > 0",
                        ));
                    }
                    if !(sweep > 0.0 && sweep <= std::f64::consts::PI + 1e-12) {
                        return Err(Error::invalid(
                            field,
                            format!("arc sweep {sweep} must lie in (0, pi]"),
                        ));
                    }
                    kept.push(*e);
                    let ea = [from.cos(), from.sin()];
                    let eb = [to.cos(), to.sin()];
                    pieces.push(Piece::Arc {
                        c: centre,
                        radius,
                        ea,
                        eb,
                    });
                }
            }
        }
        let profile = Self::with_bounds(kept, pieces)?;
        profile.check_chain()?;
        Ok(profile)
    }

    fn with_bounds(elements: Vec<Element>, pieces: Vec<Piece>) -> Result<Self> {
        if elements.is_empty() {
            return Err(Error::invalid("", "a profile needs at least one element"));
        }
        let mut p = Self {
            elements,
            pieces,
            reach: 0.0,
            r_max: 0.0,
            z_min: f64::INFINITY,
            z_max: f64::NEG_INFINITY,
        };
        for e in &p.elements {
            let (a, b) = ends(e);
            for q in [a, b] {
                p.reach = p.reach.max(norm(q));
                p.r_max = p.r_max.max(q[0]);
                p.z_min = p.z_min.min(q[1]);
                p.z_max = p.z_max.max(q[1]);
            }
            if let Element::Arc { centre, radius, .. } = *e {
                // An arc bulges at most its radius beyond its centre.
                p.reach = p.reach.max(norm(centre) + radius);
                p.r_max = p.r_max.max(centre[0] + radius);
                p.z_min = p.z_min.min(centre[1] - radius);
            }
        }
        Ok(p)
    }

    fn check_chain(&self) -> Result<()> {
        let scale = self.reach.max(1e-300);
        let tol = 1e-9 * scale;
        let first = ends(&self.elements[0]).0;
        let last = ends(&self.elements[self.elements.len() - 1]).1;
        if first[0].abs() > tol || last[0].abs() > tol {
            return Err(Error::invalid(
                "",
                format!(
                    "the chain must start and end on the axis (r = 0), got r = {} and {}",
                    first[0], last[0]
                ),
            ));
        }
        for k in 1..self.elements.len() {
            let prev = ends(&self.elements[k - 1]).1;
            let next = ends(&self.elements[k]).0;
            if norm(sub(prev, next)) > tol {
                return Err(Error::invalid(
                    format!("[{k}]"),
                    format!(
                        "starts at {next:?}, not where element {} ends ({prev:?})",
                        k - 1
                    ),
                ));
            }
        }
        Ok(())
    }

    /// The boundary elements as given (zero-length segments dropped).
    pub fn elements(&self) -> &[Element] {
        &self.elements
    }

    /// Largest distance of a point of the solid from the origin of the
    /// meridian plane (the tool tip).
    pub fn reach(&self) -> f64 {
        self.reach
    }

    /// Largest radius of the solid.
    pub fn r_max(&self) -> f64 {
        self.r_max
    }

    /// Height range `(z_min, z_max)` of the solid.
    pub fn z_range(&self) -> (f64, f64) {
        (self.z_min, self.z_max)
    }

    /// Is (r, z), r >= 0, inside the region (boundary included)?
    pub fn contains(&self, p: Rz) -> bool {
        self.pieces.iter().all(|piece| match *piece {
            Piece::Line { a, d, .. } => cross(d, sub(p, a)) >= 0.0,
            Piece::Arc { c, radius, ea, eb } => {
                let q = sub(p, c);
                let a = [ea[0] * radius, ea[1] * radius];
                let b = [eb[0] * radius, eb[1] * radius];
                dot(q, q) <= radius * radius || cross(sub(b, a), sub(q, a)) >= 0.0
            }
        })
    }

    /// Signed distance from (r, z), r >= 0, negative inside: the fast form
    /// of [`Self::nearest`]`.distance`.
    #[inline]
    pub fn signed_distance(&self, p: Rz) -> f64 {
        let mut best2 = f64::INFINITY;
        let mut inside = true;
        for piece in &self.pieces {
            let (d2, inner) = piece_distance2(piece, p);
            best2 = best2.min(d2);
            inside &= inner;
        }
        let d = best2.sqrt();
        if inside {
            -d
        } else {
            d
        }
    }

    /// The nearest boundary point of (r, z), r >= 0, with the gradient and
    /// the meridian curvature of the signed distance there.
    pub fn nearest(&self, p: Rz) -> Nearest {
        let inside = self.contains(p);
        let mut best = (f64::INFINITY, [0.0; 2], [0.0; 2], 0.0);
        for piece in &self.pieces {
            let (foot, outward, arc_centre, vertex) = piece_foot(piece, p);
            let d = norm(sub(p, foot));
            if d < best.0 {
                let curvature = match (arc_centre, vertex && !inside) {
                    (Some(c), _) => 1.0 / norm(sub(p, c)).max(1e-300),
                    (None, true) => 1.0 / d.max(1e-300),
                    (None, false) => 0.0,
                };
                best = (d, foot, outward, curvature);
            }
        }
        let (d, foot, outward, curvature) = best;
        let normal = if d > 1e-12 * self.reach.max(1e-300) {
            let s = if inside { -1.0 } else { 1.0 };
            [s * (p[0] - foot[0]) / d, s * (p[1] - foot[1]) / d]
        } else {
            outward
        };
        Nearest {
            distance: if inside { -d } else { d },
            foot,
            normal,
            curvature,
        }
    }
}

impl Profile {
    /// Number of boundary elements.
    pub fn piece_count(&self) -> usize {
        self.pieces.len()
    }

    /// The inside branch of the signed distance for element `k` alone:
    /// -d_k(p), d_k the distance to the element, with its gradient and
    /// meridian curvature. Inside the region the signed distance is the
    /// largest of these over the elements, a maximum of smooth pieces whose
    /// kinks (the medial axis) the refinement follows.
    pub fn inside_piece(&self, k: usize, p: Rz) -> Nearest {
        let (foot, outward, arc_centre, vertex) = piece_foot(&self.pieces[k], p);
        let d = norm(sub(p, foot));
        let normal = if d > 1e-12 * self.reach.max(1e-300) {
            [(foot[0] - p[0]) / d, (foot[1] - p[1]) / d]
        } else {
            outward
        };
        let curvature = match (arc_centre, vertex) {
            // -d_k = |p - c| - radius inside the circle.
            (Some(c), _) => 1.0 / norm(sub(p, c)).max(1e-300),
            // -d_k = -|p - vertex|: concave.
            (None, true) => -1.0 / d.max(1e-300),
            (None, false) => 0.0,
        };
        Nearest {
            distance: -d,
            foot,
            normal,
            curvature,
        }
    }
}

/// The two ends of an element, in the chain's direction.
fn ends(e: &Element) -> (Rz, Rz) {
    match *e {
        Element::Line { a, b } => (a, b),
        Element::Arc {
            centre,
            radius,
            from,
            to,
        } => (
            [
                centre[0] + radius * from.cos(),
                centre[1] + radius * from.sin(),
            ],
            [centre[0] + radius * to.cos(), centre[1] + radius * to.sin()],
        ),
    }
}

/// Squared distance from `p` to the element, and whether `p` is on the
/// region's side of it (the convex inside test's term for this element).
#[inline]
fn piece_distance2(piece: &Piece, p: Rz) -> (f64, bool) {
    match *piece {
        Piece::Line { a, d, len2 } => {
            let ap = sub(p, a);
            let t = (dot(ap, d) / len2).clamp(0.0, 1.0);
            let e = [ap[0] - d[0] * t, ap[1] - d[1] * t];
            (dot(e, e), cross(d, ap) >= 0.0)
        }
        Piece::Arc { c, radius, ea, eb } => {
            let q = sub(p, c);
            let q2 = dot(q, q);
            let a = [ea[0] * radius, ea[1] * radius];
            let b = [eb[0] * radius, eb[1] * radius];
            let inner = q2 <= radius * radius || cross(sub(b, a), sub(q, a)) >= 0.0;
            if cross(ea, q) >= 0.0 && cross(q, eb) >= 0.0 {
                let g = q2.sqrt() - radius;
                (g * g, inner)
            } else {
                let (da, db) = (sub(q, a), sub(q, b));
                (dot(da, da).min(dot(db, db)), inner)
            }
        }
    }
}

/// The nearest point of the element to `p`, the element's outward normal
/// there, the arc's centre when the foot is inside an arc, and whether the
/// foot is an end of the element (a vertex).
fn piece_foot(piece: &Piece, p: Rz) -> (Rz, Rz, Option<Rz>, bool) {
    match *piece {
        Piece::Line { a, d, len2 } => {
            let t_raw = dot(sub(p, a), d) / len2;
            let t = t_raw.clamp(0.0, 1.0);
            let len = len2.sqrt();
            let outward = [d[1] / len, -d[0] / len];
            let foot = [a[0] + d[0] * t, a[1] + d[1] * t];
            (foot, outward, None, t_raw != t)
        }
        Piece::Arc { c, radius, ea, eb } => {
            let q = sub(p, c);
            if cross(ea, q) >= 0.0 && cross(q, eb) >= 0.0 {
                let n = norm(q);
                let e = if n > 0.0 { [q[0] / n, q[1] / n] } else { ea };
                let foot = [c[0] + radius * e[0], c[1] + radius * e[1]];
                (foot, e, Some(c), false)
            } else {
                let a = [c[0] + radius * ea[0], c[1] + radius * ea[1]];
                let b = [c[0] + radius * eb[0], c[1] + radius * eb[1]];
                if norm(sub(p, a)) <= norm(sub(p, b)) {
                    (a, ea, None, true)
                } else {
                    (b, eb, None, true)
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::FRAC_PI_2;

    /// The torus cutter's profile: R 5, corner 1, flutes 10.
    fn torus() -> Profile {
        Profile::new(&[
            Element::Line {
                a: [0.0, 0.0],
                b: [4.0, 0.0],
            },
            Element::Arc {
                centre: [4.0, 1.0],
                radius: 1.0,
                from: -FRAC_PI_2,
                to: 0.0,
            },
            Element::Line {
                a: [5.0, 1.0],
                b: [5.0, 10.0],
            },
            Element::Line {
                a: [5.0, 10.0],
                b: [0.0, 10.0],
            },
        ])
        .unwrap()
    }

    #[test]
    fn torus_distances_at_known_points() {
        let p = torus();
        let s = std::f64::consts::FRAC_1_SQRT_2;
        let cases = [
            ([0.0, -2.0], 2.0),
            ([7.0, 5.0], 2.0),
            ([4.0 + 2.0 * s, 1.0 - 2.0 * s], 1.0),
            ([2.0, 0.5], -0.5),
            ([4.5, 5.0], -0.5),
            ([8.0, 14.0], 5.0),
            ([0.0, 5.0], -5.0),
        ];
        for (q, want) in cases {
            assert!((p.signed_distance(q) - want).abs() < 1e-12, "{q:?}");
            assert!((p.nearest(q).distance - want).abs() < 1e-12, "{q:?}");
        }
        // Outside the top outer corner the level set is a circle round it.
        let n = p.nearest([8.0, 14.0]);
        assert!((n.curvature - 0.2).abs() < 1e-12);
        assert_eq!(n.foot, [5.0, 10.0]);
        // Next to the corner arc it is a circle round the arc's centre.
        let n = p.nearest([4.0 + 2.0 * s, 1.0 - 2.0 * s]);
        assert!((n.curvature - 0.5).abs() < 1e-12);
        assert!((n.normal[0] - s).abs() < 1e-12 && (n.normal[1] + s).abs() < 1e-12);
    }

    #[test]
    fn broken_chains_are_refused_with_the_element() {
        let e = Profile::new(&[
            Element::Line {
                a: [0.0, 0.0],
                b: [4.0, 0.0],
            },
            Element::Line {
                a: [4.0, 0.5],
                b: [0.0, 1.0],
            },
        ])
        .unwrap_err();
        assert_eq!(e.field, "[1]");
        let e = Profile::new(&[Element::Line {
            a: [1.0, 0.0],
            b: [0.0, 1.0],
        }])
        .unwrap_err();
        assert!(e.message.contains("axis"), "{e}");
        let e = Profile::new(&[Element::Arc {
            centre: [0.0, 0.0],
            radius: 1.0,
            from: 0.0,
            to: 4.0,
        }])
        .unwrap_err();
        assert!(e.message.contains("sweep"), "{e}");
    }
}
