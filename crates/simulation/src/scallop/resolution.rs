//! The grid's spacing: automatic (R/8, coarser on large surfaces) or the
//! job's, refused when it asks for too many samples; and the surface's
//! extent it is measured on.

use super::settings::{ScallopSettings, AUTO_MAX_SAMPLES, MAX_SAMPLES};
use toolpath_kernel::error::{Error, Result};
use toolpath_kernel::geometry::NurbsSurface;
use toolpath_kernel::tools::CutterShape;

/// Largest arc lengths of the u- and v-isolines (sampled), mm.
pub(super) fn extents(surface: &NurbsSurface) -> (f64, f64) {
    let ((u0, u1), (v0, v1)) = surface.domain();
    const LINES: usize = 9;
    const STEPS: usize = 64;
    let mut len_u: f64 = 0.0;
    let mut len_v: f64 = 0.0;
    for l in 0..LINES {
        let f = l as f64 / (LINES - 1) as f64;
        let (v, u) = (v0 + f * (v1 - v0), u0 + f * (u1 - u0));
        let mut a = 0.0;
        let mut b = 0.0;
        let mut pa = surface.point(u0, v);
        let mut pb = surface.point(u, v0);
        for s in 1..=STEPS {
            let g = s as f64 / STEPS as f64;
            let qa = surface.point(u0 + g * (u1 - u0), v);
            let qb = surface.point(u, v0 + g * (v1 - v0));
            a += (qa - pa).norm();
            b += (qb - pb).norm();
            pa = qa;
            pb = qb;
        }
        len_u = len_u.max(a);
        len_v = len_v.max(b);
    }
    (len_u, len_v)
}

/// Checks a job's `simulation_resolution` on `surface` before any work: the
/// grid it asks for must stay within [`MAX_SAMPLES`].
pub fn check_resolution(surface: &NurbsSurface, resolution_mm: Option<f64>) -> Result<()> {
    match resolution_mm {
        Some(r) => {
            let (len_u, len_v) = extents(surface);
            fixed_resolution(r, len_u, len_v).map(|_| ())
        }
        None => Ok(()),
    }
}

/// A given grid resolution `r` > 0, refused when its grid on a surface of
/// `len_u` x `len_v` mm exceeds [`MAX_SAMPLES`].
fn fixed_resolution(r: f64, len_u: f64, len_v: f64) -> Result<f64> {
    let n = (len_u / r).ceil().max(2.0) * (len_v / r).ceil().max(2.0);
    if n.is_nan() || n > MAX_SAMPLES as f64 {
        return Err(Error::invalid(
            "simulation_resolution",
            format!(
                "{r} mm needs {n:.0} samples on this {len_u:.1} x {len_v:.1} mm surface, more than the limit {MAX_SAMPLES}"
            ),
        ));
    }
    Ok(r)
}

pub(super) fn grid_resolution(
    settings: &ScallopSettings,
    cutter: &CutterShape,
    len_u: f64,
    len_v: f64,
) -> Result<f64> {
    let r = settings.resolution_mm;
    if r.is_nan() || r.is_infinite() {
        return Err(Error::invalid(
            "simulation_resolution",
            format!("{r} is not a finite number"),
        ));
    }
    let count = |res: f64| (len_u / res).ceil().max(2.0) * (len_v / res).ceil().max(2.0);
    if r > 0.0 {
        return fixed_resolution(r, len_u, len_v);
    }
    let mut res = cutter.radius / 8.0;
    let n = count(res);
    if n > AUTO_MAX_SAMPLES as f64 {
        res *= (n / AUTO_MAX_SAMPLES as f64).sqrt() * 1.01;
    }
    Ok(res)
}
