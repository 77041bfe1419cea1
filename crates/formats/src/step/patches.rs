//! The surface of a face as a NURBS patch over the face's extent (exact for
//! planes, revolved and extruded surfaces), with the map from a 3-D
//! boundary point to the patch's (u, v).

use super::curves::Curve;
use super::records::Frame;
use super::surfaces::{Basis, Meridian};
use super::{StepFile, SurfaceFile, V3};
use nalgebra::{Point3, Vector2};
use std::f64::consts::{PI, TAU};
use toolpath_kernel::error::Result;
use toolpath_kernel::geometry::inversion::{closest_point, closest_point_near};

/// How a meridian parameter s maps to the patch's v: itself (lines and
/// B-splines), or through the conic's rational arcs.
#[derive(Clone, Copy)]
pub(super) enum VMap {
    Same,
    Arcs(Arcs),
}

impl VMap {
    pub(super) fn v_of(&self, s: f64) -> f64 {
        match self {
            VMap::Same => s,
            VMap::Arcs(a) => a.u_of(s),
        }
    }

    pub(super) fn s_of(&self, v: f64) -> f64 {
        match self {
            VMap::Same => v,
            VMap::Arcs(a) => a.theta_of(v),
        }
    }
}

/// Knots of `n` rational quadratic arcs over [0, 1].
pub(super) fn arc_knots(n: usize) -> Vec<f64> {
    let mut k = vec![0.0; 3];
    for i in 1..n {
        let u = i as f64 / n as f64;
        k.extend([u, u]);
    }
    k.extend([1.0; 3]);
    k
}

/// The angle parametrisation of a revolved NURBS: `n` rational quadratic
/// arcs of `delta` radians each from `theta0`, u in [0, 1].
#[derive(Clone, Copy)]
pub(super) struct Arcs {
    theta0: f64,
    delta: f64,
    n: usize,
}

impl Arcs {
    pub(super) fn new(theta0: f64, theta1: f64) -> Self {
        let span = (theta1 - theta0).max(1e-9);
        let n = (span / (0.5 * PI) - 1e-9).ceil().max(1.0) as usize;
        Arcs {
            theta0,
            delta: span / n as f64,
            n,
        }
    }

    /// u of angle `theta`: on the arc from -a to a with weights 1, cos a, 1,
    /// the point at parameter s in [0, 1] has angle psi with
    /// tan(psi / 2) = tan(a / 2) (2 s - 1) (docs/formats.md, "STEP import").
    pub(super) fn u_of(&self, theta: f64) -> f64 {
        let s = (theta - self.theta0) / self.delta;
        let k = (s.floor().max(0.0) as usize).min(self.n - 1);
        let psi = theta - self.theta0 - (k as f64 + 0.5) * self.delta;
        let t = 0.5 * (1.0 + (0.5 * psi).tan() / (0.25 * self.delta).tan());
        ((k as f64 + t) / self.n as f64).clamp(0.0, 1.0)
    }

    pub(super) fn theta_of(&self, u: f64) -> f64 {
        let s = u.clamp(0.0, 1.0) * self.n as f64;
        let k = (s.floor() as usize).min(self.n - 1);
        let t = s - k as f64;
        let psi = 2.0 * ((0.25 * self.delta).tan() * (2.0 * t - 1.0)).atan();
        self.theta0 + (k as f64 + 0.5) * self.delta + psi
    }
}

impl StepFile {
    /// The face's surface as a NURBS patch covering its boundary (`coarse`:
    /// the boundary's sampled loops), and the map from a 3-D boundary point
    /// (with an optional nearby (u, v) seed) to the patch's (u, v).
    pub(super) fn patch(&self, face: u64, basis: Basis, coarse: &[Vec<V3>]) -> Result<Patch> {
        match basis {
            Basis::Bspline(s) => bspline_patch(s),
            Basis::Plane(f) => self.plane_patch(face, f, coarse),
            Basis::Revolved(f, m, what) => self.revolved_patch(face, f, m, what, coarse),
            Basis::Extruded(f, m) => self.extruded_patch(face, f, m, coarse),
            Basis::Offset {
                basis,
                distance,
                id,
            } => self.offset_patch(face, *basis, distance, id, coarse),
        }
    }

