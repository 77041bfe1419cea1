//! Time parameterisation of a joint-space waypoint path.
//!
//! Each segment gets the shortest duration that keeps the tool at or below its
//! Cartesian speed (the feed on cutting moves) and every joint at or below its
//! velocity limit. Waypoint velocities are the mean of the adjacent segment
//! velocities, zero at stops (path ends, retracts). Acceleration, measured as
//! the change of waypoint velocity over a segment, is then brought under the
//! limits by lengthening the offending segments, and so are the peaks of the
//! cubic a trajectory controller interpolates between waypoints (it overshoots
//! the mean velocity by up to 1.5 times between two stops); a final uniform
//! time scaling guarantees the bounds (it scales velocities by 1/k and
//! accelerations by 1/k^2).

use super::axes::Axis;

/// One segment's speed cap: mm/s of tool motion, or `None` (rapid: joints only).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Segment {
    /// Cartesian length of the segment, mm.
    pub length: f64,
    pub max_speed: Option<f64>,
}

/// A timed trajectory: times (s, strictly increasing), positions and velocities
/// per waypoint (mm, rad, per second).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Timed {
    pub times: Vec<f64>,
    pub positions: Vec<Vec<f64>>,
    pub velocities: Vec<Vec<f64>>,
}

/// Shortest segment time, s: also keeps equal consecutive waypoints apart.
const MIN_DT: f64 = 1e-4;

fn waypoint_velocities(q: &[Vec<f64>], dt: &[f64], stops: &[bool]) -> Vec<Vec<f64>> {
    (0..q.len())
        .map(|k| waypoint_velocity(q, dt, stops, k))
        .collect()
}

/// Velocity of every joint at waypoint `k`: the mean of its two segments'
/// velocities, zero at a stop or an end.
fn waypoint_velocity(q: &[Vec<f64>], dt: &[f64], stops: &[bool], k: usize) -> Vec<f64> {
    let n = q.len();
    let joints = q.first().map_or(0, |p| p.len());
    let seg_v = |k: usize, j: usize| (q[k + 1][j] - q[k][j]) / dt[k];
    (0..joints)
        .map(|j| {
            if stops[k] || k == 0 || k + 1 == n {
                0.0
            } else {
                0.5 * (seg_v(k - 1, j) + seg_v(k, j))
            }
        })
        .collect()
}

/// Peak |velocity| and |acceleration| of the cubic Hermite a trajectory
/// controller interpolates between (q0, v0) and (q1, v1) over `dt`:
/// velocity v0 + b s + c s^2 on s in [0, 1], acceleration linear in s, so
/// largest at an end.
pub fn hermite_peaks(q0: f64, q1: f64, v0: f64, v1: f64, dt: f64) -> (f64, f64) {
    let m = (q1 - q0) / dt;
    let b = 6.0 * m - 4.0 * v0 - 2.0 * v1;
    let c = 3.0 * v0 + 3.0 * v1 - 6.0 * m;
    let mut peak = v0.abs().max(v1.abs());
    if c != 0.0 {
        let s = -b / (2.0 * c);
        if s > 0.0 && s < 1.0 {
            peak = peak.max((v0 + b * s + c * s * s).abs());
        }
    }
    (peak, b.abs().max((b + 2.0 * c).abs()) / dt)
}

/// Largest ratio over all segments and joints of acceleration to its limit,
/// or of velocity to its limit squared (stretching a segment by k divides
/// velocities by k and accelerations by about k^2), for the change of
/// waypoint velocity and for the cubic the controller interpolates.
fn worst_acceleration(
    q: &[Vec<f64>],
    v: &[Vec<f64>],
    dt: &[f64],
    limits: &[Axis],
) -> (f64, Vec<f64>) {
    let per_segment: Vec<f64> = (0..dt.len())
        .map(|k| segment_ratio(q, v, dt, limits, k))
        .collect();
    (worst_of(&per_segment), per_segment)
}

fn worst_of(per_segment: &[f64]) -> f64 {
    per_segment.iter().fold(0.0, |w, &r| w.max(r))
}

/// [`worst_acceleration`]'s ratio of segment `k` (waypoints k and k + 1).
fn segment_ratio(q: &[Vec<f64>], v: &[Vec<f64>], dt: &[f64], limits: &[Axis], k: usize) -> f64 {
    let d = dt[k];
    limits
        .iter()
        .enumerate()
        .map(|(j, l)| {
            let fd = (v[k + 1][j] - v[k][j]).abs() / (l.max_acceleration * d);
            let (vp, ap) = hermite_peaks(q[k][j], q[k + 1][j], v[k][j], v[k + 1][j], d);
            fd.max(ap / l.max_acceleration)
                .max((vp / l.max_velocity).powi(2))
        })
        .fold(0.0, f64::max)
}

