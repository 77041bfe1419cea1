//! Surfaces (with their trims) and pockets as messages and back.

use crate as msgs;
use toolpath_formats::shape::{BsplineCurveFile, TrimCurveFile};
use toolpath_formats::TrimFile;
use toolpath_kernel::error::{Error, Result};
use toolpath_kernel::geometry::{NurbsSurface, Pocket};

/// A surface message as a validated surface. Errors name `surface "<id>".<field>`.
pub fn surface_from_msg(m: &msgs::Surface) -> Result<NurbsSurface> {
    let ctx = format!("surface \"{}\"", m.surface_id);
    let inner = || -> Result<NurbsSurface> {
        if m.surface_id.trim().is_empty() {
            return Err(Error::invalid("surface_id", "must not be empty"));
        }
        let (cu, cv) = (m.count_u as usize, m.count_v as usize);
        if cu.checked_mul(cv) != Some(m.control_points.len()) {
            return Err(Error::invalid(
                "control_points",
                format!(
                    "has {} points, but count_u x count_v = {} x {} needs {}",
                    m.control_points.len(),
                    cu,
                    cv,
                    cu.saturating_mul(cv)
                ),
            ));
        }
        if cu == 0 || cv == 0 {
            return Err(Error::invalid(
                "count_u",
                "count_u and count_v must be at least 1",
            ));
        }
        if !m.weights.is_empty() && m.weights.len() != m.control_points.len() {
            return Err(Error::invalid(
                "weights",
                format!(
                    "has {} values; give none (non-rational) or one per control point ({})",
                    m.weights.len(),
                    m.control_points.len()
                ),
            ));
        }
        let grid: Vec<Vec<[f64; 3]>> = m
            .control_points
            .chunks(cv)
            .map(|row| row.iter().map(|p| p.to_array()).collect())
            .collect();
        let weights: Option<Vec<Vec<f64>>> =
            (!m.weights.is_empty()).then(|| m.weights.chunks(cv).map(|r| r.to_vec()).collect());
        let surface = NurbsSurface::new(
            m.degree_u as usize,
            m.degree_v as usize,
            m.knots_u.clone(),
            m.knots_v.clone(),
            &grid,
            weights.as_deref(),
        )?;
        match trim_from_msg(m)? {
            Some(t) => Ok(surface
                .clone()
                .with_trim(t.to_trim(&surface).map_err(|e| e.within("trim_loops"))?)),
            None => Ok(surface),
        }
    };
    inner().map_err(|e| e.within(&ctx))
}

/// The trim of a surface message in the file format's terms (validated by
/// the same `TrimFile::to_trim` as a file's): loop 0 the outer, the rest holes.
fn trim_from_msg(m: &msgs::Surface) -> Result<Option<TrimFile>> {
    if m.trim_loops.is_empty() {
        if m.trim_tolerance != 0.0 {
            return Err(Error::invalid(
                "trim_tolerance",
                "is set but trim_loops is empty",
            ));
        }
        return Ok(None);
    }
    let curve = |l: usize, c: usize, t: &msgs::TrimCurve| -> Result<TrimCurveFile> {
        let field = format!("trim_loops[{l}].curves[{c}]");
        if !t.points_uv.len().is_multiple_of(2) {
            return Err(Error::invalid(
                format!("{field}.points_uv"),
                format!("has {} values: give u, v pairs", t.points_uv.len()),
            ));
        }
        let points: Vec<[f64; 2]> = t.points_uv.chunks(2).map(|p| [p[0], p[1]]).collect();
        if t.degree == 0 {
            if !t.knots.is_empty() || !t.weights.is_empty() {
                return Err(Error::invalid(
                    field,
                    "is a polyline (degree 0) and takes no knots or weights",
                ));
            }
            return Ok(TrimCurveFile::Polyline(points));
        }
        Ok(TrimCurveFile::Bspline(BsplineCurveFile {
            degree: t.degree as usize,
            knots: t.knots.clone(),
            control_points: points,
            weights: (!t.weights.is_empty()).then(|| t.weights.clone()),
        }))
    };
    let mut loops = m.trim_loops.iter().enumerate().map(|(l, lp)| {
        lp.curves
            .iter()
            .enumerate()
            .map(|(c, t)| curve(l, c, t))
            .collect::<Result<Vec<_>>>()
    });
    let outer = loops.next().transpose()?.unwrap_or_default();
    let holes = loops.collect::<Result<Vec<_>>>()?;
    Ok(Some(TrimFile {
        tolerance: (m.trim_tolerance != 0.0).then_some(m.trim_tolerance),
        outer,
        holes,
    }))
}

/// The trim of a surface as message loops (outer first).
fn trim_to_msg(s: &NurbsSurface) -> (Vec<msgs::TrimLoop>, f64) {
    let Some(t) = s.trim() else {
        return (Vec::new(), 0.0);
    };
    let f = TrimFile::from_trim(t);
    let curve = |c: &TrimCurveFile| match c {
        TrimCurveFile::Polyline(p) => msgs::TrimCurve {
            degree: 0,
            points_uv: p.iter().flatten().copied().collect(),
            ..Default::default()
        },
        TrimCurveFile::Bspline(b) => msgs::TrimCurve {
            degree: b.degree as u32,
            knots: b.knots.clone(),
            points_uv: b.control_points.iter().flatten().copied().collect(),
            weights: b.weights.clone().unwrap_or_default(),
        },
    };
    let lp = |l: &[TrimCurveFile]| msgs::TrimLoop {
        curves: l.iter().map(curve).collect(),
    };
    let mut loops = vec![lp(&f.outer)];
    loops.extend(f.holes.iter().map(|h| lp(h)));
    (loops, f.tolerance.unwrap_or(0.0))
}

