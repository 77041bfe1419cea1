//! Five-axis mills as NC programs drive them: an A/C swivel head (mill5's
//! kinematics), an A/C trunnion table or a B/C table, with axis limits.
//!
//! Two frames: the machine frame, in which the joints X Y Z move the spindle,
//! and the workpiece frame of the result's `cl` and `axis`.
//! - `ac_head`: the frames are parallel and the part stands still; X Y Z place
//!   the A/C pivot, the spindle offset (pivot length + tool length) above the
//!   tip along the axis (see [`super::mill5`]).
//! - `ac_table`, `bc_table`: the spindle stays vertical (+z); X Y Z place its
//!   gauge point, the tool length above the tip. The tilt axis (A about +x,
//!   or B about +y, through `tilt_axis_point_mm`) carries the C table (about
//!   its own +z, through `c_axis_point_mm` at tilt 0), which carries the part.
//!   A workpiece point p sits in the machine at
//!   `M(q) p = P_t + R_t (P_c - P_t + R_z(C) (W - P_c + p))`, with
//!   right-handed rotations by the joint angles and W = `workpiece_origin_mm`
//!   (where the part's origin sits with both rotaries at 0).
//!
//! Every machine solves the tool axis with a tilt (A or B) equal to the
//! axis' angle from the part's +z and a turn C; of the two solutions (tilt,
//! C) and (-tilt, C + 180 deg) the one nearer the previous pose is taken
//! ([`super::mill5::tilt_and_turn`]).

use super::axes::Axis;
use super::config::{finite, positive, LinearAxis, Mill5Config, RotaryAxis};
use super::mill5;
use nalgebra::{Matrix3, Rotation3, Vector3};
use serde::{Deserialize, Serialize};
use toolpath_kernel::error::{Error, Result};

/// Kinematic type of a five-axis mill.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum FiveAxisKind {
    /// A/C swivel head on an X Y Z gantry (mill5).
    AcHead,
    /// A/C trunnion table: A tilts the cradle about x, C turns the table on it.
    AcTable,
    /// B/C table: B tilts about y, C turns the table on it.
    BcTable,
}

impl FiveAxisKind {
    pub fn name(self) -> &'static str {
        match self {
            FiveAxisKind::AcHead => "ac_head",
            FiveAxisKind::AcTable => "ac_table",
            FiveAxisKind::BcTable => "bc_table",
        }
    }
    /// Joint names in joint order (X Y Z tilt turn).
    pub fn joint_names(self) -> [&'static str; 5] {
        match self {
            FiveAxisKind::AcHead | FiveAxisKind::AcTable => ["X", "Y", "Z", "A", "C"],
            FiveAxisKind::BcTable => ["X", "Y", "Z", "B", "C"],
        }
    }
    pub fn is_table(self) -> bool {
        self != FiveAxisKind::AcHead
    }
}

/// A machine definition as written in YAML (launch_configs/machines/*.yaml):
/// lengths in mm, angles in degrees.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FiveAxisConfig {
    pub name: String,
    pub kinematics: FiveAxisKind,
    /// `ac_head`: A/C pivot to the spindle gauge line (the tool length is added per job).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub pivot_length_mm: Option<f64>,
    /// Head: machine X Y Z of the workpiece origin (pivot = origin + tip +
    /// spindle offset x axis). Tables: where the part's origin sits in the
    /// machine frame with both rotaries at 0.
    pub workpiece_origin_mm: [f64; 3],
    /// Tables: a point of the tilt axis (A or B), machine frame.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tilt_axis_point_mm: Option<[f64; 3]>,
    /// Tables: a point of the C axis with the tilt at 0, machine frame.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub c_axis_point_mm: Option<[f64; 3]>,
    /// Lift along the tool axis before and after each pass, and the clearance
    /// above the part's bounding box below which nothing moves at rapid.
    pub retract_mm: f64,
    pub max_feed_rate_mm_min: f64,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub x: Option<LinearAxis>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub y: Option<LinearAxis>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub z: Option<LinearAxis>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub a: Option<RotaryAxis>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub b: Option<RotaryAxis>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub c: Option<RotaryAxis>,
}

