//! Belt-grinding material-removal simulation (docs/methods.md, "Belt removal
//! (Hamann)"; the belt-grinding paper's section 3, algorithm 3, without the
//! solid modeller that makes it too slow for interactive use).
//!
//! The part is a height field over the surface's parameter grid: every node
//! holds a surface point and its normal, and the simulation records how deep
//! (along the normal) the grinding reaches there. The contact wheel is a
//! cylinder of radius R and width w about the wheel axis; between two
//! consecutive result points its centre moves on a straight line, so the
//! closest approach of a node to the wheel axis is a point-segment distance in
//! the plane normal to the axis. Per node this gives
//! - the geometric clearance (wheel at the contact point, no infeed): positive
//!   = material left (scallop), negative = the wheel cuts below the design
//!   surface (gouge);
//! - the removal depth with the wheel pressed in by the Hamann depth r: the
//!   lower envelope of the swept wheel (the paper's boolean subtraction).
//!
//! Hamann's linear model: r L_w = C_A K_A k_t v_b F_A / v_w =: Q, the removed
//! cross-section per pass (mm^2). The contact length follows from the wheel
//! and the local geometry: a wheel of radius R pressed r deep into a surface of
//! normal curvature kappa_f along the feed touches over L_w = 2 sqrt(2 R_eff r),
//! 1/R_eff = 1/R - kappa_f. Solving both: r = (Q / (2 sqrt(2 R_eff)))^(2/3).

use nalgebra::Vector3;
use serde::{Deserialize, Serialize};
use toolpath_formats::job::GrindingParams;
use toolpath_formats::PlanResult;
use toolpath_kernel::error::{Error, Result};
use toolpath_kernel::geometry::{LocalGeometry, NurbsSurface};

/// Largest grid per direction (memory guard: 4000^2 nodes).
const MAX_NODES_PER_DIRECTION: usize = 4000;
/// Nodes whose clearance exceeds this (mm) beyond the removal depth are not
/// looked at by a wheel position (they are never the lowest envelope there).
const REACH_MARGIN: f64 = 0.5;

/// Default grid spacing (mm) when the job gives no `simulation_resolution`.
pub fn default_resolution(width: f64) -> f64 {
    (width / 40.0).clamp(0.05, 0.5)
}

/// Hamann removal depth r (mm) and contact length L_w (mm) at a point whose
/// normal curvature along the feed is `kappa_feed` (concave > 0).
pub fn hamann_depth(params: &GrindingParams, wheel_radius: f64, kappa_feed: f64) -> (f64, f64) {
    let q =
        params.c_a * params.k_a * params.k_t * params.belt_speed * params.force / params.feed_speed;
    let inv = (1.0 / wheel_radius - kappa_feed).max(1e-9 / wheel_radius);
    let r_eff = 1.0 / inv;
    let r = (q / (2.0 * (2.0 * r_eff).sqrt())).powf(2.0 / 3.0);
    (r, q / r)
}

/// Statistics of a simulation run (all depths in mm).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct RemovalStats {
    /// Nodes on the face (all of them on an untrimmed surface).
    pub nodes: usize,
    /// Nodes some wheel position passed over.
    pub ground_nodes: usize,
    pub ground_fraction: f64,
    /// Removal depth over the ground nodes.
    pub mean_mm: f64,
    pub min_mm: f64,
    pub max_mm: f64,
    pub std_mm: f64,
    /// 1 - std / mean (1 = perfectly even removal).
    pub uniformity: f64,
    /// Largest material left above the design surface by the rigid wheel at
    /// its contact points (no infeed), over nodes whose closest wheel position
    /// reports no gouge.
    pub max_scallop_mm: f64,
    /// Deepest cut below the design surface by the wheel at its contact points.
    pub max_gouge_mm: f64,
    /// Hamann removed cross-section Q = C_A K_A k_t v_b F_A / v_w, mm^2.
    pub hamann_q_mm2: f64,
    /// Grid spacing used, mm.
    pub resolution_mm: f64,
}

/// The removal-depth map written by `toolpath simulate --map`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RemovalMap {
    /// Node (i, j) sits at u = u_range.0 + i du, v = v_range.0 + j dv.
    pub u_range: [f64; 2],
    pub v_range: [f64; 2],
    pub nu: usize,
    pub nv: usize,
    /// depth[i][j], mm along the surface normal; `null` where not ground.
    pub depth: Vec<Vec<Option<f64>>>,
    pub stats: RemovalStats,
}

