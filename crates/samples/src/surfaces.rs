//! Built-in sample surfaces. All have the parameter domain [0, 1]^2 and the
//! tool side (n = S_u x S_v) towards +z.

use toolpath_kernel::geometry::interpolation::interpolate_height_field;
use toolpath_kernel::geometry::NurbsSurface;

const BEZIER3: [f64; 8] = [0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 1.0];

fn built(s: toolpath_kernel::error::Result<NurbsSurface>) -> NurbsSurface {
    // The samples are fixed data; the sample tests build every one of them.
    s.expect("built-in sample is valid")
}

/// Flat 100 x 100 mm square at z = 0, bicubic.
pub fn plane() -> NurbsSurface {
    let cps: Vec<Vec<[f64; 3]>> = (0..4)
        .map(|i| {
            (0..4)
                .map(|j| [100.0 * i as f64 / 3.0, 100.0 * j as f64 / 3.0, 0.0])
                .collect()
        })
        .collect();
    built(NurbsSurface::new(
        3,
        3,
        BEZIER3.to_vec(),
        BEZIER3.to_vec(),
        &cps,
        None,
    ))
}

/// Radius of the concave cylinder sample.
pub(crate) const CYLINDER_RADIUS: f64 = 100.0;

/// Trough of a cylinder of radius 100 about an axis parallel to x at
/// (y, z) = (0, 100): x in [0, 100], a 60-degree arc (y in [-50, 50]), lowest
/// line at z = 0. Exact rational (quadratic arc with weight cos 30 deg),
/// concave towards the tool: kappa = +1/100 across the axis, 0 along it.
pub fn concave_cylinder() -> NurbsSurface {
    let r = CYLINDER_RADIUS;
    let half = 30f64.to_radians();
    let (s, c) = half.sin_cos();
    // Arc from angle -30 to +30 deg measured from straight down.
    let arc = [
        ([-r * s, r - r * c], 1.0),
        ([0.0, r - r / c], c),
        ([r * s, r - r * c], 1.0),
    ];
    let cps: Vec<Vec<[f64; 3]>> = (0..2)
        .map(|i| {
            arc.iter()
                .map(|(p, _)| [100.0 * i as f64, p[0], p[1]])
                .collect()
        })
        .collect();
    let ws: Vec<Vec<f64>> = (0..2)
        .map(|_| arc.iter().map(|(_, w)| *w).collect())
        .collect();
    built(NurbsSurface::new(
        1,
        2,
        vec![0.0, 0.0, 1.0, 1.0],
        vec![0.0, 0.0, 0.0, 1.0, 1.0, 1.0],
        &cps,
        Some(&ws),
    ))
}

/// z = 1e-5 (x^3 - 3 x y^2) on [-50, 50]^2, as an exact bicubic Bezier patch.
pub(crate) fn monkey_saddle_height(x: f64, y: f64) -> f64 {
    1e-5 * (x * x * x - 3.0 * x * y * y)
}

pub fn monkey_saddle() -> NurbsSurface {
    built(interpolate_height_field(
        monkey_saddle_height,
        (-50.0, 50.0),
        (-50.0, 50.0),
        (3, 1),
        (3, 1),
    ))
}

/// The monkey saddle trimmed to a freeform face: an outer loop that is a
/// circle of radius 0.47 in (u, v) about the domain's centre and an
/// off-centre round hole of radius 0.1, both exact rational circles
/// (docs/formats.md, "Trimmed surfaces"). The umbilic stays on the face.
pub(crate) fn trimmed_saddle() -> NurbsSurface {
    use toolpath_kernel::geometry::trim::{circle, Trim};
    let s = monkey_saddle();
    let ((u0, u1), (v0, v1)) = s.domain();
    let at = |f: f64, g: f64| [u0 + f * (u1 - u0), v0 + g * (v1 - v0)];
    let (w, h) = (u1 - u0, v1 - v0);
    debug_assert!(
        (w - h).abs() <= 1e-12 * w,
        "a square domain keeps the circles round"
    );
    let trim = Trim::new(
        &s,
        vec![circle(at(0.5, 0.5), 0.47 * w, true)],
        vec![vec![circle(at(0.64, 0.4), 0.1 * w, false)]],
        None,
    );
    built(trim.map(|t| s.clone().with_trim(t)))
}

/// Where the wing mould's umbilic is (x, y), mm.
pub const WING_UMBILIC: [f64; 2] = [82.0, 86.0];