impl FiveAxisConfig {
    /// The definition of the built-in mill5 head in a cell config.
    pub fn from_mill5(name: &str, cfg: &Mill5Config) -> Self {
        Self {
            name: name.to_string(),
            kinematics: FiveAxisKind::AcHead,
            pivot_length_mm: Some(cfg.pivot_length_mm),
            workpiece_origin_mm: cfg.workpiece_origin_mm,
            tilt_axis_point_mm: None,
            c_axis_point_mm: None,
            retract_mm: cfg.retract_mm,
            max_feed_rate_mm_min: cfg.max_feed_rate_mm_min,
            x: Some(cfg.x),
            y: Some(cfg.y),
            z: Some(cfg.z),
            a: Some(cfg.a),
            b: None,
            c: Some(cfg.c),
        }
    }

    /// Validates the definition (every field the kinematics needs, no axis
    /// it lacks) and converts it to internal units.
    pub fn build(&self) -> Result<FiveAxis> {
        let k = self.kinematics;
        if self.name.trim().is_empty() {
            return Err(Error::invalid("name", "must not be empty"));
        }
        let limits = self.axis_limits()?;
        for (i, v) in self.workpiece_origin_mm.iter().enumerate() {
            finite(&format!("workpiece_origin_mm[{i}]"), *v)?;
        }
        positive("max_feed_rate_mm_min", self.max_feed_rate_mm_min)?;
        if !self.retract_mm.is_finite() || self.retract_mm <= 0.0 {
            return Err(Error::invalid(
                "retract_mm",
                format!("must be a positive finite number, got {}", self.retract_mm),
            ));
        }
        let (pivot_length, tilt_axis_point, c_axis_point) = self.geometry()?;
        let head = Mill5Config {
            pivot_length_mm: pivot_length.max(f64::MIN_POSITIVE),
            workpiece_origin_mm: self.workpiece_origin_mm,
            max_feed_rate_mm_min: self.max_feed_rate_mm_min,
            retract_mm: self.retract_mm,
            ..Mill5Config::default()
        };
        Ok(FiveAxis {
            name: self.name.clone(),
            kinematics: k,
            pivot_length,
            workpiece_origin: self.workpiece_origin_mm,
            tilt_axis_point,
            c_axis_point,
            retract: self.retract_mm,
            max_feed_rate_mm_min: self.max_feed_rate_mm_min,
            limits,
            head,
        })
    }
    /// The five axes' limits: x, y, z, the tilt (a or b) and c; an axis the
    /// kinematics lacks is refused by name.
    fn axis_limits(&self) -> Result<[Axis; 5]> {
        let k = self.kinematics;
        let axes = match k {
            FiveAxisKind::AcHead | FiveAxisKind::AcTable => "x, y, z, a, c",
            FiveAxisKind::BcTable => "x, y, z, b, c",
        };
        let missing = |field: &str| {
            Error::invalid(
                field,
                format!("missing: {} kinematics needs the axes {axes}", k.name()),
            )
        };
        let linear = |field: &'static str, axis: &Option<LinearAxis>| -> Result<Axis> {
            let a = axis.as_ref().ok_or_else(|| missing(field))?;
            a.validate(field)?;
            Ok(a.axis(match field {
                "x" => "X",
                "y" => "Y",
                _ => "Z",
            }))
        };
        let (tilt_field, tilt, extra_field, extra) = match k {
            FiveAxisKind::BcTable => ("b", &self.b, "a", &self.a),
            _ => ("a", &self.a, "b", &self.b),
        };
        if extra.is_some() {
            return Err(Error::invalid(
                extra_field,
                format!(
                    "{} kinematics has no {extra_field} axis (its axes are {axes})",
                    k.name()
                ),
            ));
        }
        let rotary = |field: &'static str, axis: &Option<RotaryAxis>| -> Result<Axis> {
            let a = axis.as_ref().ok_or_else(|| missing(field))?;
            a.validate(field)?;
            Ok(a.axis(match field {
                "a" => "A",
                "b" => "B",
                _ => "C",
            }))
        };
        Ok([
            linear("x", &self.x)?,
            linear("y", &self.y)?,
            linear("z", &self.z)?,
            rotary(tilt_field, tilt)?,
            rotary("c", &self.c)?,
        ])
    }

    /// Pivot length (head) or the tilt and C axis points (tables).
    fn geometry(&self) -> Result<(f64, [f64; 3], [f64; 3])> {
        let k = self.kinematics;
        let point = |field: &str, p: &Option<[f64; 3]>| -> Result<[f64; 3]> {
            let p = p.ok_or_else(|| {
                Error::invalid(field, format!("missing: {} kinematics needs it", k.name()))
            })?;
            for (i, v) in p.iter().enumerate() {
                finite(&format!("{field}[{i}]"), *v)?;
            }
            Ok(p)
        };
        let not_for_head = |field: &str, given: bool| {
            if given {
                Err(Error::invalid(
                    field,
                    "only a table machine (ac_table, bc_table) has it",
                ))
            } else {
                Ok(())
            }
        };
        if k.is_table() {
            if self.pivot_length_mm.is_some() {
                return Err(Error::invalid(
                    "pivot_length_mm",
                    "only an ac_head machine has a pivot length (a table machine's spindle offset is the tool length)",
                ));
            }
            Ok((
                0.0,
                point("tilt_axis_point_mm", &self.tilt_axis_point_mm)?,
                point("c_axis_point_mm", &self.c_axis_point_mm)?,
            ))
        } else {
            not_for_head("tilt_axis_point_mm", self.tilt_axis_point_mm.is_some())?;
            not_for_head("c_axis_point_mm", self.c_axis_point_mm.is_some())?;
            let l = self
                .pivot_length_mm
                .ok_or_else(|| missing_pivot(k.name()))?;
            positive("pivot_length_mm", l)?;
            Ok((l, [0.0; 3], [0.0; 3]))
        }
    }
}

