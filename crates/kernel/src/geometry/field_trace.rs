//! Tracing a curve on a surface along a direction field given in parameter
//! space (principal directions, the feed field of a planner, ...;
//! docs/methods.md, "Field lines").
//!
//! The curve is integrated in surface arc length s: d(u, v)/ds = t / |S_u t_u + S_v t_v|
//! for the field's direction t, with the Dormand-Prince 5(4) Runge-Kutta pair and
//! step-size control on the local error measured in mm on the surface.
//! Line fields (no orientation, such as principal directions) are made
//! sign-consistent: every stage's direction is flipped to agree with the
//! heading at the start of the step. Tracing stops exactly on the domain
//! boundary (the step is shortened by regula falsi until the end point lies on
//! it), at the requested length, or where the field is undefined.

use super::differential::LocalGeometry;
use super::nurbs::NurbsSurface;
use nalgebra::{Vector2, Vector3};

/// Why a trace ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TraceStop {
    /// Reached the boundary of the parameter domain (the last point lies on it).
    Boundary,
    /// Reached `max_length`.
    MaxLength,
    /// The field returned `None` (umbilic, singular point) closer than `min_step` ahead.
    FieldUndefined,
    /// The error control needed a step below `min_step` (field turning too fast).
    StepTooSmall,
    /// `max_points` reached.
    MaxPoints,
    /// The caller's stop predicate held at the last point.
    Stopped,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TraceOptions {
    /// Stop after this arc length, mm.
    pub max_length: f64,
    /// Local error per step, mm.
    pub tolerance: f64,
    /// First trial step, mm.
    pub initial_step: f64,
    /// Longest step (also the longest gap between output points), mm.
    pub max_step: f64,
    /// Shortest step before giving up, mm.
    pub min_step: f64,
    /// `true` for a vector field (keep its sign), `false` for a line field.
    pub oriented: bool,
    pub max_points: usize,
}

impl Default for TraceOptions {
    fn default() -> Self {
        Self {
            max_length: 1e4,
            tolerance: 1e-5,
            initial_step: 0.5,
            max_step: 2.0,
            min_step: 1e-7,
            oriented: false,
            max_points: 1_000_000,
        }
    }
}

/// A traced curve: matching parameter and space polylines.
#[derive(Clone, Debug, PartialEq)]
pub struct Trace {
    pub uv: Vec<[f64; 2]>,
    pub xyz: Vec<[f64; 3]>,
    /// Integrated arc length, mm (the polyline's chords are slightly shorter).
    pub length: f64,
    pub stop: TraceStop,
}

// Dormand-Prince 5(4) coefficients (the field does not depend on s, so the nodes c_i are not needed).
const A: [[f64; 6]; 7] = [
    [0.0; 6],
    [0.2, 0.0, 0.0, 0.0, 0.0, 0.0],
    [3.0 / 40.0, 9.0 / 40.0, 0.0, 0.0, 0.0, 0.0],
    [44.0 / 45.0, -56.0 / 15.0, 32.0 / 9.0, 0.0, 0.0, 0.0],
    [
        19372.0 / 6561.0,
        -25360.0 / 2187.0,
        64448.0 / 6561.0,
        -212.0 / 729.0,
        0.0,
        0.0,
    ],
    [
        9017.0 / 3168.0,
        -355.0 / 33.0,
        46732.0 / 5247.0,
        49.0 / 176.0,
        -5103.0 / 18656.0,
        0.0,
    ],
    [
        35.0 / 384.0,
        0.0,
        500.0 / 1113.0,
        125.0 / 192.0,
        -2187.0 / 6784.0,
        11.0 / 84.0,
    ],
];
const B5: [f64; 7] = [
    35.0 / 384.0,
    0.0,
    500.0 / 1113.0,
    125.0 / 192.0,
    -2187.0 / 6784.0,
    11.0 / 84.0,
    0.0,
];
const B4: [f64; 7] = [
    5179.0 / 57600.0,
    0.0,
    7571.0 / 16695.0,
    393.0 / 640.0,
    -92097.0 / 339200.0,
    187.0 / 2100.0,
    1.0 / 40.0,
];