/// Blended-wing-like female mould, 200 x 150 mm: a bowl (radius 250 mm at
/// its bottom) around the off-centre point [`WING_UMBILIC`], a monkey-saddle
/// cubic term that makes that point a trisector umbilic and makes the mould
/// strongly anisotropic away from it (principal curvatures differ by up to
/// about 0.035 1/mm at the corners, against a mean of 0.004: the feed
/// direction matters, as on the paper's part), and gentle spanwise/chordwise
/// cubic shaping (camber and dihedral) that keeps it the only umbilic on the
/// part (checked by brute force in the sample tests).
pub(crate) fn wing_mould_height(x: f64, y: f64) -> f64 {
    let (a, b, c1, c3) = (1.0 / 250.0, 2e-5, 1.5e-6, 2e-6);
    let (dx, dy) = (x - WING_UMBILIC[0], y - WING_UMBILIC[1]);
    0.5 * a * (dx * dx + dy * dy)
        + b * (dx * dx * dx - 3.0 * dx * dy * dy)
        + c1 * dx * dx * dy
        + c3 * dy * dy * dy
}

pub fn wing_mould() -> NurbsSurface {
    // A cubic polynomial, so the bicubic spline is exact; 4 x 3 spans give the
    // mould a realistic control net.
    built(interpolate_height_field(
        wing_mould_height,
        (0.0, 200.0),
        (0.0, 150.0),
        (3, 4),
        (3, 3),
    ))
}

/// Curvatures of the die saddle: across the feed (y) concave, radius 1198 mm;
/// along the feed (x) gently convex, radius 19000 mm.
pub(crate) const DIE_KC: f64 = 1.0 / 1198.0;
pub(crate) const DIE_KF: f64 = -1.0 / 19000.0;

pub(crate) fn die_saddle_height(x: f64, y: f64) -> f64 {
    0.5 * DIE_KF * x * x + 0.5 * DIE_KC * y * y
}

/// Shallow hyperbolic paraboloid die, 600 x 400 mm, centred on the origin:
/// z = 1/2 kf x^2 + 1/2 kc y^2 (feed along x = u). Exact bicubic.
pub fn die_saddle() -> NurbsSurface {
    built(interpolate_height_field(
        die_saddle_height,
        (-300.0, 300.0),
        (-200.0, 200.0),
        (3, 3),
        (3, 2),
    ))
}

pub(crate) fn sine_wave_height(x: f64, _y: f64) -> f64 {
    5.0 * (2.0 * std::f64::consts::PI * x / 100.0).sin()
}

/// z = 5 sin(2 pi x / 100) on [0, 100]^2: cubic B-spline in x (64 spans,
/// error below 1e-4 mm), straight (degree 1) in y.
pub fn sine_wave() -> NurbsSurface {
    built(interpolate_height_field(
        sine_wave_height,
        (0.0, 100.0),
        (0.0, 100.0),
        (3, 64),
        (1, 1),
    ))
}

pub(crate) fn egg_crate_height(x: f64, y: f64) -> f64 {
    let k = 2.0 * std::f64::consts::PI / 50.0;
    2.0 * (k * x).sin() * (k * y).sin()
}

/// z = 2 sin(2 pi x / 50) sin(2 pi y / 50) on [0, 100]^2 (two periods each
/// way, smallest curvature radius about 32 mm), bicubic with 48 x 48 spans.
pub fn egg_crate() -> NurbsSurface {
    built(interpolate_height_field(
        egg_crate_height,
        (0.0, 100.0),
        (0.0, 100.0),
        (3, 48),
        (3, 48),
    ))
}

/// Apex of the turbine blade's cone.
pub(crate) const BLADE_APEX: [f64; 3] = [35.0, 600.0, 30.0];
/// Tip section = apex + BLADE_TAPER (root section - apex): the tip sits
/// 130 mm from the root along y.
pub(crate) const BLADE_TAPER: f64 = 470.0 / 600.0;

/// Developable blade: a conical ruled surface between a strongly cambered
/// root section (cubic, chord 70 mm, arc about 85 mm, camber 20 mm, at y = 0)
/// and the tip section 130 mm further along y, the tip being the root scaled
/// towards an apex (as the paper's blade: the camber makes a badly chosen
/// section plane cut obliquely across the rulings). Rulings run along v; the
/// tangent plane is constant along each ruling, so K = 0. About 9 900 mm^2,
/// convex towards the tool.
pub fn turbine_blade() -> NurbsSurface {
    let root = [
        [0.0, 0.0, 0.0],
        [23.0, 0.0, 27.0],
        [47.0, 0.0, 27.0],
        [70.0, 0.0, 0.0],
    ];
    let a = BLADE_APEX;
    let tip = |p: [f64; 3]| {
        [
            a[0] + BLADE_TAPER * (p[0] - a[0]),
            a[1] + BLADE_TAPER * (p[1] - a[1]),
            a[2] + BLADE_TAPER * (p[2] - a[2]),
        ]
    };
    let cps: Vec<Vec<[f64; 3]>> = root.iter().map(|&p| vec![p, tip(p)]).collect();
    built(NurbsSurface::new(
        3,
        1,
        BEZIER3.to_vec(),
        vec![0.0, 0.0, 1.0, 1.0],
        &cps,
        None,
    ))
}