fn missing_pivot(kind: &str) -> Error {
    Error::invalid(
        "pivot_length_mm",
        format!("missing: {kind} kinematics needs it"),
    )
}

/// A validated five-axis machine in internal units (mm, rad). Joint vectors
/// are `[X, Y, Z, tilt, C]` (tilt = A or B).
#[derive(Clone, Debug, PartialEq)]
pub struct FiveAxis {
    pub name: String,
    pub kinematics: FiveAxisKind,
    /// Head: pivot to the spindle gauge line; 0 on tables.
    pub pivot_length: f64,
    pub workpiece_origin: [f64; 3],
    pub tilt_axis_point: [f64; 3],
    pub c_axis_point: [f64; 3],
    pub retract: f64,
    pub max_feed_rate_mm_min: f64,
    /// X Y Z tilt C.
    pub limits: [Axis; 5],
    /// The head's geometry as mill5 takes it (only the origin is read).
    head: Mill5Config,
}

fn v3(p: [f64; 3]) -> Vector3<f64> {
    Vector3::new(p[0], p[1], p[2])
}

fn arr(v: Vector3<f64>) -> [f64; 3] {
    [v.x, v.y, v.z]
}

impl FiveAxis {
    pub fn joint_names(&self) -> [&'static str; 5] {
        self.kinematics.joint_names()
    }

    /// Tool tip to the point X Y Z place, along the spindle: pivot length +
    /// tool length on a head, the tool length on a table machine.
    pub fn spindle_offset(&self, tool_length: f64) -> f64 {
        self.pivot_length + tool_length
    }

    /// Rotation of the part into the machine frame for rotaries `[tilt, C]`
    /// (identity on a head).
    pub fn part_rotation(&self, r: [f64; 2]) -> Matrix3<f64> {
        let tilt_axis = match self.kinematics {
            FiveAxisKind::AcHead => return Matrix3::identity(),
            FiveAxisKind::AcTable => Vector3::x_axis(),
            FiveAxisKind::BcTable => Vector3::y_axis(),
        };
        let rt = Rotation3::from_axis_angle(&tilt_axis, r[0]);
        let rc = Rotation3::from_axis_angle(&Vector3::z_axis(), r[1]);
        (rt * rc).into_inner()
    }