    /// A surface of linear extrusion as the exact patch over the section
    /// range and the heights its boundary spans: the section's NURBS in u
    /// (as a meridian's, [`Self::meridian_profile`]) times a line along the
    /// axis in v, so u runs along the swept curve and v along the axis
    /// vector, the orientation STEP gives the surface.
    pub(super) fn extruded_patch(
        &self,
        face: u64,
        f: Frame,
        m: Meridian,
        coarse: &[Vec<V3>],
    ) -> Result<Patch> {
        const WHAT: &str = "surface of linear extrusion";
        let section = move |q: &V3| [(q - f.o).dot(&f.x), (q - f.o).dot(&f.y)];
        let height = move |q: &V3| (q - f.o).dot(&f.z);
        let (mut s0, mut s1) = (f64::INFINITY, f64::NEG_INFINITY);
        let (mut h0, mut h1) = (f64::INFINITY, f64::NEG_INFINITY);
        let mut s_reference = None;
        for l in coarse {
            let mut s_prev: Option<f64> = None;
            for q in l {
                let s = m.locate(section(q), s_prev.or(s_reference));
                s_reference.get_or_insert(s);
                s_prev = Some(s);
                (s0, s1) = (s0.min(s), s1.max(s));
                (h0, h1) = (h0.min(height(q)), h1.max(height(q)));
            }
        }
        if !(s1 > s0 && h1 > h0) {
            return Err(self.err(face, format!("has a boundary of no extent on its {WHAT}")));
        }
        let MeridianProfile {
            degree: degree_u,
            knots: knots_u,
            points: profile,
            map: umap,
            range: (s0, s1),
        } = self.meridian_profile(face, &m, WHAT, (s0, s1))?;
        let rational = profile.iter().any(|p| p.w != 1.0);
        let at = |q: [f64; 2], h: f64| {
            let p = f.o + f.x * q[0] + f.y * q[1] + f.z * h;
            [p.x, p.y, p.z]
        };
        let (u_lo, u_hi) = (umap.v_of(s0), umap.v_of(s1));
        Ok(Patch {
            surface: SurfaceFile {
                kind: "nurbs".into(),
                name: None,
                degree_u,
                degree_v: 1,
                knots_u,
                knots_v: vec![h0, h0, h1, h1],
                control_points: profile
                    .iter()
                    .map(|p| vec![at(p.q, h0), at(p.q, h1)])
                    .collect(),
                weights: rational.then(|| profile.iter().map(|p| vec![p.w, p.w]).collect()),
                trim: None,
            },
            to_uv: Box::new(move |q: &V3, seed: Option<[f64; 2]>| {
                let s_near = seed.map(|sd| umap.s_of(sd[0])).or(s_reference);
                let s = m.locate(section(q), s_near).clamp(s0, s1);
                [umap.v_of(s).clamp(u_lo, u_hi), height(q).clamp(h0, h1)]
            }),
        })
    }

