//! Inverse kinematics of passes of poses as JSON, for checks from outside
//! (tests/python/test_kinematics_pin.py checks the joints with pinocchio).
//!
//! `ik_json [REQUEST.json]` (stdin without an argument) prints the answer on
//! stdout. Request (lengths mm, angles rad):
//! ```json
//! {"urdf": "ur5.urdf", "base_link": "base_link", "tool_link": "tool0",
//!  "holds": "tool",                       // or "part": tool_link carries the part
//!  "tcp_xyz_mm": [0,0,0], "tcp_rpy": [0,0,0],            // the TCP on tool_link
//!                                          // ("part": the fixed tool in the base)
//!  "workpiece_xyz_mm": [0,0,0], "workpiece_rpy": [0,0,0], // the workpiece on part_link
//!  "part_link": null,                      // default the base ("part": tool_link)
//!  "solver": "auto",                       // or "numeric"
//!  "limits": [{"joint": "elbow_joint", "lower": -1.0, "upper": 1.0}],
//!  "start": null,                          // joints before the first pass
//!  "passes": [[{"tip": [..], "axis": [..]}, {"xyz_mm": [..], "quat_xyzw": [..]}]]}
//! ```
//! Answer: `{"joint_names": [..], "solver": "..", "passes": [{"ok": true,
//! "joints": [[..]]} | {"ok": false, "kind": "..", "pass": p, "point": k,
//! "joint": ".."|null, "message": ".."}]}`. Each pass starts from the last
//! joints of the previous pass that was solved.

use serde::Deserialize;
use serde_json::{json, Value};
use std::io::Read;
use toolpath_kinematics::{
    xyz_rpy, LimitOverride, Machine, MachineDef, SolverChoice, Target, UrdfModel,
};

#[derive(Deserialize)]
#[serde(untagged)]
enum Pose {
    Axis {
        tip: [f64; 3],
        axis: [f64; 3],
    },
    Frame {
        xyz_mm: [f64; 3],
        quat_xyzw: [f64; 4],
    },
}

#[derive(Deserialize)]
struct Limit {
    joint: String,
    lower: Option<f64>,
    upper: Option<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Request {
    urdf: String,
    base_link: String,
    tool_link: String,
    #[serde(default = "tool")]
    holds: String,
    #[serde(default)]
    tcp_xyz_mm: [f64; 3],
    #[serde(default)]
    tcp_rpy: [f64; 3],
    /// The link carrying the workpiece (a table); default the base link.
    #[serde(default)]
    part_link: Option<String>,
    #[serde(default)]
    workpiece_xyz_mm: [f64; 3],
    #[serde(default)]
    workpiece_rpy: [f64; 3],
    #[serde(default)]
    solver: Option<String>,
    #[serde(default)]
    limits: Vec<Limit>,
    #[serde(default)]
    start: Option<Vec<f64>>,
    passes: Vec<Vec<Pose>>,
}

fn tool() -> String {
    "tool".into()
}

fn machine(r: &Request) -> Result<Machine, String> {
    let text = std::fs::read_to_string(&r.urdf).map_err(|e| format!("{}: {e}", r.urdf))?;
    let model = UrdfModel::parse(&text).map_err(|e| e.to_string())?;
    let tcp = xyz_rpy(r.tcp_xyz_mm, r.tcp_rpy);
    let wp = xyz_rpy(r.workpiece_xyz_mm, r.workpiece_rpy);
    let mut def = match r.holds.as_str() {
        "tool" => MachineDef::holds_tool(&r.base_link, &r.tool_link, tcp, wp),
        "part" => MachineDef::holds_part(&r.base_link, &r.tool_link, wp, tcp),
        other => return Err(format!("holds: {other:?} is neither \"tool\" nor \"part\"")),
    };
    if let Some(p) = &r.part_link {
        def.part_link = p.clone();
    }
    def.limits = r
        .limits
        .iter()
        .map(|l| LimitOverride {
            joint: l.joint.clone(),
            lower: l.lower,
            upper: l.upper,
            ..Default::default()
        })
        .collect();
    let m = Machine::from_urdf(&model, &def).map_err(|e| e.to_string())?;
    Ok(match r.solver.as_deref() {
        Some("numeric") => m.with_solver(SolverChoice::Numeric),
        _ => m,
    })
}

fn answer(r: &Request) -> Result<Value, String> {
    let m = machine(r)?;
    let mut start = r.start.clone();
    let mut passes = Vec::with_capacity(r.passes.len());
    for (p, poses) in r.passes.iter().enumerate() {
        let targets: Result<Vec<Target>, _> = poses
            .iter()
            .map(|x| match x {
                Pose::Axis { tip, axis } => Target::axis(*tip, *axis),
                Pose::Frame { xyz_mm, quat_xyzw } => Target::frame(*xyz_mm, *quat_xyzw),
            })
            .collect();
        let solved = targets.and_then(|t| m.solve_pass(p, &t, start.as_deref()));
        passes.push(match solved {
            Ok(rows) => {
                start = rows.last().cloned().or(start);
                json!({"ok": true, "joints": rows})
            }
            Err(e) => json!({
                "ok": false,
                "kind": e.kind(),
                "pass": e.at().map(|a| a.pass),
                "point": e.at().map(|a| a.point),
                "joint": e.joint(),
                "message": e.to_string(),
            }),
        });
    }
    Ok(json!({"joint_names": m.joint_names(), "solver": m.solver_name(), "passes": passes}))
}

fn main() {
    let mut text = String::new();
    let read = match std::env::args().nth(1) {
        Some(path) => std::fs::read_to_string(&path).map(|t| text = t),
        None => std::io::stdin().read_to_string(&mut text).map(|_| ()),
    };
    let out = read
        .map_err(|e| e.to_string())
        .and_then(|_| serde_json::from_str::<Request>(&text).map_err(|e| format!("request: {e}")))
        .and_then(|r| answer(&r));
    match out {
        Ok(v) => println!("{v}"),
        Err(e) => {
            eprintln!("ik_json: {e}");
            std::process::exit(2);
        }
    }
}
