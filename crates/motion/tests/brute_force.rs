//! Seeded random paths timed against an independent optimum: the classic
//! forward-backward integration of the maximum acceleration and deceleration
//! (Bobrow; Shin and McKay) under the maximum-velocity curve, on a grid 50
//! times finer, with each stage's bound found by bisection rather than by
//! any linear program.

use toolpath_motion::spline::Spline;
use toolpath_motion::{
    parameterise, plan, Limits, Options, Parameter, Path, Segment, SegmentKind, Tips,
};

struct Rng(u64);

impl Rng {
    fn next(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// The joints' (q', q'') at s.
fn derivs(sp: &Spline, s: f64) -> Vec<(f64, f64)> {
    let k = sp.interval(s);
    (0..sp.dim())
        .map(|j| {
            let jet = sp.jet_in(k, j, s);
            (jet.d1, jet.d2)
        })
        .collect()
}

/// The range of s_ddot allowed at (s, x), or None.
fn u_range(d: &[(f64, f64)], acc: &[f64], x: f64) -> Option<(f64, f64)> {
    let (mut lo, mut hi) = (f64::NEG_INFINITY, f64::INFINITY);
    for (&(d1, d2), &a) in d.iter().zip(acc) {
        // -a <= d2 x + d1 u <= a
        if d1.abs() < 1e-14 {
            if (d2 * x).abs() > a {
                return None;
            }
            continue;
        }
        let (u1, u2) = ((-a - d2 * x) / d1, (a - d2 * x) / d1);
        lo = lo.max(u1.min(u2));
        hi = hi.min(u1.max(u2));
    }
    (lo <= hi).then_some((lo, hi))
}

/// Largest x in [0, top] with `ok(x)`, by bisection (ok monotone).
fn bisect(top: f64, ok: impl Fn(f64) -> bool) -> f64 {
    if ok(top) {
        return top;
    }
    let (mut lo, mut hi) = (0.0, top);
    for _ in 0..80 {
        let mid = 0.5 * (lo + hi);
        if ok(mid) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    lo
}

/// The independent optimum's duration over the spline from rest to rest.
fn forward_backward(sp: &Spline, vel: &[f64], acc: &[f64], m: usize) -> f64 {
    let knots = sp.knots();
    let (a, b) = (knots[0], knots[knots.len() - 1]);
    let s: Vec<f64> = (0..=m).map(|i| a + (b - a) * i as f64 / m as f64).collect();
    let d: Vec<Vec<(f64, f64)>> = s.iter().map(|&si| derivs(sp, si)).collect();
    let mvc: Vec<f64> = d
        .iter()
        .map(|di| {
            let v = di
                .iter()
                .zip(vel)
                .filter(|((d1, _), _)| *d1 != 0.0)
                .map(|((d1, _), v)| (v / d1).powi(2))
                .fold(f64::INFINITY, f64::min);
            bisect(v.min(1e12), |x| u_range(di, acc, x).is_some())
        })
        .collect();
    let h = (b - a) / m as f64;
    let mut back = vec![0.0; m + 1];
    for i in (0..m).rev() {
        // Largest x_i from which the hardest braking reaches <= back[i + 1].
        back[i] = bisect(mvc[i], |x| {
            u_range(&d[i], acc, x).is_some_and(|(lo, _)| x + 2.0 * h * lo <= back[i + 1])
        });
    }
    let mut x = vec![0.0; m + 1];
    for i in 0..m {
        let up = u_range(&d[i], acc, x[i]).map_or(0.0, |(_, hi)| hi);
        x[i + 1] = (x[i] + 2.0 * h * up).min(back[i + 1]).max(0.0);
    }
    (0..m)
        .map(|i| 2.0 * h / (x[i].sqrt() + x[i + 1].sqrt()))
        .sum()
}

#[test]
fn random_paths_are_timed_near_an_independent_optimum_within_their_limits() {
    let mut rng = Rng(2024);
    let mut ratios = Vec::new();
    for case in 0..12 {
        let joints = 2 + case % 4;
        let n = 4 + (rng.next() * 12.0) as usize;
        let mut q = vec![vec![0.0; joints]];
        for k in 1..n {
            let row = (0..joints)
                .map(|j| q[k - 1][j] + (rng.next() - 0.3) * 20.0)
                .collect();
            q.push(row);
        }
        let vel: Vec<f64> = (0..joints).map(|_| 20.0 + 80.0 * rng.next()).collect();
        let acc: Vec<f64> = (0..joints).map(|_| 50.0 + 400.0 * rng.next()).collect();
        let limits = Limits::new(vel.clone(), acc.clone());
        let segs = vec![
            Segment {
                kind: SegmentKind::Link,
                tip_speed_cap: None
            };
            n - 1
        ];
        let param = Parameter::ScaledJointChord;
        let p = Path {
            positions: &q,
            segments: &segs,
            stops: &[],
            tips: Tips::None,
            parameter: &param,
        };
        let options = Options {
            min_intervals: 400,
            ..Options::default()
        };
        let timing = parameterise(&p, &limits, &options).unwrap();
        let ours = timing.duration();
        let s: &[f64] = &timing.s;
        let sp = Spline::new(s, &q);
        let best = forward_backward(&sp, &vel, &acc, 20_000);
        let ratio = ours / best;
        ratios.push(ratio);
        assert!(
            ratio > 0.995 && ratio < 1.01,
            "case {case}: ours {ours} vs {best}"
        );
        let pl = plan(&p, &limits, &options, None).unwrap();
        let r = &pl.report.kinds[&SegmentKind::Link];
        assert!(
            r.max_velocity_ratio <= 1.0 && r.max_acceleration_ratio <= 1.0,
            "case {case}: {r:?}"
        );
        let sent = pl.trajectory.duration();
        assert!(sent / best < 1.02, "case {case}: sent {sent} vs {best}");
    }
    let mean = ratios.iter().sum::<f64>() / ratios.len() as f64;
    assert!(mean < 1.005, "{ratios:?}");
}
