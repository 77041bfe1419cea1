//! Regions of the surface for the strip-width planners (docs/methods.md,
//! "The strip-width tensor and its degenerate points", "Partition at
//! trisectors"): the degenerate points of the feed field, classified, and the
//! partition of the parameter domain along the separatrices of trisectors.

pub(crate) mod degenerate_points;
pub(crate) mod merge;
pub(crate) mod partition;

pub(crate) use partition::polygon_area;
pub use partition::Region;

use nalgebra::Vector2;
use toolpath_kernel::geometry::NurbsSurface;

/// The parameter domain as one region.
pub fn whole_domain(surface: &NurbsSurface) -> Region {
    let ((u0, u1), (v0, v1)) = surface.domain();
    let boundary_uv = vec![
        Vector2::new(u0, v0),
        Vector2::new(u1, v0),
        Vector2::new(u1, v1),
        Vector2::new(u0, v1),
    ];
    Region {
        id: 0,
        area_mm2: polygon_area(surface, &boundary_uv, 48),
        boundary_uv,
    }
}