/// Radius of the sphere cap sample.
pub const SPHERE_CAP_RADIUS: f64 = 60.0;

/// Revolves the rational profile `(r, z, weight)` (control points in the
/// xz half-plane, `r >= 0`) about the z axis by `sweep_deg` (at most 90,
/// one rational quadratic arc): u along the profile, v around the axis from
/// the +x axis. A profile point with r = 0 becomes a row of coincident
/// control points, a pole.
pub(crate) fn revolve(
    degree_u: usize,
    knots_u: Vec<f64>,
    profile: &[([f64; 2], f64)],
    sweep_deg: f64,
) -> toolpath_kernel::error::Result<NurbsSurface> {
    let half = (0.5 * sweep_deg).to_radians();
    let (s2, c2) = (2.0 * half).sin_cos();
    // The arc's middle control point lies on the bisector at 1 / cos(half).
    let dirs = [
        ([1.0, 0.0], 1.0),
        ([1.0, half.tan()], half.cos()),
        ([c2, s2], 1.0),
    ];
    let cps: Vec<Vec<[f64; 3]>> = profile
        .iter()
        .map(|&([r, z], _)| dirs.iter().map(|(d, _)| [r * d[0], r * d[1], z]).collect())
        .collect();
    let ws: Vec<Vec<f64>> = profile
        .iter()
        .map(|&(_, wp)| dirs.iter().map(|(_, w)| wp * w).collect())
        .collect();
    NurbsSurface::new(
        degree_u,
        2,
        knots_u,
        vec![0.0, 0.0, 0.0, 1.0, 1.0, 1.0],
        &cps,
        Some(&ws),
    )
}

/// Quarter of a spherical cap of radius 60 centred at the origin: polar
/// angle 0 to 60 deg (u, one exact rational quadratic arc), azimuth 0 to 90
/// deg (v). Its u = 0 row of control points is the pole (0, 0, 60): a
/// degenerate boundary where S_v = 0. Convex towards the tool (+z):
/// kappa = -1/60 everywhere, the pole included.
pub fn sphere_cap() -> NurbsSurface {
    built(sphere_cap_scaled(1.0))
}

/// [`sphere_cap`] with every weight multiplied by `scale` (the same surface:
/// weights are homogeneous), for the tiny- and huge-weight cases.
pub fn sphere_cap_scaled(scale: f64) -> toolpath_kernel::error::Result<NurbsSurface> {
    let r = SPHERE_CAP_RADIUS;
    let half = 30f64.to_radians();
    let profile = [
        ([0.0, r], scale),
        ([r * half.tan(), r], scale * half.cos()),
        ([r * (2.0 * half).sin(), r * (2.0 * half).cos()], scale),
    ];
    revolve(2, vec![0.0, 0.0, 0.0, 1.0, 1.0, 1.0], &profile, 90.0)
}

/// Control points (r, z) of [`revolved_profile`]'s cubic profile: the first
/// leg is horizontal, so the surface has a tangent plane on the axis.
pub const REVOLVED_PROFILE: [[f64; 2]; 5] = [
    [0.0, 25.0],
    [12.0, 25.0],
    [25.0, 18.0],
    [38.0, 8.0],
    [50.0, 5.0],
];

/// Knots of [`revolved_profile`]'s profile.
pub const REVOLVED_PROFILE_KNOTS: [f64; 9] = [0.0, 0.0, 0.0, 0.0, 0.5, 1.0, 1.0, 1.0, 1.0];

/// A freeform cubic profile ([`REVOLVED_PROFILE`]) revolved by 90 deg
/// about the z axis, the axis on its u = 0 boundary (a pole at (0, 0, 25)).
pub fn revolved_profile() -> NurbsSurface {
    let profile = REVOLVED_PROFILE.map(|p| (p, 1.0));
    built(revolve(3, REVOLVED_PROFILE_KNOTS.to_vec(), &profile, 90.0))
}

/// Height of [`triangle_patch`]: a quadratic saddle, tilted.
pub fn triangle_patch_height(x: f64, y: f64) -> f64 {
    0.002 * x * x - 0.003 * y * y + 0.001 * x * y + 0.1 * x + 0.05 * y
}

/// A triangular patch with a collapsed edge: the sector of the height field
/// [`triangle_patch_height`] with apex at the origin, x = 100 u,
/// y = 100 u (v - 0.5), exact biquadratic. Its u = 0 edge is the apex.
pub fn triangle_patch() -> NurbsSurface {
    built(
        toolpath_kernel::geometry::interpolation::interpolate_surface(
            |u, v| {
                let (x, y) = (100.0 * u, 100.0 * u * (v - 0.5));
                [x, y, triangle_patch_height(x, y)]
            },
            2,
            vec![0.0, 0.0, 0.0, 1.0, 1.0, 1.0],
            2,
            vec![0.0, 0.0, 0.0, 1.0, 1.0, 1.0],
        ),
    )
}
