//! Rotary joint values modulo whole turns: wrapping, unwrapping next to a
//! previous value, and the whole-turn shift that brings a pass into a joint's
//! travel.

use std::f64::consts::PI;

pub const TURN: f64 = 2.0 * PI;

/// The value congruent to `x` (mod 2 pi) in (-pi, pi].
pub fn wrap(x: f64) -> f64 {
    let y = x - TURN * (x / TURN).round();
    if y <= -PI {
        y + TURN
    } else {
        y
    }
}

/// The value congruent to `x` (mod 2 pi) nearest to `reference`.
pub fn unwrap_near(x: f64, reference: f64) -> f64 {
    x + TURN * ((reference - x) / TURN).round()
}

/// The value congruent to `x` (mod 2 pi) inside `[lower, upper]` nearest to
/// `reference`, if one is.
pub fn representative_in(x: f64, lower: f64, upper: f64, reference: f64) -> Option<f64> {
    let near = unwrap_near(x, reference);
    if near >= lower && near <= upper {
        return Some(near);
    }
    // Below the range: step up by turns; above it: step down.
    let candidate = if near < lower {
        near + TURN * ((lower - near) / TURN).ceil()
    } else {
        near - TURN * ((near - upper) / TURN).ceil()
    };
    (candidate >= lower && candidate <= upper).then_some(candidate)
}

/// The whole-turn shift (a multiple of 2 pi, the one nearest to zero) that
/// brings every value of `values` into `[lower, upper]`, if one does.
pub fn turn_shift(values: impl Iterator<Item = f64>, lower: f64, upper: f64) -> Option<f64> {
    let (lo, hi) = values.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
        (a.min(v), b.max(v))
    });
    if lo > hi {
        return Some(0.0);
    }
    let k_lo = ((lower - lo) / TURN - 1e-12).ceil();
    let k_hi = ((upper - hi) / TURN + 1e-12).floor();
    (k_lo <= k_hi).then(|| TURN * k_lo.max(0.0).min(k_hi))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wrap_and_unwrap_agree_with_whole_turns() {
        assert_eq!(wrap(PI), PI);
        assert!((wrap(-PI) - PI).abs() < 1e-15);
        assert!((wrap(3.0 * PI + 0.5) - (-PI + 0.5)).abs() < 1e-12);
        assert!((unwrap_near(0.1, 12.0) - (0.1 + 2.0 * TURN)).abs() < 1e-12);
        assert!((unwrap_near(-3.0, 3.0) - (-3.0 + TURN)).abs() < 1e-12);
    }

    #[test]
    fn representatives_respect_the_range() {
        // 200 deg is outside +-180 and has no other representative there but -160.
        let x = 200f64.to_radians();
        let r = representative_in(x, -PI, PI, x).unwrap();
        assert!((r - (-160f64).to_radians()).abs() < 1e-12);
        // A range narrower than a turn may hold none.
        assert!(representative_in(100f64.to_radians(), -1.0, 1.0, 0.0).is_none());
        // A range of two turns holds two; the one nearer the reference wins.
        let r = representative_in(0.5, -TURN, TURN, -5.0).unwrap();
        assert!((r - (0.5 - TURN)).abs() < 1e-12);
    }

    #[test]
    fn turn_shift_prefers_no_shift_then_the_smallest() {
        let lim = 220f64.to_radians();
        assert_eq!(turn_shift([0.1, 0.2].into_iter(), -lim, lim), Some(0.0));
        let s = turn_shift([5.0, 5.2].into_iter(), -lim, lim).unwrap();
        assert!((s + TURN).abs() < 1e-12);
        assert!(turn_shift([0.0, 8.0].into_iter(), -lim, lim).is_none());
    }
}