/// The simulation's per-node fields (row-major, i along u).
#[derive(Debug)]
pub struct Simulation {
    pub nu: usize,
    pub nv: usize,
    pub u_range: [f64; 2],
    pub v_range: [f64; 2],
    /// Removal depth; NaN where not ground.
    pub depth: Vec<f64>,
    /// Geometric clearance of the closest wheel position; +inf where not ground.
    pub clearance: Vec<f64>,
    /// Reported rigid-belt gouge of the closest wheel position, mm.
    pub near_gouge: Vec<f32>,
    pub stats: RemovalStats,
}

impl Simulation {
    /// The (u, v) of node (i, j).
    pub(crate) fn node_uv(&self, i: usize, j: usize) -> [f64; 2] {
        let at = |k: usize, n: usize, [lo, hi]: [f64; 2]| {
            if k + 1 == n {
                hi
            } else {
                lo + (hi - lo) / (n - 1) as f64 * k as f64
            }
        };
        [at(i, self.nu, self.u_range), at(j, self.nv, self.v_range)]
    }

    /// The nodes left more than `h` above the surface, by the rule of
    /// `stats.max_scallop_mm` (clearance above h where the closest wheel
    /// position reports no gouge), as (uv, clearance).
    pub fn nodes_above(&self, h: f64) -> Vec<([f64; 2], f64)> {
        let mut out = Vec::new();
        for i in 0..self.nu {
            for j in 0..self.nv {
                let k = i * self.nv + j;
                let c = self.clearance[k];
                if c.is_finite()
                    && c > h
                    && f64::from(self.near_gouge[k]) <= toolpath_kernel::tools::BELT_GOUGE_EPS
                {
                    out.push((self.node_uv(i, j), c));
                }
            }
        }
        out
    }
    pub fn map(&self) -> RemovalMap {
        let depth = (0..self.nu)
            .map(|i| {
                (0..self.nv)
                    .map(|j| {
                        let d = self.depth[i * self.nv + j];
                        d.is_finite().then_some((d * 1e6).round() / 1e6)
                    })
                    .collect()
            })
            .collect();
        RemovalMap {
            u_range: self.u_range,
            v_range: self.v_range,
            nu: self.nu,
            nv: self.nv,
            depth,
            stats: self.stats.clone(),
        }
    }
}

fn iso_length(surface: &NurbsSurface, along_u: bool) -> f64 {
    surface.longest_iso_curve_length(along_u)
}

fn vec3(a: [f64; 3]) -> Vector3<f64> {
    Vector3::new(a[0], a[1], a[2])
}

/// Grinds along a belt result on the surface's height field.
pub fn simulate(
    surface: &NurbsSurface,
    result: &PlanResult,
    width: f64,
    wheel_radius: f64,
    params: &GrindingParams,
    resolution: f64,
) -> Result<Simulation> {
    if !(resolution.is_finite() && resolution > 0.0) {
        return Err(Error::invalid(
            "simulation_resolution",
            format!("must be a positive number of mm, got {resolution}"),
        ));
    }
    let count = |len: f64| -> Result<usize> {
        let n = (len / resolution).ceil() + 1.0;
        if n > MAX_NODES_PER_DIRECTION as f64 {
            return Err(Error::invalid(
                "simulation_resolution",
                format!(
                    "{resolution} mm needs {n} nodes across the part (at most {MAX_NODES_PER_DIRECTION}); use a coarser resolution"
                ),
            ));
        }
        Ok((n as usize).max(2))
    };
    let nu = count(iso_length(surface, true))?;
    let nv = count(iso_length(surface, false))?;
    simulate_on_grid(
        surface,
        result,
        width,
        wheel_radius,
        params,
        (nu, nv),
        resolution,
    )
}