/// Lengthens the segments over their limits (by the square root of their
/// ratio, at most twice) and updates what depends on them: the velocities of
/// their end waypoints, and the ratios of the segments sharing those
/// waypoints. Everything else keeps its value, so the result is the one a
/// full recomputation gives.
fn stretch_over_limit(
    q: &[Vec<f64>],
    v: &mut [Vec<f64>],
    dt: &mut [f64],
    stops: &[bool],
    limits: &[Axis],
    per_segment: &mut [f64],
) {
    let over: Vec<usize> = (0..dt.len()).filter(|&k| per_segment[k] > 1.0).collect();
    for &k in &over {
        dt[k] *= per_segment[k].sqrt().min(2.0);
    }
    for &k in &over {
        v[k] = waypoint_velocity(q, dt, stops, k);
        v[k + 1] = waypoint_velocity(q, dt, stops, k + 1);
    }
    let last = dt.len() - 1;
    let mut next = 0;
    for &k in &over {
        let first = k.saturating_sub(1).max(next);
        let end = (k + 1).min(last);
        for (s, r) in per_segment.iter_mut().enumerate().take(end + 1).skip(first) {
            *r = segment_ratio(q, v, dt, limits, s);
        }
        next = next.max(end + 1);
    }
}

/// Each segment's first duration: the longer of its Cartesian feed time and
/// the slowest joint's time at its velocity limit, at least [`MIN_DT`].
fn initial_durations(q: &[Vec<f64>], segments: &[Segment], limits: &[Axis]) -> Vec<f64> {
    segments
        .iter()
        .enumerate()
        .map(|(k, s)| {
            let cart = s.max_speed.map_or(0.0, |f| s.length / f);
            let joint = limits
                .iter()
                .enumerate()
                .map(|(j, l)| (q[k + 1][j] - q[k][j]).abs() / l.max_velocity)
                .fold(0.0, f64::max);
            cart.max(joint).max(MIN_DT)
        })
        .collect()
}