    /// A plane as the bilinear patch over its boundary's box.
    pub(super) fn plane_patch(&self, face: u64, f: Frame, coarse: &[Vec<V3>]) -> Result<Patch> {
        let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
        for q in coarse.iter().flatten() {
            let r = q - f.o;
            for (k, a) in [f.x, f.y].iter().enumerate() {
                lo[k] = lo[k].min(r.dot(a));
                hi[k] = hi[k].max(r.dot(a));
            }
        }
        if !(hi[0] > lo[0] && hi[1] > lo[1]) {
            return Err(self.err(face, "has a boundary of no extent on its plane"));
        }

        // The patch is the boundary's box: a loop on the domain's
        // edges is on the face (the face is closed).
        let at = |x: f64, y: f64| {
            let p = f.o + f.x * x + f.y * y;
            [p.x, p.y, p.z]
        };
        Ok(Patch {
            surface: SurfaceFile {
                kind: "nurbs".into(),
                name: None,
                degree_u: 1,
                degree_v: 1,
                knots_u: vec![lo[0], lo[0], hi[0], hi[0]],
                knots_v: vec![lo[1], lo[1], hi[1], hi[1]],
                control_points: vec![
                    vec![at(lo[0], lo[1]), at(lo[0], hi[1])],
                    vec![at(hi[0], lo[1]), at(hi[0], hi[1])],
                ],
                weights: None,
                trim: None,
            },
            to_uv: Box::new(move |q: &V3, _| {
                let r = q - f.o;
                [
                    r.dot(&f.x).clamp(lo[0], hi[0]),
                    r.dot(&f.y).clamp(lo[1], hi[1]),
                ]
            }),
        })
    }

    /// The meridian of a surface of revolution as a NURBS over [s0, s1]:
    /// degree, knots, (rho, h) points with weights, the map between its
    /// parameter and the meridian's, and the s range it spans (a B-spline
    /// meridian spans its whole curve).
    pub(super) fn meridian_profile(
        &self,
        face: u64,
        m: &Meridian,
        what: &str,
        (s0, s1): (f64, f64),
    ) -> Result<MeridianProfile> {
        Ok(match m {
            Meridian::Line { p, d } => {
                let at = |s: f64| ProfilePoint {
                    q: [p[0] + d[0] * s, p[1] + d[1] * s],
                    w: 1.0,
                };
                MeridianProfile {
                    degree: 1,
                    knots: vec![s0, s0, s1, s1],
                    points: vec![at(s0), at(s1)],
                    map: VMap::Same,
                    range: (s0, s1),
                }
            }
            Meridian::Conic { c, a, b } => {
                if s1 - s0 > TAU + 1e-6 {
                    return Err(self.err(
                        face,
                        format!(
                            "winds round the meridian of its {what} more than once: not supported"
                        ),
                    ));
                }
                let va = Arcs::new(s0, s1.min(s0 + TAU));
                let w = (0.5 * va.delta).cos();
                let pts = (0..=2 * va.n)
                    .map(|i| {
                        let phi = va.theta0 + va.delta * i as f64 / 2.0;
                        let (k, wt) = if i % 2 == 1 { (1.0 / w, w) } else { (1.0, 1.0) };
                        let (cs, sn) = (phi.cos() * k, phi.sin() * k);
                        ProfilePoint {
                            q: [c[0] + a[0] * cs + b[0] * sn, c[1] + a[1] * cs + b[1] * sn],
                            w: wt,
                        }
                    })
                    .collect();
                MeridianProfile {
                    degree: 2,
                    knots: arc_knots(va.n),
                    points: pts,
                    map: VMap::Arcs(va),
                    range: (s0, s1),
                }
            }
            Meridian::Bspline(Curve::Bspline {
                degree,
                knots,
                points,
            }) => {
                // The whole curve; its range bounds s.
                let range = (knots[*degree], knots[knots.len() - degree - 1]);
                let pts = points
                    .iter()
                    .map(|h| ProfilePoint {
                        q: [h[0] / h[3], h[1] / h[3]],
                        w: h[3],
                    })
                    .collect();
                MeridianProfile {
                    degree: *degree,
                    knots: knots.clone(),
                    points: pts,
                    map: VMap::Same,
                    range,
                }
            }
            Meridian::Bspline(_) => return Err(self.err(face, "has a malformed meridian")),
        })
    }