/// [`simulate`] on a height field of `nu x nv` nodes (`resolution` only
/// bounds how far beyond a pass end a node still counts as passed over).
pub fn simulate_on_grid(
    surface: &NurbsSurface,
    result: &PlanResult,
    width: f64,
    wheel_radius: f64,
    params: &GrindingParams,
    (nu, nv): (usize, usize),
    resolution: f64,
) -> Result<Simulation> {
    if nu < 2 || nv < 2 || nu > MAX_NODES_PER_DIRECTION || nv > MAX_NODES_PER_DIRECTION {
        return Err(Error::invalid(
            "simulation_resolution",
            format!("a height field of {nu} x {nv} nodes is outside 2..{MAX_NODES_PER_DIRECTION} per direction"),
        ));
    }
    let ((u0, u1), (v0, v1)) = surface.domain();
    let grid = HeightField::sample(surface, nu, nv);
    let n_nodes = nu * nv;
    let mut fields = Fields {
        clearance: vec![f64::INFINITY; n_nodes],
        depth: vec![f64::NEG_INFINITY; n_nodes],
        near_gouge: vec![0.0f32; n_nodes],
    };
    let wheel = Wheel {
        // Belts laid edge to edge must both reach the node on their common edge.
        half: 0.5 * width * (1.0 + 1e-9),
        radius: wheel_radius,
        resolution,
    };
    for (pi, pass) in result.passes.iter().enumerate() {
        let pos = wheel_positions(surface, pass, pi, &wheel, params)?;
        grind_pass(&grid, &pos, &wheel, &mut fields);
    }
    // Off a trimmed face nothing is judged: those nodes count as neither
    // ground nor part of the surface.
    let mut face_nodes = n_nodes;
    if surface.trim().is_some() {
        for i in 0..nu {
            let u = if i + 1 == nu {
                u1
            } else {
                u0 + grid.du * i as f64
            };
            for j in 0..nv {
                let v = if j + 1 == nv {
                    v1
                } else {
                    v0 + grid.dv * j as f64
                };
                if !surface.in_face(u, v) {
                    fields.clearance[i * nv + j] = f64::INFINITY;
                    face_nodes -= 1;
                }
            }
        }
    }
    let stats = removal_stats(&mut fields, face_nodes, params, resolution)?;
    Ok(Simulation {
        nu,
        nv,
        u_range: [u0, u1],
        v_range: [v0, v1],
        depth: fields.depth,
        clearance: fields.clearance,
        near_gouge: fields.near_gouge,
        stats,
    })
}

/// The part: surface points and unit normals on the node grid (row-major, i along u).
struct HeightField {
    nu: usize,
    nv: usize,
    u0: f64,
    v0: f64,
    du: f64,
    dv: f64,
    points: Vec<nalgebra::Point3<f64>>,
    normals: Vec<Vector3<f64>>,
}

impl HeightField {
    fn sample(surface: &NurbsSurface, nu: usize, nv: usize) -> Self {
        let ((u0, u1), (v0, v1)) = surface.domain();
        let (du, dv) = ((u1 - u0) / (nu - 1) as f64, (v1 - v0) / (nv - 1) as f64);
        let mut points = Vec::with_capacity(nu * nv);
        let mut normals = Vec::with_capacity(nu * nv);
        for i in 0..nu {
            let u = if i + 1 == nu { u1 } else { u0 + du * i as f64 };
            for j in 0..nv {
                let v = if j + 1 == nv { v1 } else { v0 + dv * j as f64 };
                let d = surface.derivs(u, v);
                points.push(d.p);
                normals.push(
                    d.su.cross(&d.sv)
                        .try_normalize(1e-300)
                        .unwrap_or_else(Vector3::zeros),
                );
            }
        }
        Self {
            nu,
            nv,
            u0,
            v0,
            du,
            dv,
            points,
            normals,
        }
    }
}

/// Per-node results of the grinding so far.
struct Fields {
    clearance: Vec<f64>,
    depth: Vec<f64>,
    /// Reported gouge of the wheel position closest to each node.
    near_gouge: Vec<f32>,
}

/// The wheel's size and the node slack beyond a pass end.
struct Wheel {
    half: f64,
    radius: f64,
    resolution: f64,
}

/// One wheel position: centre, axis, Hamann depth, uv box of its reach,
/// reported gouge, contact point.
type Position = (Vector3<f64>, Vector3<f64>, f64, [f64; 4], f32, Vector3<f64>);

