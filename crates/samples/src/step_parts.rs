//! STEP parts the project writes itself (docs/formats.md, "STEP samples"):
//! Part 21 text built entity by entity, the same bytes on every machine
//! (no clock, no transcendental functions: every number is a product and
//! sum of the fixed data and sqrt(1/2)).
//!
//! - `step_freeform`: one bicubic Bezier face trimmed by an ellipse in
//!   (u, v) with a round hole. Every edge is an exact rational quarter arc:
//!   the pcurve is the rational quadratic arc in (u, v) and the 3-D curve its
//!   exact image on the surface, a rational Bezier of degree 12 (the bicubic
//!   patch composed with the quadratic arc).
//! - `step_multi_face`: the same kind of bicubic face, straight and flat
//!   (z = 0) along x = 0 and x = 100, joined there to a plane (z = 0, x from
//!   -40 to 0) and to a quarter cylinder (radius 30, axis along y) rolling
//!   down from x = 100, with a vertical plane wall (y = 0) under its front
//!   edge. The face areas are known in closed form except the freeform
//!   face's (docs/formats.md).

use std::fmt::Write;

/// sqrt(1/2): the middle weight of a rational quadratic quarter arc.
const W45: f64 = std::f64::consts::FRAC_1_SQRT_2;

/// Names of the STEP sample parts.
pub const STEP_SAMPLES: [&str; 2] = ["step_freeform", "step_multi_face"];

/// A STEP sample: its Part 21 text and the entity ids of its faces (the
/// freeform face first: the face the sample's job plans).
pub struct StepPart {
    pub text: String,
    pub faces: Vec<u64>,
}

/// The STEP sample `name`, if it is one.
pub fn part(name: &str) -> Option<StepPart> {
    match name {
        "step_freeform" => Some(freeform()),
        "step_multi_face" => Some(multi_face()),
        _ => None,
    }
}

/// Control heights (mm) of the freeform sample's bicubic patch, `[i][j]`
/// with x = 40 i, y = 30 j.
pub const FREEFORM_Z: [[f64; 4]; 4] = [
    [0.0, 3.0, 5.0, 2.0],
    [4.0, 10.0, 7.0, 1.0],
    [2.0, 8.0, 12.0, 5.0],
    [0.0, 2.0, 6.0, 3.0],
];

/// Extent of the freeform sample's patch, mm (x = 120 u, y = 90 v).
pub const FREEFORM_SIZE: [f64; 2] = [120.0, 90.0];

/// The freeform sample's outer loop: the ellipse centre, semi-axes (u, v).
pub const FREEFORM_OUTER: ([f64; 2], [f64; 2]) = ([0.5, 0.5], [0.46, 0.42]);

/// The freeform sample's hole: the circle centre and radius in (u, v).
pub const FREEFORM_HOLE: ([f64; 2], f64) = ([0.62, 0.44], 0.13);

/// Control heights (mm) of the multi-face part's bicubic face, `[i][j]` with
/// x = 100 i / 3, y = 80 j / 3; the rows i = 0 and 3 are flat at z = 0.
pub const MULTI_Z: [[f64; 4]; 4] = [
    [0.0, 0.0, 0.0, 0.0],
    [4.0, 12.0, 8.0, 2.0],
    [-3.0, 6.0, 14.0, 5.0],
    [0.0, 0.0, 0.0, 0.0],
];

/// The multi-face part's dimensions, mm: the freeform face's x and y extent,
/// the plane's width before it, the cylinder's radius and the wall's depth.
pub const MULTI_X: f64 = 100.0;
pub const MULTI_Y: f64 = 80.0;
pub const MULTI_PLANE_W: f64 = 40.0;
pub const MULTI_R: f64 = 30.0;
pub const MULTI_WALL: f64 = 20.0;

/// A real as Part 21 writes it: always with a decimal point.
fn real(x: f64) -> String {
    let x = if x == 0.0 { 0.0 } else { x };
    let s = format!("{x:?}");
    match s.split_once('e') {
        Some((m, e)) if m.contains('.') => format!("{m}E{e}"),
        Some((m, e)) => format!("{m}.E{e}"),
        None if s.contains('.') => s,
        None => format!("{s}."),
    }
}

