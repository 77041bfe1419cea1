//! The numerical inverse kinematics: Levenberg-Marquardt on the pose error,
//! joints held inside their limits by projection, started from the caller's
//! seed and then from a fixed low-discrepancy set of joint vectors (so the
//! same input gives the same answer).
//!
//! The residual is the position error (mm) and the rotation error scaled by
//! a length (mm per rad), so one tolerance weighs both; for a 5-axis target
//! the rotation part is the tool axis' error only, leaving the rotation about
//! it (and any redundancy) to the smallest step from the seed.

use crate::chain::JointKind;
use crate::machine::Machine;
use crate::pose::{pose_error, tool_axis_of, Target};
use nalgebra::{DMatrix, DVector, Isometry3};

/// The weighted residual (target - reached) and its Jacobian.
fn residual(
    m: &Machine,
    q: &[f64],
    target: &Target,
    scale: f64,
) -> (DVector<f64>, DMatrix<f64>, Isometry3<f64>) {
    let (t, j) = m.rel.jacobian(q);
    let n = q.len();
    let mut r = DVector::zeros(6);
    let mut jw = DMatrix::zeros(6, n);
    let dp = target.tip().coords - t.translation.vector;
    for k in 0..3 {
        r[k] = dp[k];
        for c in 0..n {
            jw[(k, c)] = j[(k, c)];
        }
    }
    match target {
        Target::Frame(f) => {
            let e = (f.rotation * t.rotation.inverse()).scaled_axis();
            for k in 0..3 {
                r[3 + k] = scale * e[k];
                for c in 0..n {
                    jw[(3 + k, c)] = scale * j[(3 + k, c)];
                }
            }
        }
        Target::Axis { axis, .. } => {
            let a = tool_axis_of(&t);
            let e = axis.into_inner() - a;
            for c in 0..n {
                let w = nalgebra::Vector3::new(j[(3, c)], j[(4, c)], j[(5, c)]);
                let da = w.cross(&a);
                for k in 0..3 {
                    jw[(3 + k, c)] = scale * da[k];
                }
            }
            for k in 0..3 {
                r[3 + k] = scale * e[k];
            }
        }
    }
    (r, jw, t)
}

/// Extra damping of a joint near a limit (0 beyond the last tenth of its
/// travel, growing as the inverse square towards the limit), so that a
/// redundant arm moves its other joints instead of pressing on the stop.
fn limit_weight(m: &Machine, j: usize, x: f64) -> f64 {
    let l = &m.limits[j];
    let zone = 0.1 * l.travel();
    if !zone.is_finite() {
        return 0.0;
    }
    let d = (x - l.lower).min(l.upper - x).max(zone * 1e-3);
    if d >= zone {
        0.0
    } else {
        (zone / d).powi(2) - 1.0
    }
}

fn clamp_to_limits(m: &Machine, q: &mut [f64]) {
    for (x, l) in q.iter_mut().zip(&m.limits) {
        *x = x.clamp(l.lower, l.upper);
    }
}

/// Levenberg-Marquardt from `seed`, joints kept inside their limits; the
/// joints and whether they reproduce `target` within the machine's tolerances.
pub fn solve_from(
    m: &Machine,
    target: &Target,
    seed: &[f64],
    iterations: usize,
) -> (Vec<f64>, bool) {
    lm(m, target, seed, iterations, true)
}

/// The same without the limits (to polish a closed-form solution before it
/// is fitted into the limits by whole turns).
pub fn solve_from_unclamped(
    m: &Machine,
    target: &Target,
    seed: &[f64],
    iterations: usize,
) -> (Vec<f64>, bool) {
    lm(m, target, seed, iterations, false)
}

