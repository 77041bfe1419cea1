//! The path-length lower bound (docs/methods.md, "Path-length lower bound"):
//! the integral over the surface of dA / w_max, since each unit of path length
//! clears at most the widest strip at its contact.

use super::width::{gouge_error, max_strip_width, WidthError};
use toolpath_formats::Job;
use toolpath_kernel::error::Result;
use toolpath_kernel::geometry::{LocalGeometry, NurbsSurface};
use toolpath_kernel::tools::LeadCutter;

/// Gauss-Legendre nodes and weights on [0, 1], 3 points.
const GAUSS3: [(f64, f64); 3] = [
    (0.112_701_665_379_258_3, 5.0 / 18.0),
    (0.5, 8.0 / 18.0),
    (0.887_298_334_620_741_7, 5.0 / 18.0),
];

/// [`path_length_lower_bound`] of a milling job at its own scallop, on the
/// grid every strip-width planner reports it with.
pub fn job_path_length_lower_bound(
    job: &Job,
    surface: &NurbsSurface,
    cutter: &LeadCutter,
) -> Result<f64> {
    path_length_lower_bound(surface, cutter, job.scallop()?, crate::LOWER_BOUND_CELLS)
}

/// [`path_length_lower_bound`] at the scallop the flat-end strategies space
/// their passes for ([`super::passes::SCALLOP_MARGIN`] h): the floor of the
/// spacing rule itself. A plan spaced for 0.9 h cannot come much below it
/// (only by the narrow side's mean half-width in the coverage test), so a
/// target relative to another plan is reachable only above it
/// (docs/methods.md, "Path-length lower bound").
pub fn job_spacing_lower_bound(job: &Job) -> Result<f64> {
    path_length_lower_bound(
        job.surface()?,
        &super::width::cutter_of_job(job)?,
        job.scallop()? * super::passes::SCALLOP_MARGIN,
        crate::LOWER_BOUND_CELLS,
    )
}

/// Lower bound of the path length for scallop h: the integral over the
/// surface of dA / w_max(p). No set of passes can be shorter, since each unit
/// of length clears at most w_max of area. `cells` per parameter direction.
///
/// It depends only on its arguments, and jobs on one surface (a node's burst,
/// the strategies of `toolpath compare`) ask for the same one, so the last few
/// are kept: a repeated call returns the stored value, the same bits.
pub(crate) fn path_length_lower_bound(
    surface: &NurbsSurface,
    cutter: &LeadCutter,
    h: f64,
    cells: usize,
) -> Result<f64> {
    let key = |e: &CacheEntry| {
        e.cutter == (cutter.radius.to_bits(), cutter.lead.to_bits(), cutter.ball)
            && e.h == h.to_bits()
            && e.cells == cells
            && e.surface == *surface
    };
    if let Some(value) = cache()
        .lock()
        .ok()
        .and_then(|c| c.iter().find(|e| key(e)).map(|e| e.value))
    {
        return Ok(value);
    }
    let value = compute(surface, cutter, h, cells)?;
    if let Ok(mut c) = cache().lock() {
        if c.len() >= CACHE_ENTRIES {
            c.remove(0);
        }
        c.push(CacheEntry {
            surface: surface.clone(),
            cutter: (cutter.radius.to_bits(), cutter.lead.to_bits(), cutter.ball),
            h: h.to_bits(),
            cells,
            value,
        });
    }
    Ok(value)
}

/// Lower bounds kept (oldest dropped first).
const CACHE_ENTRIES: usize = 8;

struct CacheEntry {
    surface: NurbsSurface,
    cutter: (u64, u64, bool),
    h: u64,
    cells: usize,
    value: f64,
}

fn cache() -> &'static std::sync::Mutex<Vec<CacheEntry>> {
    static CACHE: std::sync::OnceLock<std::sync::Mutex<Vec<CacheEntry>>> =
        std::sync::OnceLock::new();
    CACHE.get_or_init(Default::default)
}

/// The integral: the cells' Gauss terms computed in parallel over rows of
/// cells, then summed in the fixed row-major order (the same bits on any
/// number of threads). The first gouge in that order is the error.
fn compute(surface: &NurbsSurface, cutter: &LeadCutter, h: f64, cells: usize) -> Result<f64> {
    let ((u0, u1), (v0, v1)) = surface.domain();
    let (du, dv) = ((u1 - u0) / cells as f64, (v1 - v0) / cells as f64);
    let rows: Vec<usize> = (0..cells).collect();
    if let Some(trim) = surface.trim() {
        // A trimmed face: the same integral over the face only (the
        // boundary cells by their subcells on the face).
        let terms = toolpath_kernel::parallel::map_chunks(&rows, 1, |rows| {
            let mut terms = Vec::new();
            let mut nodes = Vec::new();
            for &i in rows {
                for j in 0..cells {
                    nodes.clear();
                    let corner = (u0 + i as f64 * du, v0 + j as f64 * dv);
                    trim.cell_nodes(corner, (du, dv), &mut nodes);
                    for &(u, v, weight) in &nodes {
                        let Some(g) = LocalGeometry::at(surface, u, v) else {
                            continue;
                        };
                        match max_strip_width(cutter, h, &g) {
                            Ok((w, _)) => terms.push(Ok(weight * g.area_element() / w)),
                            Err(WidthError::Gouge { depth }) => {
                                terms.push(Err(gouge_error(cutter, [u, v], g.k_max, depth)));
                                return terms;
                            }
                        }
                    }
                }
            }
            terms
        });
        let mut total = 0.0;
        for term in terms.into_iter().flatten() {
            total += term?;
        }
        return Ok(total);
    }
    let terms = toolpath_kernel::parallel::map_chunks(&rows, 1, |rows| {
        let mut terms = Vec::with_capacity(rows.len() * cells * 9);
        for &i in rows {
            for j in 0..cells {
                for &(a, wa) in &GAUSS3 {
                    for &(b, wb) in &GAUSS3 {
                        let (u, v) = (u0 + (i as f64 + a) * du, v0 + (j as f64 + b) * dv);
                        let Some(g) = LocalGeometry::at(surface, u, v) else {
                            continue;
                        };
                        let w = match max_strip_width(cutter, h, &g) {
                            Ok((w, _)) => w,
                            Err(WidthError::Gouge { depth }) => {
                                terms.push(Err(gouge_error(cutter, [u, v], g.k_max, depth)));
                                return terms;
                            }
                        };
                        terms.push(Ok(wa * wb * du * dv * g.area_element() / w));
                    }
                }
            }
        }
        terms
    });
    let mut total = 0.0;
    for term in terms.into_iter().flatten() {
        total += term?;
    }
    Ok(total)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn flat() -> LeadCutter {
        LeadCutter {
            radius: 2.5,
            lead: 5f64.to_radians(),
            ball: false,
        }
    }

    #[test]
    fn lower_bound_of_a_plane_is_area_over_width() {
        let s = crate::test_surfaces::sheared_plane();
        let lb = path_length_lower_bound(&s, &flat(), 0.05, 8).unwrap();
        assert!((lb - 10000.0 / 3.18704).abs() / lb < 1e-3, "{lb}");
    }
}