fn reals(xs: &[f64]) -> String {
    xs.iter().map(|&x| real(x)).collect::<Vec<_>>().join(",")
}

fn refs(ids: &[u64]) -> String {
    ids.iter()
        .map(|i| format!("#{i}"))
        .collect::<Vec<_>>()
        .join(",")
}

/// Entity instances in the order written.
struct Writer {
    lines: Vec<String>,
    ctx2: u64,
}

impl Writer {
    fn add(&mut self, body: impl Into<String>) -> u64 {
        self.lines.push(body.into());
        self.lines.len() as u64
    }

    fn point(&mut self, p: &[f64]) -> u64 {
        self.add(format!("CARTESIAN_POINT('',({}))", reals(p)))
    }

    fn direction(&mut self, d: &[f64]) -> u64 {
        self.add(format!("DIRECTION('',({}))", reals(d)))
    }

    fn axis(&mut self, o: [f64; 3], z: [f64; 3], x: [f64; 3]) -> u64 {
        let (o, z, x) = (self.point(&o), self.direction(&z), self.direction(&x));
        self.add(format!("AXIS2_PLACEMENT_3D('',#{o},#{z},#{x})"))
    }

    fn vertex(&mut self, p: [f64; 3]) -> u64 {
        let p = self.point(&p);
        self.add(format!("VERTEX_POINT('',#{p})"))
    }

    /// A line from `a` along `d` (unit-free: t in [0, 1] runs a to a + d).
    fn line(&mut self, a: &[f64], d: &[f64]) -> u64 {
        let len = d.iter().map(|x| x * x).sum::<f64>().sqrt();
        let unit: Vec<f64> = d.iter().map(|x| x / len).collect();
        let (p, dir) = (self.point(a), self.direction(&unit));
        let v = self.add(format!("VECTOR('',#{dir},{})", real(len)));
        self.add(format!("LINE('',#{p},#{v})"))
    }

    /// A clamped Bezier curve (degree = points - 1), rational with `weights`.
    fn bezier(&mut self, pts: &[Vec<f64>], weights: Option<&[f64]>) -> u64 {
        let ids: Vec<u64> = pts.iter().map(|p| self.point(p)).collect();
        let n = ids.len();
        let degree = n - 1;
        match weights {
            None => self.add(format!(
                "B_SPLINE_CURVE_WITH_KNOTS('',{degree},({}),.UNSPECIFIED.,.F.,.F.,({n},{n}),(0.,1.),.UNSPECIFIED.)",
                refs(&ids)
            )),
            Some(w) => self.add(format!(
                "( BOUNDED_CURVE() B_SPLINE_CURVE({degree},({}),.UNSPECIFIED.,.F.,.F.) B_SPLINE_CURVE_WITH_KNOTS(({n},{n}),(0.,1.),.UNSPECIFIED.) CURVE() GEOMETRIC_REPRESENTATION_ITEM() RATIONAL_B_SPLINE_CURVE(({})) REPRESENTATION_ITEM('') )",
                refs(&ids),
                reals(w)
            )),
        }
    }

    /// A pcurve on `surface`: the 2-D curve `curve2d` in its (u, v).
    fn pcurve(&mut self, surface: u64, curve2d: u64) -> u64 {
        let ctx = self.ctx2;
        let rep = self.add(format!(
            "DEFINITIONAL_REPRESENTATION('',(#{curve2d}),#{ctx})"
        ));
        self.add(format!("PCURVE('',#{surface},#{rep})"))
    }

    /// An edge from `a` to `b` on the 3-D curve `curve`, with pcurves.
    fn edge(&mut self, a: u64, b: u64, curve: u64, pcurves: &[u64]) -> u64 {
        let geometry = if pcurves.is_empty() {
            curve
        } else {
            self.add(format!(
                "SURFACE_CURVE('',#{curve},({}),.PCURVE_S1.)",
                refs(pcurves)
            ))
        };
        self.add(format!("EDGE_CURVE('',#{a},#{b},#{geometry},.T.)"))
    }

