//! Test surfaces for the strip-width planners: B-spline interpolation of a
//! function at the Greville abscissae (exact for polynomials within the
//! spline space, geometry/interpolation.rs), so that a surface can be given
//! any parametrisation and knot vector while its geometry stays known in
//! closed form.

use toolpath_kernel::geometry::interpolation::interpolate_surface;
use toolpath_kernel::geometry::NurbsSurface;

/// Interpolates `f(u, v)` with a B-spline surface of the given degrees and
/// clamped knot vectors.
pub fn fit(
    pu: usize,
    pv: usize,
    knots_u: Vec<f64>,
    knots_v: Vec<f64>,
    f: impl Fn(f64, f64) -> [f64; 3],
) -> NurbsSurface {
    interpolate_surface(f, pu, knots_u, pv, knots_v).expect("valid test surface")
}

/// Clamped knot vector of degree p on [0, 1] with the given interior knots.
pub fn clamped(p: usize, interior: &[f64]) -> Vec<f64> {
    let mut k = vec![0.0; p + 1];
    k.extend_from_slice(interior);
    k.extend(std::iter::repeat_n(1.0, p + 1));
    k
}

/// Monkey saddle z = 1e-5 (x^3 - 3 x y^2) on [-50, 50]^2 (docs/methods.md,
/// "Degenerate points"), moved by `offset` in xy, with x and y given by
/// monotone maps of u and v (`warp` = 0: linear). Non-uniform interior knots when `warp` != 0.
pub fn monkey_saddle(offset: [f64; 2], warp: f64) -> NurbsSurface {
    // x(u) = -50 + 100 (u + warp u (1 - u)): quadratic, monotone for |warp| < 1.
    let map = move |t: f64| -50.0 + 100.0 * (t + warp * t * (1.0 - t));
    let f = move |u: f64, v: f64| {
        let (x, y) = (map(u), map(v));
        [
            x + offset[0],
            y + offset[1],
            1e-5 * (x * x * x - 3.0 * x * y * y),
        ]
    };
    if warp == 0.0 {
        fit(3, 3, clamped(3, &[]), clamped(3, &[]), f)
    } else {
        // Degree 6 holds x^3 with quadratic x(u) exactly, on any knots.
        fit(
            6,
            6,
            clamped(6, &[0.13, 0.5, 0.71]),
            clamped(6, &[0.29, 0.41, 0.83]),
            f,
        )
    }
}

/// Plane z = 0 on [0, 100]^2 with a sheared, non-orthogonal parametrisation.
pub(crate) fn sheared_plane() -> NurbsSurface {
    fit(1, 1, clamped(1, &[]), clamped(1, &[]), |u, v| {
        [100.0 * u + 40.0 * v, 100.0 * v, 0.0]
    })
}

/// Elliptic paraboloid z = a x^2 + b y^2 (concave towards +z) with the
/// sheared parametrisation x = 60 (u + 0.7 v) - 30, y = 60 v - 30.
pub(crate) fn sheared_paraboloid(a: f64, b: f64) -> NurbsSurface {
    fit(2, 2, clamped(2, &[]), clamped(2, &[]), move |u, v| {
        let (x, y) = (60.0 * (u + 0.7 * v) - 30.0, 60.0 * v - 30.0);
        [x, y, a * x * x + b * y * y]
    })
}

/// A milling job on `surface` with a flat-end cutter.
pub fn job(
    surface: NurbsSurface,
    strategy: toolpath_formats::Strategy,
    radius: f64,
    lead_deg: f64,
    scallop: f64,
) -> toolpath_formats::Job {
    let tool = toolpath_kernel::tools::Tool::FlatEnd {
        radius,
        length: None,
    };
    let file = toolpath_formats::JobFile {
        scallop: Some(scallop),
        lead_angle_deg: Some(lead_deg),
        feed_rate: Some(1000.0),
        ..toolpath_formats::JobFile::new("test", strategy, Some(tool))
    };
    toolpath_formats::Job::new(file, toolpath_formats::Shape::Surface(surface))
        .expect("valid test job")
}

/// Concave half-cylinder of radius `r` about an axis along x at height r,
/// x in [0, length], as a rational quadratic surface (exact).
pub fn concave_cylinder(r: f64, length: f64) -> NurbsSurface {
    let w = std::f64::consts::FRAC_1_SQRT_2;
    // Arc from (y=-r, z=r) through the bottom (0, 0) to (r, r); inside faces +z.
    let arc = [
        ([-r, r], 1.0),
        ([-r, 0.0], w),
        ([0.0, 0.0], 1.0),
        ([r, 0.0], w),
        ([r, r], 1.0),
    ];
    let cps: Vec<Vec<[f64; 3]>> = (0..2)
        .map(|i| {
            arc.iter()
                .map(|(p, _)| [length * i as f64, p[0], p[1]])
                .collect()
        })
        .collect();
    let ws: Vec<Vec<f64>> = (0..2)
        .map(|_| arc.iter().map(|(_, w)| *w).collect())
        .collect();
    NurbsSurface::new(
        1,
        2,
        vec![0., 0., 1., 1.],
        vec![0., 0., 0., 0.5, 0.5, 1., 1., 1.],
        &cps,
        Some(&ws),
    )
    .expect("valid cylinder")
}