/// The wheel positions of pass `pi`.
fn wheel_positions(
    surface: &NurbsSurface,
    pass: &toolpath_formats::Pass,
    pi: usize,
    wheel: &Wheel,
    params: &GrindingParams,
) -> Result<Vec<Position>> {
    let r_wheel = wheel.radius;
    let mut pos: Vec<Position> = Vec::with_capacity(pass.points.len());
    for (k, q) in pass.points.iter().enumerate() {
        let field = |name: &str| format!("passes[{pi}].points[{k}].{name}");
        let (u, v) = (q.uv[0], q.uv[1]);
        if !(u.is_finite() && v.is_finite()) {
            return Err(Error::invalid(field("uv"), "is not finite"));
        }
        let geom = LocalGeometry::at(surface, u, v)
            .ok_or_else(|| Error::invalid(field("uv"), "the surface normal is undefined there"))?;
        let axis = vec3(q.wheel_axis.unwrap_or(q.axis))
            .try_normalize(1e-12)
            .ok_or_else(|| Error::invalid(field("wheel_axis"), "must be a non-zero vector"))?;
        let centre = vec3(q.wheel_center.unwrap_or(q.cl));
        let feed = axis.cross(&geom.forms.n);
        let kappa = geom.normal_curvature(feed);
        let (r, _) = hamann_depth(params, r_wheel, kappa);
        // Reach along the feed: where the wheel rises REACH_MARGIN above its depth.
        let reach_f = (2.0 * r_wheel * (r + REACH_MARGIN)).sqrt();
        let a_uv = geom.tangent_to_uv(axis) * (wheel.half + wheel.resolution);
        let f_uv = geom.tangent_to_uv(feed) * (reach_f + wheel.resolution);
        let (eu, ev) = (a_uv.x.abs() + f_uv.x.abs(), a_uv.y.abs() + f_uv.y.abs());
        pos.push((
            centre,
            axis,
            r,
            [u - eu, u + eu, v - ev, v + ev],
            q.gouge.unwrap_or(0.0) as f32,
            geom.point().coords,
        ));
    }
    Ok(pos)
}

/// Sweeps the wheel between consecutive positions of one pass over the nodes
/// it reaches, keeping each node's lowest clearance and deepest removal.
fn grind_pass(grid: &HeightField, pos: &[Position], wheel: &Wheel, fields: &mut Fields) {
    let segments: Vec<(usize, usize)> = if pos.len() == 1 {
        vec![(0, 0)]
    } else {
        (0..pos.len().saturating_sub(1))
            .map(|k| (k, k + 1))
            .collect()
    };
    let last_segment = segments.len().saturating_sub(1);
    let (nu, nv) = (grid.nu, grid.nv);
    for (si, (ka, kb)) in segments.into_iter().enumerate() {
        let (wa, axa, ra, boxa, ga, cca) = pos[ka];
        let (wb, axb, rb, boxb, gb, ccb) = pos[kb];
        let cc_seg = ccb - cca;
        let cc_len2 = cc_seg.norm_squared();
        let axis = (axa + axb).try_normalize(1e-12).unwrap_or(axa);
        let seg = wb - wa;
        let seg_perp = seg - axis * seg.dot(&axis);
        let seg_len2 = seg_perp.norm_squared();
        let (ulo, uhi) = (boxa[0].min(boxb[0]), boxa[1].max(boxb[1]));
        let (vlo, vhi) = (boxa[2].min(boxb[2]), boxa[3].max(boxb[3]));
        let i0 = (((ulo - grid.u0) / grid.du).floor().max(0.0)) as usize;
        let i1 = (((uhi - grid.u0) / grid.du).ceil().min((nu - 1) as f64)) as usize;
        let j0 = (((vlo - grid.v0) / grid.dv).floor().max(0.0)) as usize;
        let j1 = (((vhi - grid.v0) / grid.dv).ceil().min((nv - 1) as f64)) as usize;
        // Beyond the ends of the pass the wheel never passed over the node.
        let beyond = wheel.resolution / cc_len2.sqrt().max(1e-12);
        // Inside the pass a node projecting beyond a segment belongs to the
        // neighbouring one (half a segment of slack for the outside of corners).
        let lo_s = if si == 0 { -beyond } else { -0.5 };
        let hi_s = if si == last_segment {
            1.0 + beyond
        } else {
            1.5
        };
        for i in i0..=i1 {
            for j in j0..=j1 {
                let idx = i * nv + j;
                let e = grid.points[idx].coords - wa;
                let e_perp = e - axis * e.dot(&axis);
                let s_free = if seg_len2 > 0.0 {
                    e_perp.dot(&seg_perp) / seg_len2
                } else {
                    0.0
                };
                // Which segment a node belongs to is decided along the contact
                // path (the wheel centres bunch up where the wheel nearly fits
                // a concave section).
                let s_cc = if cc_len2 > 0.0 {
                    (grid.points[idx].coords - cca).dot(&cc_seg) / cc_len2
                } else {
                    0.0
                };
                if s_cc < lo_s || s_cc > hi_s {
                    continue;
                }
                let s = s_free.clamp(0.0, 1.0);
                // The machine turns the wheel axis linearly between the points:
                // measure against the pose at s itself.
                let axis_s = (axa + (axb - axa) * s).try_normalize(1e-12).unwrap_or(axis);
                let e_s = e - seg * s;
                let axial = e_s.dot(&axis_s);
                if axial.abs() > wheel.half {
                    continue;
                }
                let radial = e_s - axis_s * axial;
                // Only the part of the wheel facing the surface grinds.
                if radial.dot(&grid.normals[idx]) > 0.0 {
                    continue;
                }
                let c = radial.norm() - wheel.radius;
                if c < fields.clearance[idx] {
                    fields.clearance[idx] = c;
                    fields.near_gouge[idx] = if s < 0.5 { ga } else { gb };
                }
                let cut = ra + s * (rb - ra) - c;
                if cut > fields.depth[idx] {
                    fields.depth[idx] = cut;
                }
            }
        }
    }
}

