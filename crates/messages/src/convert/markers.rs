//! The RViz markers of a plan.

use super::MM;
use crate as msgs;
use toolpath_formats::PlanResult;
use toolpath_machines as machines;

/// Region colours (a qualitative palette), cycled.
const PALETTE: [[f32; 3]; 8] = [
    [0.12, 0.47, 0.71],
    [1.0, 0.5, 0.05],
    [0.17, 0.63, 0.17],
    [0.84, 0.15, 0.16],
    [0.58, 0.4, 0.74],
    [0.55, 0.34, 0.29],
    [0.89, 0.47, 0.76],
    [0.5, 0.5, 0.5],
];

/// RViz markers: a DELETEALL, then the passes as line strips coloured by region
/// (cl points), degenerate points as spheres, separatrices as line strips. Metres.
pub fn markers(result: &PlanResult, header: msgs::Header) -> msgs::MarkerArray {
    let p = |x: [f64; 3]| msgs::Point {
        x: x[0] * MM,
        y: x[1] * MM,
        z: x[2] * MM,
    };
    let base = |ns: &str, id: i32, marker_type: i32, color: [f32; 3], width: f64| msgs::Marker {
        header: header.clone(),
        ns: ns.into(),
        id,
        marker_type,
        action: msgs::Marker::ADD,
        scale: msgs::Vector3 {
            x: width,
            y: width,
            z: width,
        },
        color: msgs::ColorRGBA {
            r: color[0],
            g: color[1],
            b: color[2],
            a: 1.0,
        },
        ..Default::default()
    };
    let mut out = vec![msgs::Marker {
        header: header.clone(),
        action: msgs::Marker::DELETEALL,
        ..Default::default()
    }];
    for (id, pass) in machines::tool_poses(result).into_iter().enumerate() {
        let region = result.passes.get(id).map_or(0, |q| q.region);
        let mut m = base(
            "passes",
            i32::try_from(id).unwrap_or(i32::MAX),
            msgs::Marker::LINE_STRIP,
            PALETTE[region % PALETTE.len()],
            0.0005,
        );
        m.points = pass.iter().map(|t| p(t.tip)).collect();
        out.push(m);
    }
    if let Some(d) = &result.degenerate_points {
        let mut m = base(
            "degenerate_points",
            0,
            msgs::Marker::SPHERE_LIST,
            [0.0, 0.0, 0.0],
            0.003,
        );
        m.points = d.iter().map(|q| p(q.xyz)).collect();
        out.push(m);
    }
    for (k, s) in result.separatrices.iter().flatten().enumerate() {
        let mut m = base(
            "separatrices",
            k as i32,
            msgs::Marker::LINE_STRIP,
            [0.0, 0.0, 0.0],
            0.001,
        );
        m.points = s.iter().map(|q| p(*q)).collect();
        out.push(m);
    }
    msgs::MarkerArray { markers: out }
}
