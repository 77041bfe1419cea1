//! Times a joint path given as JSON on stdin and writes the result as JSON
//! on stdout (used by the Python comparison with the `toppra` package).
//!
//! Input: `positions` (rows), `velocity`, `acceleration`, optional `jerk`,
//! optional `tip_speed_cap` (mm/s on every segment; the tool tip is the
//! first three joints), optional `stops`, `min_intervals`, `margin`.
//! Output: `s` (waypoint parameters), `topp_duration`, `grid` (s, s_dot,
//! time), `trajectory` (times, positions, velocities, accelerations) and the
//! sampled `report`.

use serde_json::{json, Value};
use std::io::Read;
use std::process::ExitCode;
use toolpath_motion::{
    plan, Limits, Options, Parameter, Path, Segment, SegmentKind, Tips, ToolPose,
};

fn rows(v: &Value, what: &str) -> Result<Vec<Vec<f64>>, String> {
    v.get(what)
        .and_then(Value::as_array)
        .ok_or(format!("{what}: missing or not a list"))?
        .iter()
        .enumerate()
        .map(|(k, r)| numbers(r, &format!("{what}[{k}]")))
        .collect()
}

fn numbers(v: &Value, what: &str) -> Result<Vec<f64>, String> {
    v.as_array()
        .ok_or(format!("{what}: not a list"))?
        .iter()
        .enumerate()
        .map(|(j, x)| x.as_f64().ok_or(format!("{what}[{j}]: not a number")))
        .collect()
}

fn first_three(q: &[f64]) -> ToolPose {
    ToolPose {
        tip: [q[0], q[1], q.get(2).copied().unwrap_or(0.0)],
        axis: [0.0, 0.0, 1.0],
    }
}

fn run(input: &Value) -> Result<Value, String> {
    let q = rows(input, "positions")?;
    let vel = numbers(&input["velocity"], "velocity")?;
    let acc = numbers(&input["acceleration"], "acceleration")?;
    let mut limits = Limits::new(vel, acc);
    if let Some(j) = input.get("jerk").filter(|j| !j.is_null()) {
        limits = limits.with_jerk(numbers(j, "jerk")?);
    }
    let cap = input.get("tip_speed_cap").and_then(Value::as_f64);
    let stops: Vec<usize> = match input.get("stops") {
        Some(s) if !s.is_null() => numbers(s, "stops")?.iter().map(|&x| x as usize).collect(),
        _ => Vec::new(),
    };
    let segs = vec![
        Segment {
            kind: SegmentKind::Cut,
            tip_speed_cap: cap,
        };
        q.len().saturating_sub(1)
    ];
    let mut options = Options::default();
    if let Some(m) = input.get("min_intervals").and_then(Value::as_u64) {
        options.min_intervals = m as usize;
    }
    if let Some(m) = input.get("margin").and_then(Value::as_f64) {
        options.margin = m;
    }
    let param = Parameter::ScaledJointChord;
    let tips = if cap.is_some() {
        Tips::Kinematics(&first_three)
    } else {
        Tips::None
    };
    let path = Path {
        positions: &q,
        segments: &segs,
        stops: &stops,
        tips,
        parameter: &param,
    };
    let started = std::time::Instant::now();
    let pl = plan(&path, &limits, &options, None).map_err(|e| e.to_string())?;
    let plan_s = started.elapsed().as_secs_f64();
    let grid = pl.timing.grid();
    let tr = &pl.trajectory;
    let topp: f64 = (0..pl.timing.profiles().len())
        .map(|p| pl.timing.profiles()[p].optimal().duration())
        .sum();
    let r = &pl.report.kinds[&SegmentKind::Cut];
    Ok(json!({
        "s": pl.timing.s,
        "topp_duration": topp,
        "duration": tr.duration(),
        "stretch": pl.timing.stretch(),
        "plan_s": plan_s,
        "grid": {
            "s": grid.iter().map(|g| g.s).collect::<Vec<_>>(),
            "s_dot": grid.iter().map(|g| g.s_dot).collect::<Vec<_>>(),
            "time": grid.iter().map(|g| g.time).collect::<Vec<_>>(),
        },
        "trajectory": {
            "times": tr.times,
            "s": tr.s,
            "positions": tr.positions,
            "velocities": tr.velocities,
            "accelerations": tr.accelerations,
        },
        "report": {
            "max_velocity_ratio": r.max_velocity_ratio,
            "max_acceleration_ratio": r.max_acceleration_ratio,
            "max_jerk_ratio": r.max_jerk_ratio,
        },
    }))
}

fn main() -> ExitCode {
    let mut text = String::new();
    if let Err(e) = std::io::stdin().read_to_string(&mut text) {
        eprintln!("stdin: {e}");
        return ExitCode::from(2);
    }
    let input: Value = match serde_json::from_str(&text) {
        Ok(v) => v,
        Err(e) => {
            eprintln!("input: not JSON: {e}");
            return ExitCode::from(2);
        }
    };
    match run(&input) {
        Ok(out) => {
            println!("{out}");
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("{e}");
            ExitCode::from(2)
        }
    }
}