    /// Machine position of the workpiece point `p` with rotaries `r`.
    pub fn part_to_machine(&self, r: [f64; 2], p: [f64; 3]) -> [f64; 3] {
        if !self.kinematics.is_table() {
            let o = self.workpiece_origin;
            return [p[0] + o[0], p[1] + o[1], p[2] + o[2]];
        }
        let (pt, pc, w) = (
            v3(self.tilt_axis_point),
            v3(self.c_axis_point),
            v3(self.workpiece_origin),
        );
        let tilt = self.part_rotation([r[0], 0.0]);
        let rc = Rotation3::from_axis_angle(&Vector3::z_axis(), r[1]);
        arr(pt + tilt * (pc - pt + rc * (w - pc + v3(p))))
    }

    /// Workpiece coordinates of the machine point `m` with rotaries `r`.
    pub fn machine_to_part(&self, r: [f64; 2], m: [f64; 3]) -> [f64; 3] {
        let origin = v3(self.part_to_machine(r, [0.0; 3]));
        arr(self.part_rotation(r).transpose() * (v3(m) - origin))
    }

    /// Unit direction from the tool tip to the spindle in the machine frame.
    pub fn spindle_direction(&self, r: [f64; 2]) -> [f64; 3] {
        match self.kinematics {
            FiveAxisKind::AcHead => {
                let (sa, ca) = r[0].sin_cos();
                let (sc, cc) = r[1].sin_cos();
                [sa * sc, -sa * cc, ca]
            }
            _ => [0.0, 0.0, 1.0],
        }
    }

    /// Machine position of the tool tip for joints `q`.
    pub fn tip_in_machine(&self, tool_length: f64, q: &[f64; 5]) -> [f64; 3] {
        let d = self.spindle_direction([q[3], q[4]]);
        let l = self.spindle_offset(tool_length);
        [q[0] - l * d[0], q[1] - l * d[1], q[2] - l * d[2]]
    }

    /// Forward kinematics: joints -> (tip, unit axis) in the workpiece frame.
    pub fn forward(&self, tool_length: f64, q: &[f64; 5]) -> ([f64; 3], [f64; 3]) {
        if !self.kinematics.is_table() {
            return mill5::forward(&self.head, self.spindle_offset(tool_length), q);
        }
        let r = [q[3], q[4]];
        let tip = self.machine_to_part(r, self.tip_in_machine(tool_length, q));
        let axis = self.part_rotation(r).transpose() * Vector3::z();
        (tip, arr(axis))
    }

    /// C of the positive-tilt solution for a unit workpiece axis.
    pub fn turn_of(&self, a: [f64; 3]) -> f64 {
        match self.kinematics {
            FiveAxisKind::AcHead => mill5::head_turn(a),
            // R^T z = (sin A sin C, sin A cos C, cos A).
            FiveAxisKind::AcTable => a[0].atan2(a[1]),
            // R^T z = (-sin B cos C, sin B sin C, cos B).
            FiveAxisKind::BcTable => a[1].atan2(-a[0]),
        }
    }

    /// The C the first tilted axis of a path asks for (so that a path that
    /// starts with the tool on the C axis does not spin C when it tilts).
    pub fn turn_hint(&self, axes: &[[f64; 3]]) -> f64 {
        axes.iter()
            .find(|a| {
                a[0].hypot(a[1])
                    >= mill5::SINGULAR_SIN_A * (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt()
            })
            .map_or(0.0, |a| self.turn_of(*a))
    }

    /// Inverse kinematics of one pose; `prev` picks the branch and unwraps C
    /// (see [`mill5::tilt_and_turn`]), `turn_hint` is C when the first pose
    /// of a path has the tool on the C axis.
    pub fn inverse(
        &self,
        tool_length: f64,
        tip: [f64; 3],
        axis: [f64; 3],
        prev: Option<&[f64; 5]>,
        turn_hint: f64,
    ) -> Result<[f64; 5]> {
        let l = self.spindle_offset(tool_length);
        if !self.kinematics.is_table() {
            return mill5::inverse(&self.head, l, tip, axis, prev, turn_hint);
        }
        let n = (axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2]).sqrt();
        if !n.is_finite() || n < 1e-12 || tip.iter().any(|x| !x.is_finite()) {
            return Err(Error::planning(format!(
                "{}: cannot pose the tool at tip {tip:?} with axis {axis:?} (not a finite unit axis)",
                self.name
            )));
        }
        let a = [axis[0] / n, axis[1] / n, axis[2] / n];
        let (t, c) =
            mill5::tilt_and_turn(a, self.turn_of(a), prev.map(|p| (p[3], p[4])), turn_hint);
        let m = self.part_to_machine([t, c], tip);
        Ok([m[0], m[1], m[2] + l, t, c])
    }

