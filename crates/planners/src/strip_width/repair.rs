//! Rest finishing of the islands a verified plan leaves above the scallop
//! height (docs/methods.md, "Repair passes"). The pipeline simulates a
//! flat-end plan, groups the surface samples still above h (or not reached)
//! into islands, and asks for passes over each: straight-heading passes on
//! the surface through the island, along its long axis when it is a ridge
//! (the scallop between two passes, cut by one pass along it) and otherwise
//! along the local best feed direction, spaced across the island by
//! 0.8 of the local strip width, each with its run-in and run-out
//! ([`extend_pass`]). The pipeline re-checks and repeats a bounded number of
//! rounds.

use super::field::feed_at;
use super::pass_ends::extend_pass;
use super::passes::{walk_on_surface, Contact, PassSettings};
use super::width::curvatures_along;
use nalgebra::{Matrix2, SymmetricEigen, Vector2, Vector3};
use toolpath_formats::{Job, Pass};
use toolpath_kernel::error::Result;
use toolpath_kernel::geometry::{LocalGeometry, NurbsSurface};

/// Share of the local strip width between neighbouring repair passes.
const SPACING_SHARE: f64 = 0.8;
/// Share of the local strip width one repair pass is counted on to cover
/// across an island.
const REACH_SHARE: f64 = 0.95;
/// An island longer than this many times its width (and at least
/// [`RIDGE_MIN_SAMPLES`] samples) is a ridge: its passes run along it.
const RIDGE_ELONGATION: f64 = 2.0;
const RIDGE_MIN_SAMPLES: usize = 4;

/// Surface samples (uv) of one island, with the sampling spacing, mm.
#[derive(Clone, Debug)]
pub struct Island {
    pub uv: Vec<Vector2<f64>>,
    pub spacing_mm: f64,
}

/// Repair passes over `islands`, each pass tagged with `region`. Islands
/// where no pass can be posed (the cutter would gouge, the surface is
/// singular) get none; the pipeline then reports them.
pub fn repair_passes(job: &Job, islands: &[Island], region: usize) -> Result<Vec<Pass>> {
    let surface = job.surface()?;
    let s = PassSettings::from_job(job)?;
    let mut out = Vec::new();
    for island in islands {
        out.extend(island_passes(surface, &s, island, region));
    }
    // On a trimmed face, repair passes keep to it like the plan's own.
    let reach = crate::trim_clip::reach(job.tool()?);
    Ok(crate::trim_clip::clip_passes(surface, &out, reach))
}

fn island_passes(
    surface: &NurbsSurface,
    s: &PassSettings,
    island: &Island,
    region: usize,
) -> Vec<Pass> {
    let Some(centre_uv) = island_centre(island) else {
        return Vec::new();
    };
    let Some(g) = LocalGeometry::at(surface, centre_uv.x, centre_uv.y) else {
        return Vec::new();
    };
    let extent = island_extent(surface, s, &g, island);
    let Ok(w) = s
        .cutter
        .strip_width(s.scallop, curvatures_along(&g.forms, extent.feed))
    else {
        return Vec::new();
    };
    let (feed, cross) = (extent.feed, extent.cross);
    let mut passes = Vec::new();
    for (k, offset) in pass_offsets(extent.across, w).into_iter().enumerate() {
        let forward = k % 2 == 0;
        let heading = if forward { feed } else { -feed };
        if let Some(points) = straight_pass(
            surface,
            s,
            centre_uv,
            cross,
            offset,
            heading,
            forward,
            extent.along,
        ) {
            let mut pass = Pass {
                region,
                points,
                min_strip_width: None,
            };
            if extend_pass(surface, &mut pass.points, s).is_ok() {
                passes.push(pass);
            }
        }
    }
    passes
}

/// The island's sample nearest the mean of its samples, so the centre lies
/// on the island; `None` for an empty island.
fn island_centre(island: &Island) -> Option<Vector2<f64>> {
    if island.uv.is_empty() {
        return None;
    }
    let mean = island.uv.iter().sum::<Vector2<f64>>() / island.uv.len() as f64;
    Some(
        island
            .uv
            .iter()
            .copied()
            .min_by(|a, b| (a - mean).norm().total_cmp(&(b - mean).norm()))
            .unwrap_or(mean),
    )
}

/// An island in the tangent plane at its centre: the feed of its passes,
/// the cross direction, its extent along the feed (from the centre) and
/// across it, each padded by half a sample spacing (the island's true
/// extent around its samples).
struct Extent {
    feed: Vector3<f64>,
    cross: Vector3<f64>,
    along: (f64, f64),
    across: (f64, f64),
}