fn lm(
    m: &Machine,
    target: &Target,
    seed: &[f64],
    iterations: usize,
    clamp: bool,
) -> (Vec<f64>, bool) {
    let scale = length_scale(m);
    let mut q = seed.to_vec();
    if clamp {
        clamp_to_limits(m, &mut q);
    }
    let (mut r, mut j, mut t) = residual(m, &q, target, scale);
    let mut cost = r.norm_squared();
    let mut lambda = 1e-3;
    let n = q.len();
    for _ in 0..iterations {
        let (dp, da) = pose_error(&t, target);
        if dp <= m.options.tol_position * 0.01 && da <= m.options.tol_rotation * 0.01 {
            break;
        }
        let jt = j.transpose();
        let a = &jt * &j;
        let g = &jt * &r;
        let mut accepted = false;
        while lambda < 1e12 {
            let mut damped = a.clone();
            for k in 0..n {
                damped[(k, k)] += lambda * (a[(k, k)] + 1e-6) * (1.0 + limit_weight(m, k, q[k]));
            }
            let Some(step) = damped.cholesky().map(|c| c.solve(&g)) else {
                lambda *= 10.0;
                continue;
            };
            let mut trial: Vec<f64> = q.iter().zip(step.iter()).map(|(x, d)| x + d).collect();
            if clamp {
                clamp_to_limits(m, &mut trial);
            }
            let (r2, j2, t2) = residual(m, &trial, target, scale);
            let c2 = r2.norm_squared();
            if c2 < cost {
                (q, r, j, t, cost) = (trial, r2, j2, t2, c2);
                lambda = (lambda / 3.0).max(1e-12);
                accepted = true;
                break;
            }
            lambda *= 4.0;
        }
        if !accepted {
            break;
        }
    }
    let (dp, da) = pose_error(&t, target);
    let ok = dp <= m.options.tol_position && da <= m.options.tol_rotation;
    (q, ok)
}

/// Millimetres per radian in the residual: the machine's size, so that a
/// rotation error moves a point at arm's length by about as much.
pub fn length_scale(m: &Machine) -> f64 {
    let mut s = 0.0;
    for e in &m.rel.elements {
        if let crate::relchain::Element::Fixed(f) = e {
            s += f.translation.vector.norm();
        }
    }
    s.clamp(100.0, 5000.0)
}

/// The k-th point of the Halton sequence in base `b`.
fn halton(mut k: usize, b: usize) -> f64 {
    let (mut f, mut r) = (1.0, 0.0);
    while k > 0 {
        f /= b as f64;
        r += f * (k % b) as f64;
        k /= b;
    }
    r
}

const PRIMES: [usize; 12] = [2, 3, 5, 7, 11, 13, 17, 19, 23, 29, 31, 37];

/// The machine's fixed starting points: Halton points over each joint's
/// travel (a continuous joint over one turn, an unlimited slide over +-1 m).
pub fn seeds(m: &Machine, count: usize) -> Vec<Vec<f64>> {
    (1..=count)
        .map(|k| {
            m.limits
                .iter()
                .zip(&m.kinds)
                .enumerate()
                .map(|(j, (l, kind))| {
                    let (lo, hi) = match (l.lower.is_finite() && l.upper.is_finite(), kind) {
                        (true, _) => (l.lower, l.upper),
                        (false, JointKind::Prismatic) => (-1000.0, 1000.0),
                        (false, _) => (-std::f64::consts::PI, std::f64::consts::PI),
                    };
                    lo + (hi - lo) * halton(k, PRIMES[j % PRIMES.len()])
                })
                .collect()
        })
        .collect()
}

/// Every distinct solution found from `first` (if given) and the fixed seeds.
pub fn solve_all(m: &Machine, target: &Target, first: Option<&[f64]>) -> Vec<Vec<f64>> {
    let mut out: Vec<Vec<f64>> = Vec::new();
    let starts = first
        .map(|f| f.to_vec())
        .into_iter()
        .chain(seeds(m, m.options.seeds));
    for s in starts {
        let (q, ok) = solve_from(m, target, &s, m.options.max_iterations);
        if ok && !out.iter().any(|o| same_joints(m, o, &q)) {
            out.push(q);
        }
    }
    out
}

/// Whether two joint vectors are the same configuration (rotary joints mod
/// a whole turn).
pub fn same_joints(m: &Machine, a: &[f64], b: &[f64]) -> bool {
    close_joints(m, a, b, 1e-6)
}

/// The same with a looser tolerance (a polished solution against its start).
pub fn same_joints_loose(m: &Machine, a: &[f64], b: &[f64]) -> bool {
    close_joints(m, a, b, 1e-4)
}

fn close_joints(m: &Machine, a: &[f64], b: &[f64], tol: f64) -> bool {
    a.iter().zip(b).zip(&m.kinds).all(|((x, y), k)| {
        let d = if k.is_rotary() {
            crate::angles::wrap(x - y)
        } else {
            x - y
        };
        d.abs() < tol
    })
}