    /// A surface of revolution as the exact rational patch over the angles
    /// and the meridian range its boundary spans (at most one turn): the
    /// circle's rational quadratic arcs of at most 90 degrees in u times the
    /// meridian's NURBS in v, control point (i, j) at the meridian's point j
    /// turned to the arc's point i, weight the product of theirs
    /// (docs/formats.md, "STEP import").
    /// A boundary point on the axis (a pole, an apex) takes the angle of
    /// the loop's previous point, so a loop through a pole runs along the
    /// patch's collapsed edge there.
    pub(super) fn revolved_patch(
        &self,
        face: u64,
        f: Frame,
        m: Meridian,
        what: &str,
        coarse: &[Vec<V3>],
    ) -> Result<Patch> {
        let size = coarse
            .iter()
            .flatten()
            .map(|q| (q - f.o).norm())
            .fold(1.0, f64::max);
        let on_axis = 1e-9 * size;
        let meridian = move |q: &V3| -> [f64; 2] {
            let d = q - f.o;
            let h = d.dot(&f.z);
            [(d - f.z * h).norm(), h]
        };
        let angle = move |q: &V3| -> Option<f64> {
            let d = q - f.o;
            let (x, y) = (d.dot(&f.x), d.dot(&f.y));
            (x.hypot(y) > on_axis).then(|| y.atan2(x))
        };
        let e = self.revolved_extent(face, &m, what, coarse, &meridian, &angle)?;
        let (t0, t1) = e.angles;
        let arcs = Arcs::new(t0, t1);
        let MeridianProfile {
            degree: degree_v,
            knots: knots_v,
            points: profile,
            map: vmap,
            range: (s0, s1),
        } = self.meridian_profile(face, &m, what, e.meridian)?;
        if profile.iter().any(|p| p.q[0] < -on_axis) {
            return Err(self.err(
                face,
                format!("lies on a part of its {what} that crosses its axis: not supported"),
            ));
        }
        let w = (0.5 * arcs.delta).cos();
        let mut rows = Vec::new();
        let mut wrows = Vec::new();
        for i in 0..=2 * arcs.n {
            let th = t0 + arcs.delta * i as f64 / 2.0;
            let (k, wa) = if i % 2 == 1 { (1.0 / w, w) } else { (1.0, 1.0) };
            let dir = (f.x * th.cos() + f.y * th.sin()) * k;
            rows.push(
                profile
                    .iter()
                    .map(|pp| {
                        let p = f.o + dir * pp.q[0] + f.z * pp.q[1];
                        [p.x, p.y, p.z]
                    })
                    .collect(),
            );
            wrows.push(profile.iter().map(|pp| wa * pp.w).collect());
        }
        let (v_lo, v_hi) = (vmap.v_of(s0), vmap.v_of(s1));
        let (reference, s_reference) = (e.angle_reference, e.meridian_reference);
        Ok(Patch {
            surface: SurfaceFile {
                kind: "nurbs".into(),
                name: None,
                degree_u: 2,
                degree_v,
                knots_u: arc_knots(arcs.n),
                knots_v,
                control_points: rows,
                weights: Some(wrows),
                trim: None,
            },
            to_uv: Box::new(move |q: &V3, seed: Option<[f64; 2]>| {
                let near = seed
                    .map(|s| arcs.theta_of(s[0]))
                    .or(reference)
                    .unwrap_or(t0);
                let t = angle(q).map_or(near, |t| t + TAU * ((near - t) / TAU).round());
                let s_near = seed.map(|s| vmap.s_of(s[1])).or(s_reference);
                let s = m.locate(meridian(q), s_near).clamp(s0, s1);
                [arcs.u_of(t.clamp(t0, t1)), vmap.v_of(s).clamp(v_lo, v_hi)]
            }),
        })
    }