    /// A loop of (edge, forward) pairs.
    fn edge_loop(&mut self, edges: &[(u64, bool)]) -> u64 {
        let oriented: Vec<u64> = edges
            .iter()
            .map(|&(e, fwd)| {
                let f = if fwd { "T" } else { "F" };
                self.add(format!("ORIENTED_EDGE('',*,*,#{e},.{f}.)"))
            })
            .collect();
        self.add(format!("EDGE_LOOP('',({}))", refs(&oriented)))
    }

    /// A face on `surface` with its outer loop and holes (loops, each with
    /// the bound's orientation).
    fn face(&mut self, surface: u64, outer: u64, holes: &[(u64, bool)]) -> u64 {
        let mut bounds = vec![self.add(format!("FACE_OUTER_BOUND('',#{outer},.T.)"))];
        for &(h, o) in holes {
            let o = if o { "T" } else { "F" };
            bounds.push(self.add(format!("FACE_BOUND('',#{h},.{o}.)")));
        }
        self.add(format!(
            "ADVANCED_FACE('',({}),#{surface},.T.)",
            refs(&bounds)
        ))
    }

    /// A bicubic Bezier surface from its 4 x 4 control points.
    fn bicubic(&mut self, cp: &[[[f64; 3]; 4]; 4]) -> u64 {
        let rows: Vec<String> = cp
            .iter()
            .map(|row| {
                let ids: Vec<u64> = row.iter().map(|p| self.point(p)).collect();
                format!("({})", refs(&ids))
            })
            .collect();
        self.add(format!(
            "B_SPLINE_SURFACE_WITH_KNOTS('',3,3,({}),.UNSPECIFIED.,.F.,.F.,.F.,(4,4),(4,4),(0.,1.),(0.,1.),.UNSPECIFIED.)",
            rows.join(",")
        ))
    }

    /// The whole file: product structure, the faces as one open shell, the
    /// units (mm) and the 2-D context of the pcurves.
    fn finish(self, name: &str, faces: &[u64], ctx3: u64) -> String {
        let mut out = String::new();
        let _ = write!(
            out,
            "ISO-10303-21;\nHEADER;\nFILE_DESCRIPTION(('toolpath sample part {name}'),'2;1');\n\
             FILE_NAME('{name}.step','2026-01-01T00:00:00',('toolpath_planner'),('toolpath_planner'),\
             'toolpath sample','toolpath sample','');\n\
             FILE_SCHEMA(('AUTOMOTIVE_DESIGN {{ 1 0 10303 214 1 1 1 1 }}'));\nENDSEC;\nDATA;\n"
        );
        let mut lines = self.lines;
        let n = lines.len() as u64;
        // The trailer's ids follow the geometry's.
        let k = |i: u64| n + i;
        let faces = refs(faces);
        let trailer = [
            "APPLICATION_CONTEXT('core data for automotive mechanical design processes')".to_string(),
            format!("APPLICATION_PROTOCOL_DEFINITION('international standard','automotive_design',2000,#{})", k(1)),
            format!("PRODUCT_CONTEXT('',#{},'mechanical')", k(1)),
            format!("PRODUCT('{name}','{name}','',(#{}))", k(3)),
            format!("PRODUCT_DEFINITION_FORMATION('','',#{})", k(4)),
            format!("PRODUCT_DEFINITION_CONTEXT('part definition',#{},'design')", k(1)),
            format!("PRODUCT_DEFINITION('design','',#{},#{})", k(5), k(6)),
            format!("PRODUCT_DEFINITION_SHAPE('','',#{})", k(7)),
            format!("OPEN_SHELL('',({faces}))"),
            format!("SHELL_BASED_SURFACE_MODEL('',(#{}))", k(9)),
            "CARTESIAN_POINT('',(0.,0.,0.))".to_string(),
            "DIRECTION('',(0.,0.,1.))".to_string(),
            "DIRECTION('',(1.,0.,0.))".to_string(),
            format!("AXIS2_PLACEMENT_3D('',#{},#{},#{})", k(11), k(12), k(13)),
            format!("MANIFOLD_SURFACE_SHAPE_REPRESENTATION('',(#{},#{}),#{ctx3})", k(14), k(10)),
            format!("SHAPE_DEFINITION_REPRESENTATION(#{},#{})", k(8), k(15)),
            format!("PRODUCT_RELATED_PRODUCT_CATEGORY('part',$,(#{}))", k(4)),
        ];
        lines.extend(trailer);
        for (i, l) in lines.iter().enumerate() {
            let _ = writeln!(out, "#{} = {l};", i + 1);
        }
        out.push_str("ENDSEC;\nEND-ISO-10303-21;\n");
        out
    }
}

