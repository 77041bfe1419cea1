//! Closed form of 6R arms, in product-of-exponentials form: every joint is a
//! rotation about its axis as it lies with all joints at zero, so
//! `E(q) = e^(xi1 q1) ... e^(xi6 q6) E0` (docs/methods.md, "Machine
//! kinematics from URDF"). Two structures are solved:
//!
//! - Spherical wrist (OPW: KUKA, ABB, Fanuc, Staubli...): axes 2 and 3
//!   parallel, axes 4, 5, 6 through one point, the wrist centre `c`. Joints
//!   2-6 keep `c`'s coordinate along axis 2, which gives q1 (subproblem 4);
//!   the distance from axis 2 gives q3 (subproblem 3), then q2 (subproblem
//!   1); the wrist's rotation gives q4 q5 q6 (subproblems 2 and 1).
//! - Parallel axes 2, 3, 4 with axes 5 and 6 meeting (Universal Robots and
//!   the like): their meeting point fixes q1 the same way; the rotation
//!   `Rot(w2, q2+q3+q4) Rot(w5, q5) Rot(w6, q6)` gives the sum and q5 q6;
//!   then axis 4's point is known and q3, q2 follow as above.
//!
//! Each gives up to 8 solutions, labelled by their branches (shoulder, elbow,
//! wrist: bits 0, 1, 2), which stay continuous along a path away from
//! singularities.

use crate::chain::Chain;
use crate::machine::Machine;
use crate::solve::Candidate;
use crate::subproblems::{rot, sp1, sp3, sp4, three_rotations};
use nalgebra::{Isometry3, Point3, Unit, Vector3};

/// Where the arm is: carrying the tool (the part fixed in the cell) or
/// carrying the part (the tool fixed in the cell).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Side {
    Tool,
    Part,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Wrist {
    Spherical,
    Parallel,
}

/// Within this fraction of the arm's reach from axis 1 the wrist centre
/// counts as near the shoulder singularity.
const SHOULDER_ZONE: f64 = 0.1;
/// Lines meeting or axes parallel within these (mm, sine) count as exact;
/// the solutions are then polished on the real chain.
const MEET_MM: f64 = 1e-6;
const PARALLEL_SIN: f64 = 1e-9;
const DISTINCT_SIN: f64 = 1e-6;