struct Tracer<'a, F> {
    surface: &'a NurbsSurface,
    field: F,
    oriented: bool,
    lo: Vector2<f64>,
    hi: Vector2<f64>,
}

enum Step {
    Ok { x: Vector2<f64>, err_mm: f64 },
    Undefined,
}

impl<F: Fn(Vector2<f64>) -> Option<Vector2<f64>>> Tracer<'_, F> {
    fn clamp(&self, x: Vector2<f64>) -> Vector2<f64> {
        Vector2::new(
            x.x.clamp(self.lo.x, self.hi.x),
            x.y.clamp(self.lo.y, self.hi.y),
        )
    }

    /// Unit-speed parameter velocity at `x`, sign-matched to `heading` for line fields.
    fn velocity(
        &self,
        x: Vector2<f64>,
        heading: &Vector3<f64>,
    ) -> Option<(Vector2<f64>, Vector3<f64>)> {
        let x = self.clamp(x);
        let t = (self.field)(x)?;
        let d = self.surface.first_derivs(x.x, x.y);
        let t3 = d.su * t.x + d.sv * t.y;
        let len = t3.norm();
        if !(len.is_finite() && len > 1e-300) {
            return None;
        }
        let (mut vel, mut dir) = (t / len, t3 / len);
        if !self.oriented && dir.dot(heading) < 0.0 {
            vel = -vel;
            dir = -dir;
        }
        Some((vel, dir))
    }

    fn step(&self, x: Vector2<f64>, heading: &Vector3<f64>, h: f64) -> Step {
        let mut k = [Vector2::zeros(); 7];
        for s in 0..7 {
            let mut xs = x;
            for (j, kj) in k.iter().enumerate().take(s) {
                xs += *kj * (h * A[s][j]);
            }
            match self.velocity(xs, heading) {
                Some((v, _)) => k[s] = v,
                None => return Step::Undefined,
            }
        }
        let mut x5 = x;
        let mut e = Vector2::zeros();
        for s in 0..7 {
            x5 += k[s] * (h * B5[s]);
            e += k[s] * (h * (B5[s] - B4[s]));
        }
        let d = self.surface.first_derivs(x.x, x.y);
        let err_mm = (d.su * e.x + d.sv * e.y).norm();
        Step::Ok { x: x5, err_mm }
    }

    /// How far outside the domain `x` is, relative to the domain size (<= 0 inside).
    fn outside(&self, x: Vector2<f64>) -> f64 {
        let span = self.hi - self.lo;
        [
            (self.lo.x - x.x) / span.x,
            (x.x - self.hi.x) / span.x,
            (self.lo.y - x.y) / span.y,
            (x.y - self.hi.y) / span.y,
        ]
        .into_iter()
        .fold(f64::NEG_INFINITY, f64::max)
    }
}

/// Traces from `start` along `field` (a parameter-space direction at each
/// (u, v), `None` where undefined). `direction` (parameter space) picks the
/// sense of travel for a line field, and is ignored for oriented fields except
/// as a fallback. Points are step ends, at most `max_step` apart.
pub fn trace_field<F>(
    surface: &NurbsSurface,
    field: F,
    start: Vector2<f64>,
    direction: Vector2<f64>,
    options: &TraceOptions,
) -> Trace
where
    F: Fn(Vector2<f64>) -> Option<Vector2<f64>>,
{
    trace_field_until(surface, field, start, direction, options, &|_, _| false)
}