    /// Joints that put the tip at `tip` (workpiece frame) with the rotaries at
    /// `r`, which must be a solution for the pose's axis: a whole turn of C
    /// or the other branch moves X Y Z on a table machine (the part turns
    /// about the tool axis), not on a head.
    pub fn joints_at(&self, tool_length: f64, tip: [f64; 3], r: [f64; 2]) -> [f64; 5] {
        let l = self.spindle_offset(tool_length);
        let m = self.part_to_machine(r, tip);
        let s = self.spindle_direction(r);
        [
            m[0] + l * s[0],
            m[1] + l * s[1],
            m[2] + l * s[2],
            r[0],
            r[1],
        ]
    }

    /// Joints of consecutive poses, continuous in tilt and C.
    pub fn inverse_path(
        &self,
        tool_length: f64,
        poses: &[([f64; 3], [f64; 3])],
    ) -> Result<Vec<[f64; 5]>> {
        let axes: Vec<[f64; 3]> = poses.iter().map(|p| p.1).collect();
        let hint = self.turn_hint(&axes);
        let mut out: Vec<[f64; 5]> = Vec::with_capacity(poses.len());
        for (tip, axis) in poses {
            let q = self.inverse(tool_length, *tip, *axis, out.last(), hint)?;
            out.push(q);
        }
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Matrix4, Translation3, Vector4};

    fn table(k: FiveAxisKind) -> FiveAxis {
        let rot = RotaryAxis::new(-120.0, 120.0, 90.0, 360.0);
        let lin = Some(LinearAxis::new(-2000.0, 2000.0, 500.0, 2000.0));
        FiveAxisConfig {
            name: "t".into(),
            kinematics: k,
            pivot_length_mm: None,
            workpiece_origin_mm: [30.0, -40.0, 120.0],
            tilt_axis_point_mm: Some([0.0, 15.0, 80.0]),
            c_axis_point_mm: Some([5.0, -7.0, 0.0]),
            retract_mm: 10.0,
            max_feed_rate_mm_min: 5000.0,
            x: lin,
            y: lin,
            z: lin,
            a: (k == FiveAxisKind::AcTable).then_some(rot),
            b: (k == FiveAxisKind::BcTable).then_some(rot),
            c: Some(RotaryAxis::new(-400.0, 400.0, 90.0, 360.0)),
        }
        .build()
        .unwrap()
    }

    /// Independent forward kinematics of a table machine: the part's
    /// homogeneous transform composed joint by joint, then the tool tip and
    /// axis (machine +z) carried back into the part.
    fn fk_matrices(m: &FiveAxis, l: f64, q: &[f64; 5]) -> ([f64; 3], [f64; 3]) {
        let t = |p: [f64; 3]| Translation3::new(p[0], p[1], p[2]).to_homogeneous();
        let neg = |p: [f64; 3]| [-p[0], -p[1], -p[2]];
        let tilt_axis = if m.kinematics == FiveAxisKind::AcTable {
            Vector3::x_axis()
        } else {
            Vector3::y_axis()
        };
        let rt: Matrix4<f64> = Rotation3::from_axis_angle(&tilt_axis, q[3]).to_homogeneous();
        let rc: Matrix4<f64> =
            Rotation3::from_axis_angle(&Vector3::z_axis(), q[4]).to_homogeneous();
        let part = t(m.tilt_axis_point)
            * rt
            * t(neg(m.tilt_axis_point))
            * t(m.c_axis_point)
            * rc
            * t(neg(m.c_axis_point))
            * t(m.workpiece_origin);
        let inv = part.try_inverse().unwrap();
        let tip = inv * Vector4::new(q[0], q[1], q[2] - l, 1.0);
        let ax = inv * Vector4::new(0.0, 0.0, 1.0, 0.0);
        ([tip.x, tip.y, tip.z], [ax.x, ax.y, ax.z])
    }