/// The island's [`Extent`] at the geometry `g` of its centre: the feed
/// runs along the island's long axis when it is a ridge (elongated past
/// [`RIDGE_ELONGATION`]), else along the local best feed direction.
fn island_extent(
    surface: &NurbsSurface,
    s: &PassSettings,
    g: &LocalGeometry,
    island: &Island,
) -> Extent {
    let c = g.point();
    let e1 = g
        .forms
        .derivs
        .su
        .try_normalize(1e-300)
        .unwrap_or(Vector3::x());
    let e1 = (e1 - g.forms.n * e1.dot(&g.forms.n)).normalize();
    let e2 = g.forms.n.cross(&e1);
    let plane: Vec<Vector2<f64>> = island
        .uv
        .iter()
        .map(|uv| {
            let d = surface.point(uv.x, uv.y) - c;
            Vector2::new(d.dot(&e1), d.dot(&e2))
        })
        .collect();
    let mean = plane.iter().sum::<Vector2<f64>>() / plane.len() as f64;
    let mut cov = Matrix2::zeros();
    for p in &plane {
        let d = p - mean;
        cov += d * d.transpose();
    }
    let eig = SymmetricEigen::new(cov / plane.len() as f64);
    let (big, small) = if eig.eigenvalues[0] >= eig.eigenvalues[1] {
        (0, 1)
    } else {
        (1, 0)
    };
    let axis = eig.eigenvectors.column(big).into_owned();
    let ridge = island.uv.len() >= RIDGE_MIN_SAMPLES
        && eig.eigenvalues[big]
            > RIDGE_ELONGATION.powi(2) * eig.eigenvalues[small].max(0.0)
                + (0.5 * island.spacing_mm).powi(2);
    let feed = if ridge {
        e1 * axis.x + e2 * axis.y
    } else {
        match feed_at(g, s.cutter.k_b()) {
            Some(f) => f.feed,
            None => g.dir_min,
        }
    };
    let cross = g.forms.n.cross(&feed);
    let (mut a0, mut a1, mut b0, mut b1) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
    for p in &plane {
        let q = e1 * p.x + e2 * p.y;
        let (a, b) = (q.dot(&feed), q.dot(&cross));
        a0 = a0.min(a);
        a1 = a1.max(a);
        b0 = b0.min(b);
        b1 = b1.max(b);
    }
    let pad = 0.5 * island.spacing_mm;
    Extent {
        feed,
        cross,
        along: (a0 - pad, a1 + pad),
        across: (b0 - pad, b1 + pad),
    }
}

/// The offsets across the feed of an island's passes, for strips `w` mm
/// wide: one pass's strip (less a margin) covers an island up to its
/// width; wider islands get passes from edge to edge, no further apart
/// than the spacing share of the strip width. Outside the island the
/// material is already within h.
fn pass_offsets((b0, b1): (f64, f64), w: f64) -> Vec<f64> {
    let across = b1 - b0;
    let reach = REACH_SHARE * w;
    let count = if across <= reach {
        1
    } else {
        ((across - reach) / (SPACING_SHARE * w)).ceil() as usize + 1
    };
    (0..count)
        .map(|k| {
            if count == 1 {
                0.5 * (b0 + b1)
            } else {
                let first = b0 + 0.5 * reach;
                let last = b1 - 0.5 * reach;
                first + (last - first) * k as f64 / (count - 1) as f64
            }
        })
        .collect()
}

/// The pass `offset` mm across (along `cross`) from `centre`, heading
/// `heading` (+feed when `forward`) over the island's extent a0..a1 along
/// +feed, sampled every point step; `None` where a pose would gouge.
#[allow(clippy::too_many_arguments)]
fn straight_pass(
    surface: &NurbsSurface,
    s: &PassSettings,
    centre: Vector2<f64>,
    cross: Vector3<f64>,
    offset: f64,
    heading: Vector3<f64>,
    forward: bool,
    (a0, a1): (f64, f64),
) -> Option<Vec<toolpath_formats::PathPoint>> {
    let (mid, _, _) = if offset.abs() > 1e-9 {
        walk_on_surface(surface, centre, cross * offset.signum(), offset.abs())?
    } else {
        (centre, cross, false)
    };
    // From the middle of the island back to where the pass starts: the
    // island spans a0..a1 along +feed; heading along -feed starts at a1.
    let start_len = if forward { -a0 } else { a1 };
    let length = a1 - a0;
    let (start, dir, _) = walk_on_surface(surface, mid, -heading, start_len.max(1e-6))?;
    let mut dir = -dir;
    let mut uv = start;
    let steps = ((length / s.point_step).ceil() as usize).max(1);
    let step = length / steps as f64;
    let mut points = Vec::with_capacity(steps + 1);
    for k in 0..=steps {
        let c = Contact::new(surface, uv, dir)?;
        points.push(c.path_point(s).ok()?);
        if k == steps {
            break;
        }
        let (next, d, hit) = walk_on_surface(surface, uv, dir, step)?;
        if hit {
            let c = Contact::new(surface, next, d)?;
            points.push(c.path_point(s).ok()?);
            break;
        }
        uv = next;
        dir = d;
    }
    Some(points)
}