/// A writer whose first entities are the units and the two contexts; the
/// 3-D context's id is returned with it.
fn start() -> (Writer, u64) {
    let mut w = Writer {
        lines: Vec::new(),
        ctx2: 0,
    };
    let mm = w.add("( LENGTH_UNIT() NAMED_UNIT(*) SI_UNIT(.MILLI.,.METRE.) )");
    let rad = w.add("( NAMED_UNIT(*) PLANE_ANGLE_UNIT() SI_UNIT($,.RADIAN.) )");
    let sr = w.add("( NAMED_UNIT(*) SI_UNIT($,.STERADIAN.) SOLID_ANGLE_UNIT() )");
    let unc = w.add(format!(
        "UNCERTAINTY_MEASURE_WITH_UNIT(LENGTH_MEASURE(1.E-07),#{mm},'distance_accuracy_value','confusion accuracy')"
    ));
    let ctx3 = w.add(format!(
        "( GEOMETRIC_REPRESENTATION_CONTEXT(3) GLOBAL_UNCERTAINTY_ASSIGNED_CONTEXT((#{unc})) GLOBAL_UNIT_ASSIGNED_CONTEXT((#{mm},#{rad},#{sr})) REPRESENTATION_CONTEXT('Context #1','3D Context with UNIT and UNCERTAINTY') )"
    ));
    w.ctx2 = w.add(
        "( GEOMETRIC_REPRESENTATION_CONTEXT(2) PARAMETRIC_REPRESENTATION_CONTEXT() REPRESENTATION_CONTEXT('2D SPACE','') )",
    );
    (w, ctx3)
}

/// Bernstein coefficients of a polynomial on [0, 1].
type Bern = Vec<f64>;

fn binomial(n: usize, k: usize) -> f64 {
    (0..k).fold(1.0, |c, i| c * (n - i) as f64 / (i + 1) as f64)
}

/// The product of two polynomials in Bernstein form (exact up to rounding:
/// every coefficient is a positive combination).
fn mul(a: &Bern, b: &Bern) -> Bern {
    let (m, n) = (a.len() - 1, b.len() - 1);
    let mut c = vec![0.0; m + n + 1];
    for (i, x) in a.iter().enumerate() {
        for (j, y) in b.iter().enumerate() {
            c[i + j] += binomial(m, i) * binomial(n, j) / binomial(m + n, i + j) * x * y;
        }
    }
    c
}

fn pow(a: &Bern, k: usize) -> Bern {
    (0..k).fold(vec![1.0], |acc, _| mul(&acc, a))
}

/// Control points and weights of the image on the bicubic Bezier patch
/// `cp` of the rational quadratic (u, v) arc with control points `q` and
/// middle weight `w1`: a rational Bezier of degree 12. With U, V, W the
/// arc's homogeneous coordinates, B_i(U / W) = C(3, i) U^i (W - U)^(3-i) / W^3,
/// so the image is sum P_ij C(3,i) C(3,j) U^i (W-U)^(3-i) V^j (W-V)^(3-j) over W^6.
fn arc_image(cp: &[[[f64; 3]; 4]; 4], q: [[f64; 2]; 3], w1: f64) -> (Vec<Vec<f64>>, Vec<f64>) {
    let w: Bern = vec![1.0, w1, 1.0];
    let u: Bern = vec![q[0][0], w1 * q[1][0], q[2][0]];
    let v: Bern = vec![q[0][1], w1 * q[1][1], q[2][1]];
    let minus = |a: &Bern| -> Bern { w.iter().zip(a).map(|(p, q)| p - q).collect() };
    let (wu, wv) = (minus(&u), minus(&v));
    let mut hom = vec![[0.0; 3]; 13];
    for (i, row) in cp.iter().enumerate() {
        let fu = mul(&pow(&u, i), &pow(&wu, 3 - i));
        for (j, p) in row.iter().enumerate() {
            let f = mul(&fu, &mul(&pow(&v, j), &pow(&wv, 3 - j)));
            let c = binomial(3, i) * binomial(3, j);
            for (h, fk) in hom.iter_mut().zip(&f) {
                for d in 0..3 {
                    h[d] += c * fk * p[d];
                }
            }
        }
    }
    let weights = pow(&w, 6);
    let points = hom
        .iter()
        .zip(&weights)
        .map(|(h, wk)| h.iter().map(|x| x / wk).collect())
        .collect();
    (points, weights)
}