/// Times the path `q` (one row of joint values per waypoint). `segments[k]`
/// joins waypoints k and k + 1; `stops[k]` forces zero velocity at waypoint k.
pub fn parameterise(
    q: Vec<Vec<f64>>,
    segments: &[Segment],
    stops: &[bool],
    limits: &[Axis],
) -> Timed {
    let n = q.len();
    if n == 0 {
        return Timed::default();
    }
    let mut dt = initial_durations(&q, segments, limits);
    let mut v = waypoint_velocities(&q, &dt, stops);
    let (mut worst, mut per_segment) = worst_acceleration(&q, &v, &dt, limits);
    for _ in 0..60 {
        if worst <= 1.0 {
            break;
        }
        stretch_over_limit(&q, &mut v, &mut dt, stops, limits, &mut per_segment);
        worst = worst_of(&per_segment);
    }
    if worst > 1.0 {
        // Stretching time by k divides velocities by k and accelerations by k^2.
        let k = worst.sqrt() * (1.0 + 1e-9);
        dt.iter_mut().for_each(|d| *d *= k);
        v = waypoint_velocities(&q, &dt, stops);
    }
    let mut times = Vec::with_capacity(n);
    let mut t = 0.0;
    times.push(t);
    for d in &dt {
        t += d;
        times.push(t);
    }
    Timed {
        times,
        positions: q,
        velocities: v,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn limit(name: &'static str, v: f64, a: f64) -> Axis {
        Axis {
            name: name.to_string(),
            rotary: false,
            min: -1e9,
            max: 1e9,
            max_velocity: v,
            max_acceleration: a,
            max_jerk: None,
        }
    }

    #[test]
    fn straight_feed_move_runs_at_the_feed_rate() {
        // 101 points 1 mm apart along X, feed 10 mm/s, generous joint limits.
        let q: Vec<Vec<f64>> = (0..=100).map(|k| vec![k as f64, 0.0]).collect();
        let segs = vec![
            Segment {
                length: 1.0,
                max_speed: Some(10.0)
            };
            100
        ];
        let mut stops = vec![false; 101];
        stops[0] = true;
        stops[100] = true;
        let limits = [limit("X", 1000.0, 1e6), limit("Y", 1000.0, 1e6)];
        let t = parameterise(q, &segs, &stops, &limits);
        assert!((t.times[100] - 10.0).abs() < 1e-9, "{}", t.times[100]);
        assert!((t.velocities[50][0] - 10.0).abs() < 1e-9);
        assert_eq!(t.velocities[0][0], 0.0);
    }

    #[test]
    fn joint_limits_hold_and_time_increases() {
        // A zig-zag with sharp reversals in Y: acceleration-limited.
        let q: Vec<Vec<f64>> = (0..200)
            .map(|k| vec![k as f64 * 0.5, if k % 2 == 0 { 0.0 } else { 3.0 }])
            .collect();
        let segs: Vec<Segment> = q
            .windows(2)
            .map(|w| Segment {
                length: (w[1][0] - w[0][0]).hypot(w[1][1] - w[0][1]),
                max_speed: Some(50.0),
            })
            .collect();
        let mut stops = vec![false; 200];
        stops[0] = true;
        stops[199] = true;
        let limits = [limit("X", 20.0, 100.0), limit("Y", 40.0, 200.0)];
        let t = parameterise(q.clone(), &segs, &stops, &limits);
        for k in 1..t.times.len() {
            let dt = t.times[k] - t.times[k - 1];
            assert!(dt > 0.0);
            for (j, l) in limits.iter().enumerate() {
                // Independent checks from the output alone.
                let mean_v = (q[k][j] - q[k - 1][j]) / dt;
                assert!(mean_v.abs() <= l.max_velocity * (1.0 + 1e-9));
                assert!(t.velocities[k][j].abs() <= l.max_velocity * (1.0 + 1e-9));
                let acc = (t.velocities[k][j] - t.velocities[k - 1][j]) / dt;
                assert!(
                    acc.abs() <= l.max_acceleration * (1.0 + 1e-6),
                    "k {k} j {j} acc {acc}"
                );
            }
            let speed = segs[k - 1].length / dt;
            assert!(speed <= 50.0 * (1.0 + 1e-9));
        }
    }

    /// The timing with every velocity and ratio recomputed in every round:
    /// the incremental update must give the same bits.
    fn parameterise_recomputing_all(
        q: &[Vec<f64>],
        segments: &[Segment],
        stops: &[bool],
        limits: &[Axis],
    ) -> (Vec<f64>, Vec<Vec<f64>>) {
        let mut dt = initial_durations(q, segments, limits);
        let mut v = waypoint_velocities(q, &dt, stops);
        for _ in 0..60 {
            let (worst, per_segment) = worst_acceleration(q, &v, &dt, limits);
            if worst <= 1.0 {
                break;
            }
            for (d, r) in dt.iter_mut().zip(&per_segment) {
                if *r > 1.0 {
                    *d *= r.sqrt().min(2.0);
                }
            }
            v = waypoint_velocities(q, &dt, stops);
        }
        let (worst, _) = worst_acceleration(q, &v, &dt, limits);
        if worst > 1.0 {
            let k = worst.sqrt() * (1.0 + 1e-9);
            dt.iter_mut().for_each(|d| *d *= k);
            v = waypoint_velocities(q, &dt, stops);
        }
        (dt, v)
    }

    #[test]
    fn incremental_stretching_matches_full_recomputation_bit_for_bit() {
        // An irregular 3-joint path: steps of varying size, sharp and mild
        // turns, a stop in the middle, tight and loose limits.
        let q: Vec<Vec<f64>> = (0..300)
            .map(|k| {
                let t = k as f64;
                vec![
                    0.7 * t + (0.37 * t).sin() * 4.0,
                    if k % 7 < 3 { 0.0 } else { 2.5 } + 0.01 * t,
                    (0.05 * t).cos() * 0.4,
                ]
            })
            .collect();
        let segs: Vec<Segment> = q
            .windows(2)
            .enumerate()
            .map(|(k, w)| Segment {
                length: (w[1][0] - w[0][0]).hypot(w[1][1] - w[0][1]),
                max_speed: (k % 50 != 49).then_some(40.0),
            })
            .collect();
        let mut stops = vec![false; q.len()];
        stops[0] = true;
        stops[150] = true;
        stops[299] = true;
        let limits = [
            limit("X", 20.0, 100.0),
            limit("Y", 40.0, 150.0),
            limit("A", 2.0, 5.0),
        ];
        let t = parameterise(q.clone(), &segs, &stops, &limits);
        let (dt, v) = parameterise_recomputing_all(&q, &segs, &stops, &limits);
        assert!(
            dt.iter().any(|&d| d > 0.1),
            "the limits must stretch some segments"
        );
        let times: Vec<f64> = std::iter::once(0.0)
            .chain(dt.iter().scan(0.0, |t, d| {
                *t += d;
                Some(*t)
            }))
            .collect();
        assert_eq!(t.times, times);
        assert_eq!(t.velocities, v);
    }
}