/// Statistics over the ground nodes; sets the depth of the others to NaN and
/// clamps the ground ones at 0.
fn removal_stats(
    fields: &mut Fields,
    face_nodes: usize,
    params: &GrindingParams,
    resolution: f64,
) -> Result<RemovalStats> {
    let n_nodes = fields.depth.len();
    let mut stats = RemovalStats {
        nodes: face_nodes,
        resolution_mm: resolution,
        hamann_q_mm2: params.c_a * params.k_a * params.k_t * params.belt_speed * params.force
            / params.feed_speed,
        ..Default::default()
    };
    let (mut sum, mut lo, mut hi) = (0.0, f64::INFINITY, f64::NEG_INFINITY);
    let mut ground = 0usize;
    for idx in 0..n_nodes {
        if !fields.clearance[idx].is_finite() {
            fields.depth[idx] = f64::NAN;
            continue;
        }
        let d = fields.depth[idx].max(0.0);
        fields.depth[idx] = d;
        ground += 1;
        sum += d;
        lo = lo.min(d);
        hi = hi.max(d);
        let c = fields.clearance[idx];
        if c > 0.0 && f64::from(fields.near_gouge[idx]) <= toolpath_kernel::tools::BELT_GOUGE_EPS {
            stats.max_scallop_mm = stats.max_scallop_mm.max(c);
        }
        if c < 0.0 {
            stats.max_gouge_mm = stats.max_gouge_mm.max(-c);
        }
    }
    if ground == 0 {
        return Err(Error::invalid(
            "passes",
            "no wheel position touches the surface: is the result planned for this job's surface?",
        ));
    }
    let mean = sum / ground as f64;
    let var = fields
        .depth
        .iter()
        .filter(|d| d.is_finite())
        .map(|d| (d - mean) * (d - mean))
        .sum::<f64>()
        / ground as f64;
    let std = var.sqrt();
    stats.ground_nodes = ground;
    stats.ground_fraction = ground as f64 / face_nodes.max(1) as f64;
    stats.mean_mm = mean;
    stats.min_mm = lo;
    stats.max_mm = hi;
    stats.std_mm = std;
    stats.uniformity = if mean > 0.0 { 1.0 - std / mean } else { 0.0 };
    Ok(stats)
}

/// Simulates a belt result for its job: the job's belt, grinding parameters
/// and `simulation_resolution` (default [`default_resolution`]).
pub fn simulate_job(job: &toolpath_formats::Job, result: &PlanResult) -> Result<Simulation> {
    let toolpath_kernel::tools::Tool::Belt {
        width,
        wheel_radius,
    } = *job.tool()?
    else {
        return Err(Error::invalid(
            "tool.kind",
            format!(
                "the removal simulation needs a belt tool, got {} (milling results are checked by the scallop simulator)",
                job.tool()?.kind()
            ),
        ));
    };
    job.tool()?.validate().map_err(|e| e.within("tool"))?;
    let resolution = job
        .simulation_resolution
        .unwrap_or(default_resolution(width));
    simulate(
        job.surface()?,
        result,
        width,
        wheel_radius,
        &job.grinding,
        resolution,
    )
}
