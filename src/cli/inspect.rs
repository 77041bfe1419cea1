use serde_json::json;
use std::path::Path;
use toolpath_formats::{self as formats, Shape};
use toolpath_kernel::error::{Error, Result};
use toolpath_kernel::geometry::LocalGeometry;

/// Curvature difference (1/mm) below which a point counts as umbilic.
pub const UMBILIC_TOL: f64 = 1e-7;

pub fn run(path: &Path, u: f64, v: f64) -> Result<()> {
    let surface = match formats::read_shape(path)? {
        Shape::Surface(s) => s,
        Shape::Pocket(_) => {
            return Err(Error::invalid(
                "kind",
                "inspect needs a NURBS surface, got a pocket",
            ))
        }
    };
    for (name, x) in [("u", u), ("v", v)] {
        if !x.is_finite() {
            return Err(Error::invalid(
                format!("--uv {name}"),
                "is not a finite number",
            ));
        }
    }
    let ((u0, u1), (v0, v1)) = surface.domain();
    if u < u0 || u > u1 || v < v0 || v > v1 {
        return Err(Error::invalid(
            "--uv",
            format!("({u}, {v}) is outside the parameter domain [{u0}, {u1}] x [{v0}, {v1}]"),
        ));
    }
    let g = LocalGeometry::at(&surface, u, v).ok_or_else(|| {
        Error::planning(format!(
            "the surface is singular at ({u}, {v}): S_u x S_v = 0"
        ))
    })?;
    let v3 = |x: nalgebra::Vector3<f64>| [x.x, x.y, x.z];
    let out = json!({
        "uv": [u, v],
        "point": [g.point().x, g.point().y, g.point().z],
        "normal": v3(g.forms.n),
        "k1": g.k_max,
        "k2": g.k_min,
        "k_max": g.k_max,
        "k_min": g.k_min,
        "dir_k1": v3(g.dir_max),
        "dir_k2": v3(g.dir_min),
        "mean_curvature": g.mean_curvature(),
        "gaussian_curvature": g.gaussian_curvature(),
        "first_fundamental_form": [[g.forms.first[(0, 0)], g.forms.first[(0, 1)]], [g.forms.first[(1, 0)], g.forms.first[(1, 1)]]],
        "second_fundamental_form": [[g.forms.second[(0, 0)], g.forms.second[(0, 1)]], [g.forms.second[(1, 0)], g.forms.second[(1, 1)]]],
        "umbilic": g.is_umbilic(UMBILIC_TOL),
    });
    formats::write_json(Path::new("-"), &out)
}