/// Joints, branch label, (conditioning, what sets it).
type Solution6 = ([f64; 6], u8, (f64, &'static str));

#[derive(Clone, Debug, PartialEq)]
pub struct ArmSolver {
    pub side: Side,
    pub wrist: Wrist,
    /// Machine joint index of each chain joint, base first.
    joints: [usize; 6],
    w: [Unit<Vector3<f64>>; 6],
    p: [Point3<f64>; 6],
    /// Wrist centre (spherical) or the meeting point of axes 5 and 6 (parallel), at zero.
    centre: Point3<f64>,
    /// The end frame (TCP on the tool side, workpiece frame on the part side) at zero.
    e0: Isometry3<f64>,
    /// The other side's fixed frame in the base.
    fixed: Isometry3<f64>,
    reach: f64,
}

/// The closest points of two lines (point, unit direction), if not parallel.
fn closest(
    p: &Point3<f64>,
    u: &Vector3<f64>,
    q: &Point3<f64>,
    v: &Vector3<f64>,
) -> Option<(Point3<f64>, Point3<f64>)> {
    let w0 = p - q;
    let b = u.dot(v);
    let denom = 1.0 - b * b;
    if denom < DISTINCT_SIN * DISTINCT_SIN {
        return None;
    }
    let (d, e) = (u.dot(&w0), v.dot(&w0));
    let s = (b * e - d) / denom;
    let t = (e - b * d) / denom;
    Some((p + u * s, q + v * t))
}

fn distance_to_line(x: &Point3<f64>, p: &Point3<f64>, u: &Vector3<f64>) -> f64 {
    let d = x - p;
    (d - u * u.dot(&d)).norm()
}

/// Where two lines meet, if they do (within `MEET_MM`).
fn meet(
    p: &Point3<f64>,
    u: &Vector3<f64>,
    q: &Point3<f64>,
    v: &Vector3<f64>,
) -> Option<Point3<f64>> {
    let (a, b) = closest(p, u, q, v)?;
    ((a - b).norm() <= MEET_MM).then(|| Point3::from((a.coords + b.coords) / 2.0))
}

impl ArmSolver {
    /// The solver when one side is a 6R chain of a solved structure and the
    /// other side has no joints.
    pub fn detect(m: &Machine) -> Option<Self> {
        let (side, chain, index, end, fixed) = match (m.tool.dof(), m.part.dof()) {
            (6, 0) => (
                Side::Tool,
                &m.tool,
                &m.tool_index,
                m.tcp,
                m.part.forward(&[]) * m.workpiece,
            ),
            (0, 6) => (
                Side::Part,
                &m.part,
                &m.part_index,
                m.workpiece,
                m.tool.forward(&[]) * m.tcp,
            ),
            _ => return None,
        };
        if chain.joints.iter().any(|j| !j.kind.is_rotary()) {
            return None;
        }
        let (w, p) = zero_axes(chain);
        let par = |a: usize, b: usize| w[a].cross(&w[b]).norm() < PARALLEL_SIN;
        let distinct = |a: usize, b: usize| w[a].cross(&w[b]).norm() > DISTINCT_SIN;
        if !(distinct(0, 1) && par(1, 2) && distinct(4, 5)) {
            return None;
        }
        let spherical = distinct(3, 4)
            .then(|| meet(&p[3], &w[3], &p[4], &w[4]))
            .flatten()
            .filter(|c| distance_to_line(c, &p[5], &w[5]) <= MEET_MM);
        let (wrist, centre) = match spherical {
            Some(c) => (Wrist::Spherical, c),
            None if par(2, 3) && distinct(1, 4) => {
                (Wrist::Parallel, meet(&p[4], &w[4], &p[5], &w[5])?)
            }
            None => return None,
        };
        let e0 = chain.forward(&[0.0; 6]) * end;
        let reach = p.windows(2).map(|s| (s[1] - s[0]).norm()).sum::<f64>()
            + (e0.translation.vector - p[5].coords).norm();
        Some(Self {
            side,
            wrist,
            joints: [index[0], index[1], index[2], index[3], index[4], index[5]],
            w,
            p,
            centre,
            e0,
            fixed,
            reach: reach.max(1.0),
        })
    }

    pub fn name(&self) -> &'static str {
        match self.wrist {
            Wrist::Spherical => "closed form, 6R spherical wrist (OPW)",
            Wrist::Parallel => "closed form, 6R with parallel axes 2-3-4 (UR)",
        }
    }

    /// The arm's end frame in the base for a TCP pose `x` in the workpiece frame.
    pub fn end_target(&self, x: &Isometry3<f64>) -> Isometry3<f64> {
        match self.side {
            Side::Tool => self.fixed * x,
            Side::Part => self.fixed * x.inverse(),
        }
    }

    /// Every solution for the TCP pose `x`; `hold` = previous joints (the
    /// last joint keeps its value in a wrist singularity).
    pub fn candidates(
        &self,
        m: &Machine,
        x: &Isometry3<f64>,
        hold: &[f64],
    ) -> Result<Vec<Candidate>, String> {
        let e = self.end_target(x);
        let centre = e * (self.e0.inverse() * self.centre);
        let hold6 = hold[self.joints[5]];
        let shoulder = sp4(
            &self.p[0],
            &self.w[0],
            &centre,
            &self.w[1],
            self.w[1].dot(&self.centre.coords),
        );
        if shoulder.is_empty() {
            return Err(format!(
                "the wrist centre ({:.1} mm from axis 1) cannot be brought into the arm's plane: out of reach",
                distance_to_line(&centre, &self.p[0], &self.w[0])
            ));
        }
        let near_axis = (distance_to_line(&centre, &self.p[0], &self.w[0])
            / (SHOULDER_ZONE * self.reach))
            .min(1.0);
        let mut out = Vec::new();
        let mut why = String::new();
        for (k1, &(t, c1)) in shoulder.iter().enumerate() {
            let q1 = -t;
            let c_sh = c1 * near_axis;
            // The centre with joint 1 undone.
            let wc = self.p[0] + rot(&self.w[0], t) * (centre - self.p[0]);
            let g0 = rot(&self.w[0], q1).inverse() * e.rotation * self.e0.rotation.inverse();
            let found = match self.wrist {
                Wrist::Spherical => self.spherical(&wc, &g0, q1, hold6, k1 as u8, c_sh),
                Wrist::Parallel => self.parallel(&wc, &g0, q1, hold6, k1 as u8, c_sh),
            };
            match found {
                Ok(list) => out.extend(list),
                Err(w) => why = w,
            }
        }
        if out.is_empty() {
            return Err(why);
        }
        Ok(out
            .into_iter()
            .map(|(q6, config, conditioning)| {
                let mut q = vec![0.0; m.dof()];
                for (&i, v) in self.joints.iter().zip(q6) {
                    q[i] = v;
                }
                Candidate {
                    q,
                    config,
                    conditioning: conditioning.0,
                    weakest: conditioning.1,
                }
            })
            .collect())
    }

    /// q2 and q3 that carry the point `from` (on link 3, at zero) to `to`
    /// (joint 1 undone), with the elbow conditioning.
    fn elbow(&self, from: &Point3<f64>, to: &Point3<f64>) -> Result<Vec<(f64, f64, f64)>, String> {
        let delta = (to - self.p[1]).norm();
        let sols = sp3(&self.p[2], &self.w[2], from, &self.p[1], delta);
        if sols.is_empty() {
            return Err(format!("the wrist is {delta:.1} mm from the shoulder axis, beyond what the upper arm and forearm reach"));
        }
        Ok(sols
            .into_iter()
            .map(|(q3, c)| {
                let y = self.p[2] + rot(&self.w[2], q3) * (from - self.p[2]);
                let q2 = sp1(&self.w[1], &(y - self.p[1]), &(to - self.p[1]));
                (q2, q3, c)
            })
            .collect())
    }

    fn spherical(
        &self,
        wc: &Point3<f64>,
        g0: &nalgebra::UnitQuaternion<f64>,
        q1: f64,
        hold6: f64,
        k1: u8,
        c_sh: f64,
    ) -> Result<Vec<Solution6>, String> {
        let mut out = Vec::new();
        for (k3, (q2, q3, c_el)) in self.elbow(&self.centre, wc)?.into_iter().enumerate() {
            let g = (rot(&self.w[1], q2) * rot(&self.w[2], q3)).inverse() * g0;
            let wrist = three_rotations([&self.w[3], &self.w[4], &self.w[5]], &g, hold6);
            for (k5, (t, c_wr)) in wrist.into_iter().enumerate() {
                let config = k1 | ((k3 as u8) << 1) | ((k5 as u8) << 2);
                out.push((
                    [q1, q2, q3, t[0], t[1], t[2]],
                    config,
                    weakest(c_sh, c_el, c_wr),
                ));
            }
        }
        Ok(out)
    }

    fn parallel(
        &self,
        p56: &Point3<f64>,
        g0: &nalgebra::UnitQuaternion<f64>,
        q1: f64,
        hold6: f64,
        k1: u8,
        c_sh: f64,
    ) -> Result<Vec<Solution6>, String> {
        let s3 = self.w[2].dot(&self.w[1]).signum();
        let s4 = self.w[3].dot(&self.w[1]).signum();
        let mut out = Vec::new();
        let mut why = String::new();
        let wrist = three_rotations([&self.w[1], &self.w[4], &self.w[5]], g0, hold6);
        for (k5, (t, c_wr)) in wrist.into_iter().enumerate() {
            // Axis 4's point, where the forearm must bring it.
            let p4 = p56 - rot(&self.w[1], t[0]) * (self.centre - self.p[3]);
            let elbow = match self.elbow(&self.p[3], &p4) {
                Ok(e) => e,
                Err(w) => {
                    why = w;
                    continue;
                }
            };
            for (k3, (q2, q3, c_el)) in elbow.into_iter().enumerate() {
                let q4 = s4 * (t[0] - q2 - s3 * q3);
                let config = k1 | ((k3 as u8) << 1) | ((k5 as u8) << 2);
                out.push((
                    [q1, q2, q3, q4, t[1], t[2]],
                    config,
                    weakest(c_sh, c_el, c_wr),
                ));
            }
        }
        if out.is_empty() {
            return Err(why);
        }
        Ok(out)
    }
}

/// The smallest of the shoulder, elbow and wrist conditionings, with its name.
fn weakest(shoulder: f64, elbow: f64, wrist: f64) -> (f64, &'static str) {
    let mut w = (shoulder, "shoulder (wrist centre near axis 1)");
    if elbow < w.0 {
        w = (elbow, "elbow (arm stretched or folded)");
    }
    if wrist < w.0 {
        w = (wrist, "wrist (its first and last axes aligned)");
    }
    w
}

/// Each joint's axis and a point on it, all joints at zero, in the chain's base.
pub fn zero_axes(chain: &Chain) -> ([Unit<Vector3<f64>>; 6], [Point3<f64>; 6]) {
    let frames = chain.joint_frames(&vec![0.0; chain.dof()]);
    let w: Vec<Unit<Vector3<f64>>> = frames
        .iter()
        .zip(&chain.joints)
        .map(|(f, j)| Unit::new_normalize(f.rotation * j.axis.into_inner()))
        .collect();
    let p: Vec<Point3<f64>> = frames
        .iter()
        .map(|f| Point3::from(f.translation.vector))
        .collect();
    (
        [w[0], w[1], w[2], w[3], w[4], w[5]],
        [p[0], p[1], p[2], p[3], p[4], p[5]],
    )
}