    /// The angle and meridian ranges a revolved face's boundary spans
    /// (`coarse`: its loops' samples; `meridian`: a point's (rho, h);
    /// `angle`: its angle about the axis, none on the axis), each angle
    /// unwrapped next to the loop's previous one. A loop that winds round
    /// the axis, or a face over more than one turn, is refused.
    fn revolved_extent(
        &self,
        face: u64,
        m: &Meridian,
        what: &str,
        coarse: &[Vec<V3>],
        meridian: &dyn Fn(&V3) -> [f64; 2],
        angle: &dyn Fn(&V3) -> Option<f64>,
    ) -> Result<RevolvedExtent> {
        let (mut t0, mut t1) = (f64::INFINITY, f64::NEG_INFINITY);
        let (mut s0, mut s1) = (f64::INFINITY, f64::NEG_INFINITY);
        let (mut reference, mut s_reference) = (None, None);
        for l in coarse {
            let (mut prev, mut s_prev): (Option<f64>, Option<f64>) = (None, None);
            let mut first = None;
            for q in l {
                if let Some(mut t) = angle(q) {
                    if let Some(p) = prev.or(reference) {
                        t += TAU * ((p - t) / TAU).round();
                    }
                    reference.get_or_insert(t);
                    first.get_or_insert(t);
                    prev = Some(t);
                    t0 = t0.min(t);
                    t1 = t1.max(t);
                }
                let s = m.locate(meridian(q), s_prev.or(s_reference));
                s_reference.get_or_insert(s);
                s_prev = Some(s);
                s0 = s0.min(s);
                s1 = s1.max(s);
            }
            if let (Some(a), Some(b)) = (first, prev) {
                if (b - a).abs() > PI {
                    return Err(self.err(
                        face,
                        format!("has a loop that winds round the axis of its {what} (a face closed round a pole or a band without a seam edge): not supported"),
                    ));
                }
            }
        }
        if !(t1 > t0 && s1 > s0) {
            return Err(self.err(face, format!("has a boundary of no extent on its {what}")));
        }
        if t1 - t0 > TAU + 1e-6 {
            return Err(self.err(
                face,
                format!("winds round its {what} more than once: not supported"),
            ));
        }
        Ok(RevolvedExtent {
            angles: (t0, t1.min(t0 + TAU)),
            meridian: (s0, s1),
            angle_reference: reference,
            meridian_reference: s_reference,
        })
    }
}

/// What [`StepFile::revolved_extent`] finds: the ranges of angle and
/// meridian parameter, and the first boundary point's values (the seeds
/// of points without a previous one).
struct RevolvedExtent {
    angles: (f64, f64),
    meridian: (f64, f64),
    angle_reference: Option<f64>,
    meridian_reference: Option<f64>,
}

/// A meridian (or an extrusion's section) as a NURBS curve in the 2-D
/// plane of its frame, as [`StepFile::meridian_profile`] gives it.
pub(super) struct MeridianProfile {
    pub(super) degree: usize,
    pub(super) knots: Vec<f64>,
    pub(super) points: Vec<ProfilePoint>,
    /// The map between the profile's parameter and the meridian's.
    pub(super) map: VMap,
    /// The meridian parameter range the profile spans.
    pub(super) range: (f64, f64),
}

/// A control point of a [`MeridianProfile`]: (rho, h) (or the section's
/// two coordinates) and its weight.
#[derive(Clone, Copy)]
pub(super) struct ProfilePoint {
    pub(super) q: [f64; 2],
    pub(super) w: f64,
}

/// The map from a 3-D point near a patch (with an optional nearby (u, v)
/// seed) to the patch's (u, v).
pub(super) type ToUv = Box<dyn Fn(&V3, Option<[f64; 2]>) -> [f64; 2]>;

/// A face's NURBS patch and the map of its boundary points to (u, v).
pub(super) struct Patch {
    pub(super) surface: SurfaceFile,
    pub(super) to_uv: ToUv,
}

/// A B-spline surface is its own patch; points map by closest-point inversion.
pub(super) fn bspline_patch(s: SurfaceFile) -> Result<Patch> {
    let n = s.to_surface()?;
    Ok(Patch {
        surface: s,
        to_uv: Box::new(move |q: &V3, seed: Option<[f64; 2]>| {
            let c = match seed {
                Some(sd) => closest_point_near(&n, &Point3::from(*q), Vector2::new(sd[0], sd[1])),
                None => closest_point(&n, &Point3::from(*q)),
            };
            [c.uv.x, c.uv.y]
        }),
    })
}