/// A surface as a message (control points row-major, i along u).
pub fn surface_to_msg(id: &str, s: &NurbsSurface, header: msgs::Header) -> msgs::Surface {
    let grid = s.control_grid();
    let (trim_loops, trim_tolerance) = trim_to_msg(s);
    msgs::Surface {
        header,
        surface_id: id.to_string(),
        degree_u: s.degree_u() as u32,
        degree_v: s.degree_v() as u32,
        knots_u: s.knots_u().to_vec(),
        knots_v: s.knots_v().to_vec(),
        count_u: s.count_u() as u32,
        count_v: s.count_v() as u32,
        control_points: grid
            .iter()
            .flatten()
            .map(|p| msgs::Point::from_array(*p))
            .collect(),
        weights: s
            .weight_grid()
            .map(|w| w.into_iter().flatten().collect())
            .unwrap_or_default(),
        trim_loops,
        trim_tolerance,
    }
}

/// A pocket message as a validated pocket.
pub fn pocket_from_msg(m: &msgs::Pocket) -> Result<Pocket> {
    let ctx = format!("pocket \"{}\"", m.pocket_id);
    if m.pocket_id.trim().is_empty() {
        return Err(Error::invalid("pocket_id", "must not be empty").within(&ctx));
    }
    let xy = |l: &msgs::PocketLoop| {
        l.points
            .iter()
            .map(|p| [p.x, p.y])
            .collect::<Vec<[f64; 2]>>()
    };
    let holes: Vec<Vec<[f64; 2]>> = m.holes.iter().map(xy).collect();
    Pocket::new(&xy(&m.outer), &holes).map_err(|e| e.within(&ctx))
}

pub fn pocket_to_msg(id: &str, p: &Pocket, header: msgs::Header) -> msgs::Pocket {
    let lp = |l: &[[f64; 2]]| msgs::PocketLoop {
        points: l
            .iter()
            .map(|q| msgs::Point {
                x: q[0],
                y: q[1],
                z: 0.0,
            })
            .collect(),
    };
    msgs::Pocket {
        header,
        pocket_id: id.to_string(),
        outer: lp(&p.outer),
        holes: p.holes.iter().map(|h| lp(h)).collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use toolpath_formats::Shape;

    fn surface_msg() -> msgs::Surface {
        surface_to_msg(
            "plane",
            &toolpath_samples::surfaces::plane(),
            msgs::Header::default(),
        )
    }

    #[test]
    fn surface_round_trips_through_its_message() {
        let s = toolpath_samples::surfaces::plane();
        assert_eq!(surface_from_msg(&surface_msg()).unwrap(), s);
    }

    #[test]
    fn a_trimmed_surface_round_trips_through_its_message() {
        let Shape::Surface(s) = toolpath_samples::shape("trimmed_saddle").unwrap() else {
            panic!("trimmed_saddle is a surface");
        };
        let t = s.trim().unwrap();
        let m = surface_to_msg("trimmed_saddle", &s, msgs::Header::default());
        assert_eq!(m.trim_loops.len(), 1 + t.holes.len());
        let back = surface_from_msg(&m).unwrap();
        assert_eq!(back, s);
        assert_eq!(back.trim().unwrap().outer, t.outer);
        // The trim is checked as a file's: a hole outside the outer loop.
        let mut bad = m.clone();
        bad.trim_loops[1] = msgs::TrimLoop {
            curves: vec![msgs::TrimCurve {
                degree: 0,
                points_uv: vec![5.0, 5.0, 6.0, 5.0, 6.0, 6.0, 5.0, 5.0],
                ..Default::default()
            }],
        };
        let e = surface_from_msg(&bad).unwrap_err().to_string();
        assert!(e.contains("surface \"trimmed_saddle\".trim_loops"), "{e}");
        let mut odd = m.clone();
        odd.trim_loops[0].curves[0].points_uv.push(0.5);
        let e = surface_from_msg(&odd).unwrap_err().to_string();
        assert!(e.contains("trim_loops[0].curves[0].points_uv"), "{e}");
    }

    #[test]
    fn bad_surfaces_name_the_field() {
        let mut m = surface_msg();
        m.control_points[5].y = f64::NAN;
        let e = surface_from_msg(&m).unwrap_err().to_string();
        assert_eq!(
            e,
            "invalid input: surface \"plane\".control_points[1][1]: has a coordinate that is not a finite number"
        );
        let mut m = surface_msg();
        m.control_points.pop();
        let e = surface_from_msg(&m).unwrap_err().to_string();
        assert!(
            e.contains("has 15 points, but count_u x count_v = 4 x 4 needs 16"),
            "{e}"
        );
        let mut m = surface_msg();
        m.weights = vec![1.0; 3];
        assert!(surface_from_msg(&m)
            .unwrap_err()
            .to_string()
            .contains("weights"));
    }
}