/// As [`trace_field`], also ending (with [`TraceStop::Stopped`]) at the first
/// step end where `stop(uv, xyz)` holds; that point is the last of the trace.
pub fn trace_field_until<F>(
    surface: &NurbsSurface,
    field: F,
    start: Vector2<f64>,
    direction: Vector2<f64>,
    options: &TraceOptions,
    stop: &dyn Fn(Vector2<f64>, &nalgebra::Point3<f64>) -> bool,
) -> Trace
where
    F: Fn(Vector2<f64>) -> Option<Vector2<f64>>,
{
    let ((u0, u1), (v0, v1)) = surface.domain();
    let tracer = Tracer {
        surface,
        field,
        oriented: options.oriented,
        lo: Vector2::new(u0, v0),
        hi: Vector2::new(u1, v1),
    };
    let mut x = tracer.clamp(start);
    let p0 = surface.point(x.x, x.y);
    let mut out = Trace {
        uv: vec![[x.x, x.y]],
        xyz: vec![[p0.x, p0.y, p0.z]],
        length: 0.0,
        stop: TraceStop::MaxLength,
    };
    let d0 = surface.first_derivs(x.x, x.y);
    let mut heading = (d0.su * direction.x + d0.sv * direction.y)
        .try_normalize(1e-300)
        .unwrap_or_else(Vector3::zeros);
    match tracer.velocity(x, &heading) {
        Some((_, dir)) => heading = dir,
        None => {
            out.stop = TraceStop::FieldUndefined;
            return out;
        }
    }
    let max_step = options.max_step.max(options.min_step);
    let mut h = options.initial_step.clamp(options.min_step, max_step);
    loop {
        let remaining = options.max_length - out.length;
        if remaining <= 1e-12 * options.max_length.max(1.0) {
            out.stop = TraceStop::MaxLength;
            return out;
        }
        if out.uv.len() >= options.max_points {
            out.stop = TraceStop::MaxPoints;
            return out;
        }
        let last_step = h >= remaining;
        h = h.min(remaining);
        let (x_new, h_taken, grow) = match attempt(&tracer, x, &heading, h, options) {
            Attempt::Accept { x, h, grow } => (x, h, grow),
            Attempt::Retry(shorter) => {
                h = shorter;
                continue;
            }
            Attempt::Stop(stop) => {
                out.stop = stop;
                return out;
            }
        };
        // Leaving the domain: shorten the step so that it ends on the boundary.
        let (x_acc, h_acc, at_boundary) = if tracer.outside(x_new) > 0.0 {
            match shorten_to_boundary(&tracer, x, &heading, h_taken, x_new) {
                Some((xb, hb)) => (xb, hb, true),
                None => {
                    out.stop = TraceStop::FieldUndefined;
                    return out;
                }
            }
        } else {
            (x_new, h_taken, false)
        };
        x = x_acc;
        out.length += h_acc;
        let p = surface.point(x.x, x.y);
        out.uv.push([x.x, x.y]);
        out.xyz.push([p.x, p.y, p.z]);
        if at_boundary {
            out.stop = TraceStop::Boundary;
            return out;
        }
        if stop(x, &p) {
            out.stop = TraceStop::Stopped;
            return out;
        }
        if last_step && h_acc >= remaining {
            out.stop = TraceStop::MaxLength;
            return out;
        }
        if let Some((_, dir)) = tracer.velocity(x, &heading) {
            heading = dir;
        }
        h = (h_taken * grow).min(max_step);
    }
}

/// What one try of a step of length h gives.
enum Attempt {
    /// The step's end, its length, and the factor for the next step.
    Accept { x: Vector2<f64>, h: f64, grow: f64 },
    /// Try again with this shorter step.
    Retry(f64),
    /// The trace ends here.
    Stop(TraceStop),
}