    fn close(a: [f64; 3], b: [f64; 3], tol: f64) -> bool {
        (0..3).all(|k| (a[k] - b[k]).abs() <= tol)
    }

    #[test]
    fn table_forward_matches_composed_transforms_and_inverse_round_trips() {
        for k in [FiveAxisKind::AcTable, FiveAxisKind::BcTable] {
            let m = table(k);
            let l = 60.0;
            let mut prev: Option<[f64; 5]> = None;
            for i in 0..400 {
                let t = i as f64;
                let tip = [
                    80.0 * (0.37 * t).sin(),
                    60.0 * (0.11 * t).cos(),
                    20.0 * (0.05 * t).sin(),
                ];
                let polar = 1.9 * ((0.013 * t).sin()).abs();
                let az = 0.7 * t;
                let axis = [polar.sin() * az.cos(), polar.sin() * az.sin(), polar.cos()];
                let q = m.inverse(l, tip, axis, prev.as_ref(), 0.0).unwrap();
                let (tip2, axis2) = fk_matrices(&m, l, &q);
                assert!(
                    close(tip, tip2, 1e-9),
                    "{k:?} tip {tip:?} -> {q:?} -> {tip2:?}"
                );
                assert!(
                    close(axis, axis2, 1e-12),
                    "{k:?} axis {axis:?} -> {axis2:?}"
                );
                let (tip3, axis3) = m.forward(l, &q);
                assert!(close(tip3, tip2, 1e-9) && close(axis3, axis2, 1e-12));
                // The other branch: same axis, the part turned about it, X Y Z moved.
                let pi = std::f64::consts::PI;
                let other = m.joints_at(l, tip, [-q[3], q[4] + pi]);
                let (tip4, axis4) = fk_matrices(&m, l, &other);
                assert!(close(tip, tip4, 1e-9) && close(axis, axis4, 1e-12));
                if let Some(p) = prev {
                    assert!((q[4] - p[4]).abs() < 3.2, "C jumps {} -> {}", p[4], q[4]);
                }
                prev = Some(q);
            }
        }
    }

    #[test]
    fn the_head_is_mill5() {
        let cfg = Mill5Config::default();
        let m = FiveAxisConfig::from_mill5("mill5", &cfg).build().unwrap();
        let q = [2600.0, 900.0, 700.0, 0.4, -1.1];
        assert_eq!(m.forward(30.0, &q), mill5::forward(&cfg, 280.0, &q));
        let (tip, axis) = m.forward(30.0, &q);
        let back = m.inverse(30.0, tip, axis, Some(&q), 0.0).unwrap();
        assert!((0..5).all(|k| (back[k] - q[k]).abs() < 1e-9), "{back:?}");
        assert_eq!(m.limits, <[Axis; 5]>::try_from(cfg.limits()).unwrap());
    }

    #[test]
    fn definitions_name_what_is_missing_or_extra() {
        let mut cfg = FiveAxisConfig::from_mill5("m", &Mill5Config::default());
        cfg.c = None;
        let e = cfg.build().unwrap_err().to_string();
        assert!(
            e.contains("c: missing: ac_head kinematics needs the axes x, y, z, a, c"),
            "{e}"
        );
        let mut cfg = FiveAxisConfig::from_mill5("m", &Mill5Config::default());
        cfg.b = cfg.a;
        let e = cfg.build().unwrap_err().to_string();
        assert!(e.contains("b: ac_head kinematics has no b axis"), "{e}");
        let mut cfg = FiveAxisConfig::from_mill5("m", &Mill5Config::default());
        cfg.kinematics = FiveAxisKind::BcTable;
        let e = cfg.build().unwrap_err().to_string();
        assert!(e.contains("a: bc_table kinematics has no a axis"), "{e}");
    }
}
