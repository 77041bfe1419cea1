//! The extreme residuals refined between the grid samples: compass search
//! in (u, v) from the grid's best local extrema.

use super::motion_index::Scratch;
use super::report::{RefinedPeak, ResidualMap};
use super::residual::Method;
use super::simulator::Simulator;

impl Simulator<'_> {
    /// Refines the grid's extreme residual (`sign` 1: max, -1: min) by compass
    /// search in (u, v) from its `starts` best local extrema, the starts in
    /// parallel; `None` if nothing is covered. Also the climbed extrema,
    /// most extreme first.
    pub(super) fn refine(
        &self,
        map: &ResidualMap,
        sign: f64,
        (du, dv): (f64, f64),
        starts: usize,
        method: Method,
    ) -> (Option<f64>, Vec<RefinedPeak>) {
        let (nu, nv) = (map.nu, map.nv);
        let value = |k: usize| {
            map.residual
                .get(k)
                .copied()
                .flatten()
                .filter(|_| map.on_face(k))
                .map(|r| sign * r)
        };
        let mut extrema: Vec<(f64, usize)> = Vec::new();
        for i in 0..nu {
            for j in 0..nv {
                let k = i * nv + j;
                let Some(r) = value(k) else { continue };
                let mut is_max = true;
                for di in -1i64..=1 {
                    for dj in -1i64..=1 {
                        let (a, b) = (i as i64 + di, j as i64 + dj);
                        if (di, dj) == (0, 0) || a < 0 || b < 0 || a >= nu as i64 || b >= nv as i64
                        {
                            continue;
                        }
                        if let Some(o) = value(a as usize * nv + b as usize) {
                            if o > r {
                                is_max = false;
                            }
                        }
                    }
                }
                if is_max {
                    extrema.push((r, k));
                }
            }
        }
        extrema.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
        let Some(grid_best) = extrema.first().map(|e| e.0) else {
            return (None, Vec::new());
        };
        if sign < 0.0 && grid_best <= 0.0 {
            // No gouge on the grid: nothing to refine.
            return (Some(-grid_best), Vec::new());
        }
        extrema.truncate(starts);
        let climbed: Vec<RefinedPeak> =
            toolpath_kernel::parallel::map_chunks(&extrema, 1, |start| {
                let mut scratch = Scratch::new(self.motions.len());
                start
                    .iter()
                    .map(|&(r0, k)| self.climb(map, k, r0, sign, (du, dv), &mut scratch, method))
                    .collect::<Vec<_>>()
            })
            .into_iter()
            .flatten()
            .collect();
        let best = climbed.iter().map(|p| p.residual).fold(grid_best, f64::max);
        // A start without a sample position has no place to report.
        let mut peaks: Vec<RefinedPeak> = climbed
            .into_iter()
            .filter(|p| p.uv.iter().all(|x| x.is_finite()))
            .map(|p| RefinedPeak {
                residual: sign * p.residual,
                ..p
            })
            .collect();
        peaks.sort_by(|a, b| (sign * b.residual).total_cmp(&(sign * a.residual)));
        (Some(sign * best), peaks)
    }

    /// Compass search in (u, v) for the largest `sign * residual` from grid
    /// sample `k` (the peak's residual is `sign *` the true one).
    #[allow(clippy::too_many_arguments)]
    pub(super) fn climb(
        &self,
        map: &ResidualMap,
        k: usize,
        r0: f64,
        sign: f64,
        (du, dv): (f64, f64),
        scratch: &mut Scratch,
        method: Method,
    ) -> RefinedPeak {
        let (Some(&[mut u, mut v]), Some(&xyz0)) = (map.uv.get(k), map.xyz.get(k)) else {
            return RefinedPeak {
                uv: [f64::NAN; 2],
                xyz: [f64::NAN; 3],
                residual: r0,
            };
        };
        let mut xyz = xyz0;
        let mut r = r0;
        let (mut su, mut sv) = (du, dv);
        for _ in 0..400 {
            if su < du * 1e-7 {
                break;
            }
            let mut moved = None;
            for (a, b) in [
                (1.0, 0.0),
                (-1.0, 0.0),
                (0.0, 1.0),
                (0.0, -1.0),
                (1.0, 1.0),
                (1.0, -1.0),
                (-1.0, 1.0),
                (-1.0, -1.0),
            ] {
                let (uu, vv) = self.surface.clamp_uv(u + a * su, v + b * sv);
                if !self.surface.in_face(uu, vv) {
                    continue;
                }
                let Some((p, n, _)) = self.sample(uu, vv) else {
                    continue;
                };
                if let Some(x) = self.residual_by(&p, &n, scratch, method) {
                    if sign * x > r && moved.is_none_or(|(m, _, _, _)| sign * x > m) {
                        moved = Some((sign * x, uu, vv, p));
                    }
                }
            }
            match moved {
                Some((x, uu, vv, p)) => {
                    r = x;
                    u = uu;
                    v = vv;
                    xyz = [p.x, p.y, p.z];
                }
                None => {
                    su *= 0.5;
                    sv *= 0.5;
                }
            }
        }
        RefinedPeak {
            uv: [u, v],
            xyz,
            residual: r,
        }
    }
}