/// One try of a step of length `h` from `x` along `heading`: accepted when
/// its error estimate is within the tolerance (the next step grown by the
/// fifth-order rule, at most 5 times), else shortened by the same rule (a
/// field undefined along the step halves it), down to the minimum step.
fn attempt<F: Fn(Vector2<f64>) -> Option<Vector2<f64>>>(
    tracer: &Tracer<'_, F>,
    x: Vector2<f64>,
    heading: &Vector3<f64>,
    mut h: f64,
    options: &TraceOptions,
) -> Attempt {
    let (x_new, h_taken, err) = match tracer.step(x, heading, h) {
        Step::Undefined => {
            h *= 0.5;
            if h < options.min_step {
                return Attempt::Stop(TraceStop::FieldUndefined);
            }
            return Attempt::Retry(h);
        }
        Step::Ok { x: xn, err_mm } => (xn, h, err_mm),
    };
    let tol = options.tolerance.max(1e-15);
    if err > tol {
        h *= (0.9 * (tol / err).powf(0.2)).clamp(0.1, 0.9);
        if h < options.min_step {
            return Attempt::Stop(TraceStop::StepTooSmall);
        }
        return Attempt::Retry(h);
    }
    let grow = if err > 0.0 {
        (0.9 * (tol / err).powf(0.2)).clamp(1.0, 5.0)
    } else {
        5.0
    };
    Attempt::Accept {
        x: x_new,
        h: h_taken,
        grow,
    }
}

/// Regula falsi on the step length so that the step ends on the boundary.
fn shorten_to_boundary<F: Fn(Vector2<f64>) -> Option<Vector2<f64>>>(
    tracer: &Tracer<'_, F>,
    x: Vector2<f64>,
    heading: &Vector3<f64>,
    h_out: f64,
    x_out: Vector2<f64>,
) -> Option<(Vector2<f64>, f64)> {
    let (mut a, mut ga) = (0.0, tracer.outside(x).min(0.0));
    let (mut b, mut gb) = (h_out, tracer.outside(x_out));
    let mut xb = x_out;
    let mut side = 0;
    for _ in 0..60 {
        let mut c = if gb != ga {
            (a * gb - b * ga) / (gb - ga)
        } else {
            0.5 * (a + b)
        };
        if !(c > a && c < b) {
            c = 0.5 * (a + b);
        }
        let xc = match tracer.step(x, heading, c) {
            Step::Ok { x, .. } => x,
            Step::Undefined => return None,
        };
        let gc = tracer.outside(xc);
        if gc.abs() <= 1e-13 || b - a <= 1e-15 * h_out {
            xb = xc;
            b = c;
            break;
        }
        if gc > 0.0 {
            b = c;
            gb = gc;
            xb = xc;
            if side == -1 {
                ga *= 0.5;
            }
            side = -1;
        } else {
            a = c;
            ga = gc;
            if side == 1 {
                gb *= 0.5;
            }
            side = 1;
        }
    }
    // Snap onto the boundary (the residual is at rounding level).
    let span = tracer.hi - tracer.lo;
    let mut x = tracer.clamp(xb);
    let snap = |t: f64, lo: f64, hi: f64, span: f64| {
        if (t - lo).abs() <= 1e-12 * span {
            lo
        } else if (hi - t).abs() <= 1e-12 * span {
            hi
        } else {
            t
        }
    };
    x.x = snap(x.x, tracer.lo.x, tracer.hi.x, span.x);
    x.y = snap(x.y, tracer.lo.y, tracer.hi.y, span.y);
    Some((x, b))
}

/// Which principal direction a field follows.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Principal {
    /// Direction of the minimum normal curvature.
    Min,
    /// Direction of the maximum normal curvature.
    Max,
}

/// The principal-direction line field of `surface` in parameter space, undefined
/// (`None`) where |k_max - k_min| <= `umbilic_tol` (1/mm) or the surface is singular.
pub fn principal_field(
    surface: &NurbsSurface,
    which: Principal,
    umbilic_tol: f64,
) -> impl Fn(Vector2<f64>) -> Option<Vector2<f64>> + '_ {
    move |x| {
        let g = LocalGeometry::at(surface, x.x, x.y)?;
        if g.is_umbilic(umbilic_tol) {
            return None;
        }
        Some(match which {
            Principal::Min => g.dir_min_uv,
            Principal::Max => g.dir_max_uv,
        })
    }
}