/// Point of the bicubic Bezier patch at (u, v).
pub fn bicubic_point(cp: &[[[f64; 3]; 4]; 4], u: f64, v: f64) -> [f64; 3] {
    let b = |t: f64| {
        let s = 1.0 - t;
        [s * s * s, 3.0 * t * s * s, 3.0 * t * t * s, t * t * t]
    };
    let (bu, bv) = (b(u), b(v));
    let mut p = [0.0; 3];
    for i in 0..4 {
        for j in 0..4 {
            for d in 0..3 {
                p[d] += bu[i] * bv[j] * cp[i][j][d];
            }
        }
    }
    p
}

/// The 4 x 4 control points of a bicubic patch over `size` with heights `z`.
fn grid(size: [f64; 2], z: &[[f64; 4]; 4]) -> [[[f64; 3]; 4]; 4] {
    let mut cp = [[[0.0; 3]; 4]; 4];
    for i in 0..4 {
        for j in 0..4 {
            cp[i][j] = [size[0] * i as f64 / 3.0, size[1] * j as f64 / 3.0, z[i][j]];
        }
    }
    cp
}

/// The freeform sample's control points.
pub fn freeform_control_points() -> [[[f64; 3]; 4]; 4] {
    grid(FREEFORM_SIZE, &FREEFORM_Z)
}

/// The multi-face part's freeform control points.
pub fn multi_control_points() -> [[[f64; 3]; 4]; 4] {
    grid([MULTI_X, MULTI_Y], &MULTI_Z)
}

/// A closed loop of four rational quarter arcs of the ellipse with centre
/// `c` and semi-axes `ab` in (u, v), counter-clockwise from angle 0, as
/// edges on `surface` (patch `cp`).
fn ellipse_loop(
    w: &mut Writer,
    surface: u64,
    cp: &[[[f64; 3]; 4]; 4],
    c: [f64; 2],
    ab: [f64; 2],
) -> u64 {
    const COS: [f64; 4] = [1.0, 0.0, -1.0, 0.0];
    const SIN: [f64; 4] = [0.0, 1.0, 0.0, -1.0];
    let at = |k: usize| [c[0] + ab[0] * COS[k % 4], c[1] + ab[1] * SIN[k % 4]];
    let vertices: Vec<u64> = (0..4)
        .map(|k| {
            let q = at(k);
            w.vertex(bicubic_point(cp, q[0], q[1]))
        })
        .collect();
    let mut edges = Vec::new();
    for k in 0..4 {
        let corner = [
            c[0] + ab[0] * (COS[k] - SIN[k]),
            c[1] + ab[1] * (SIN[k] + COS[k]),
        ];
        let q = [at(k), corner, at(k + 1)];
        let (pts, weights) = arc_image(cp, q, W45);
        let curve = w.bezier(&pts, Some(&weights));
        let q2: Vec<Vec<f64>> = q.iter().map(|p| p.to_vec()).collect();
        let c2 = w.bezier(&q2, Some(&[1.0, W45, 1.0]));
        let pc = w.pcurve(surface, c2);
        edges.push((
            w.edge(vertices[k], vertices[(k + 1) % 4], curve, &[pc]),
            true,
        ));
    }
    w.edge_loop(&edges)
}

fn freeform() -> StepPart {
    let (mut w, ctx3) = start();
    let cp = freeform_control_points();
    let surface = w.bicubic(&cp);
    let outer = ellipse_loop(&mut w, surface, &cp, FREEFORM_OUTER.0, FREEFORM_OUTER.1);
    let (hc, hr) = FREEFORM_HOLE;
    // The hole runs counter-clockwise as written; its bound's .F. reverses it.
    let hole = ellipse_loop(&mut w, surface, &cp, hc, [hr, hr]);
    let face = w.face(surface, outer, &[(hole, false)]);
    StepPart {
        text: w.finish("step_freeform", &[face], ctx3),
        faces: vec![face],
    }
}

fn multi_face() -> StepPart {
    let (mut w, ctx3) = start();
    let (x1, y1, x0, r, d) = (MULTI_X, MULTI_Y, -MULTI_PLANE_W, MULTI_R, MULTI_WALL);
    let cp = multi_control_points();
    let free = w.bicubic(&cp);
    // Vertices: the freeform face's corners, the plane's far corners, the
    // cylinder's lower corners and the wall's lower corners.
    let v00 = w.vertex([0.0, 0.0, 0.0]);
    let v10 = w.vertex([x1, 0.0, 0.0]);
    let v11 = w.vertex([x1, y1, 0.0]);
    let v01 = w.vertex([0.0, y1, 0.0]);
    let p0 = w.vertex([x0, 0.0, 0.0]);
    let p1 = w.vertex([x0, y1, 0.0]);
    let c0 = w.vertex([x1 + r, 0.0, -r]);
    let c1 = w.vertex([x1 + r, y1, -r]);
    let b0 = w.vertex([0.0, 0.0, -d]);
    let b1 = w.vertex([x1, 0.0, -d]);
    // 2-D lines in the freeform face's (u, v).
    let uv_line = |w: &mut Writer, a: [f64; 2], dir: [f64; 2]| {
        let l = w.line(&a, &dir);
        w.pcurve(free, l)
    };
    // The freeform face's four edges: straight along x = 0 and x = x1, its
    // boundary rows (cubic Bezier curves in y = 0 and y = y1) along v.
    let l = w.line(&[0.0, 0.0, 0.0], &[0.0, y1, 0.0]);
    let pc = uv_line(&mut w, [0.0, 0.0], [0.0, 1.0]);
    let e_x0 = w.edge(v00, v01, l, &[pc]);
    let l = w.line(&[x1, 0.0, 0.0], &[0.0, y1, 0.0]);
    let pc = uv_line(&mut w, [1.0, 0.0], [0.0, 1.0]);
    let e_x1 = w.edge(v10, v11, l, &[pc]);
    let row = |j: usize| -> Vec<Vec<f64>> { (0..4).map(|i| cp[i][j].to_vec()).collect() };
    let c = w.bezier(&row(0), None);
    let pc = uv_line(&mut w, [0.0, 0.0], [1.0, 0.0]);
    let e_y0 = w.edge(v00, v10, c, &[pc]);
    let c = w.bezier(&row(3), None);
    let pc = uv_line(&mut w, [0.0, 1.0], [1.0, 0.0]);
    let e_y1 = w.edge(v01, v11, c, &[pc]);
    let outer = w.edge_loop(&[(e_y0, true), (e_x1, true), (e_y1, false), (e_x0, false)]);
    let f_free = w.face(free, outer, &[]);
    // The plane z = 0 from x = x0 to 0.
    let frame = w.axis([0.0, 0.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]);
    let plane = w.add(format!("PLANE('',#{frame})"));
    let l = w.line(&[x0, 0.0, 0.0], &[-x0, 0.0, 0.0]);
    let e_p0 = w.edge(p0, v00, l, &[]);
    let l = w.line(&[x0, y1, 0.0], &[-x0, 0.0, 0.0]);
    let e_p1 = w.edge(p1, v01, l, &[]);
    let l = w.line(&[x0, 0.0, 0.0], &[0.0, y1, 0.0]);
    let e_px = w.edge(p0, p1, l, &[]);
    let outer = w.edge_loop(&[(e_p0, true), (e_x0, true), (e_p1, false), (e_px, false)]);
    let f_plane = w.face(plane, outer, &[]);
    // The quarter cylinder about the axis (x1, *, -r) along +y, angle 0 at
    // the top (joined to the freeform face) and 90 degrees towards +x.
    let frame = w.axis([x1, 0.0, -r], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]);
    let cyl = w.add(format!("CYLINDRICAL_SURFACE('',#{frame},{})", real(r)));
    let f0 = w.axis([x1, 0.0, -r], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]);
    let circle0 = w.add(format!("CIRCLE('',#{f0},{})", real(r)));
    let a0 = w.edge(v10, c0, circle0, &[]);
    let f1 = w.axis([x1, y1, -r], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]);
    let circle1 = w.add(format!("CIRCLE('',#{f1},{})", real(r)));
    let a1 = w.edge(v11, c1, circle1, &[]);
    let l = w.line(&[x1 + r, 0.0, -r], &[0.0, y1, 0.0]);
    let e_c = w.edge(c0, c1, l, &[]);
    let outer = w.edge_loop(&[(e_x1, false), (a0, true), (e_c, true), (a1, false)]);
    let f_cyl = w.face(cyl, outer, &[]);
    // The wall y = 0 under the freeform face's front edge, normal -y.
    let frame = w.axis([0.0, 0.0, 0.0], [0.0, -1.0, 0.0], [1.0, 0.0, 0.0]);
    let wall = w.add(format!("PLANE('',#{frame})"));
    let l = w.line(&[0.0, 0.0, 0.0], &[0.0, 0.0, -d]);
    let e_w0 = w.edge(v00, b0, l, &[]);
    let l = w.line(&[0.0, 0.0, -d], &[x1, 0.0, 0.0]);
    let e_wb = w.edge(b0, b1, l, &[]);
    let l = w.line(&[x1, 0.0, -d], &[0.0, 0.0, d]);
    let e_w1 = w.edge(b1, v10, l, &[]);
    let outer = w.edge_loop(&[(e_y0, false), (e_w0, true), (e_wb, true), (e_w1, true)]);
    let f_wall = w.face(wall, outer, &[]);
    let faces = vec![f_free, f_plane, f_cyl, f_wall];
    StepPart {
        text: w.finish("step_multi_face", &faces, ctx3),
        faces,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reals_always_have_a_decimal_point() {
        assert_eq!(real(1.0), "1.0");
        assert_eq!(real(-0.0), "0.0");
        assert_eq!(real(0.25), "0.25");
        assert_eq!(real(1e-7), "1.E-7");
        assert_eq!(real(-2.5e20), "-2.5E20");
    }

    #[test]
    fn the_arc_image_is_the_patch_at_the_arcs_points() {
        // Independent: the quarter arc evaluated directly, then the patch.
        let cp = freeform_control_points();
        let q = [[0.9, 0.5], [0.9, 0.9], [0.5, 0.9]];
        let (pts, w) = arc_image(&cp, q, W45);
        for k in 0..=20 {
            let t = k as f64 / 20.0;
            let b2 = [(1.0 - t) * (1.0 - t), 2.0 * t * (1.0 - t), t * t];
            let ws = [1.0, W45, 1.0];
            let den: f64 = (0..3).map(|i| b2[i] * ws[i]).sum();
            let uv: Vec<f64> = (0..2)
                .map(|d| (0..3).map(|i| b2[i] * ws[i] * q[i][d]).sum::<f64>() / den)
                .collect();
            // On the circle of radius 0.4 about (0.5, 0.5).
            assert!(((uv[0] - 0.5).hypot(uv[1] - 0.5) - 0.4).abs() < 1e-14);
            let want = bicubic_point(&cp, uv[0], uv[1]);
            let mut num = [0.0; 3];
            let mut den12 = 0.0;
            for (i, (p, wi)) in pts.iter().zip(&w).enumerate() {
                let b = binomial(12, i) * t.powi(i as i32) * (1.0 - t).powi(12 - i as i32);
                den12 += b * wi;
                for d in 0..3 {
                    num[d] += b * wi * p[d];
                }
            }
            for d in 0..3 {
                assert!(
                    (num[d] / den12 - want[d]).abs() < 1e-10,
                    "{t}: {num:?} {want:?}"
                );
            }
        }
    }

    #[test]
    fn the_parts_are_the_same_bytes_every_time() {
        for name in STEP_SAMPLES {
            assert_eq!(part(name).unwrap().text, part(name).unwrap().text);
        }
    }
}
