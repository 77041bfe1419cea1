//! Paths refined where a simulation finds material above the job's limit
//! (docs/methods.md, "Belt refinement" and "MPEC refinement"), for the
//! strategies whose paths each lie on one level.
//!
//! The belt contact model steps each path by assuming the neighbouring
//! contact has the same feed; MPEC steps by strip widths measured at the
//! drive points. Where neighbouring paths are not parallel (iso-curves that
//! fan out from a pole or an apex, sections oblique to an edge) or the part
//! ends under the tool, the step can be too long. Every path of these
//! strategies lies on one level (iso-parametric belt and MPEC: its cross
//! parameter; iso-planar belt: its offset along the section normal), so a
//! place the simulation leaves above the limit lies between two levels or
//! beyond the last one. A gap left at s > h is first re-stepped aiming at
//! h x 0.95 h / s where the planner has a scallop to aim at (belts; the
//! scallop grows with the step, so the model's error there is divided out);
//! a gap still above h after that (a step the scallop does not limit), or
//! any gap of a planner without such an aim (MPEC), gets a path at its
//! middle level. A place beyond the last path gets a path at its own level.

use crate::strategy::PathLevels;
use nalgebra::Vector3;
use toolpath_formats::{FeedDirection, Job, PlanResult};
use toolpath_kernel::error::{Error, Result};

/// A node the removal simulation left above h: its uv, surface point and
/// how high it was left, mm.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Residual {
    pub uv: [f64; 2],
    pub point: [f64; 3],
    pub height: f64,
}

/// The re-stepping aims never below this share of h.
const MIN_FACTOR: f64 = 0.05;

/// What the refinement rounds changed: scallop targets of steps and added
/// paths, in level space.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Refinement {
    /// (lo, hi, factor): a step from a level in the gap [lo, hi] (towards it)
    /// aims at factor x h.
    pub tightened: Vec<(f64, f64, f64)>,
    /// Levels of added paths, sorted.
    pub added: Vec<f64>,
}

impl Refinement {
    /// The share of h a step aims at from `level`, towards higher levels
    /// (`up`) or lower ones.
    pub fn factor(&self, level: f64, up: bool) -> f64 {
        let product: f64 = self
            .tightened
            .iter()
            .filter(|&&(lo, hi, _)| {
                if up {
                    lo <= level && level < hi
                } else {
                    lo < level && level <= hi
                }
            })
            .map(|t| t.2)
            .product();
        product.max(MIN_FACTOR)
    }
}

/// How a round treats a gap left above h.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mode {
    /// Re-step it aiming below h by the ratio found.
    Tighten,
    /// Add a path at its middle level.
    Split,
}

/// How a belt strategy lays its paths on levels.
#[derive(Clone, Copy, Debug)]
enum Levels {
    /// Iso-parametric belt and MPEC: the level is `uv[index]` (the cross parameter).
    Cross { index: usize, range: f64 },
    /// Iso-planar: the level is `point . normal`.
    Plane { normal: Vector3<f64> },
}

impl Levels {
    fn of(job: &Job, result: &PlanResult) -> Result<Self> {
        match crate::strategy(job.strategy).path_levels() {
            Some(PathLevels::CrossParameter) => {
                let feed_u = job.feed_direction.unwrap_or(FeedDirection::U) == FeedDirection::U;
                let ((u0, u1), (v0, v1)) = job.surface()?.domain();
                Ok(if feed_u {
                    Self::Cross {
                        index: 1,
                        range: v1 - v0,
                    }
                } else {
                    Self::Cross {
                        index: 0,
                        range: u1 - u0,
                    }
                })
            }
            Some(PathLevels::SectionPlane) => {
                let n = result.section_normal.ok_or_else(|| {
                    Error::planning(
                        "internal: an iso-planar belt result without its section normal",
                    )
                })?;
                Ok(Self::Plane {
                    normal: Vector3::new(n[0], n[1], n[2]),
                })
            }
            None => Err(Error::planning(format!(
                "internal: refinement asked for strategy {}",
                job.strategy.name()
            ))),
        }
    }

    fn level(&self, uv: [f64; 2], point: [f64; 3]) -> f64 {
        match *self {
            Self::Cross { index, .. } => uv[index],
            Self::Plane { normal } => Vector3::new(point[0], point[1], point[2]).dot(&normal),
        }
    }
}

/// One refinement round: finds the gaps between `result`'s path levels
/// that hold `residuals` above `h` (the job's scallop height or tolerance)
/// and records in `refinement` how they are treated (`mode`); a residual
/// beyond the first or last path adds the level of the farthest one. Returns
/// false when nothing could change (every gap holding a residual is already
/// below the levels' resolution).
pub fn refine(
    job: &Job,
    result: &PlanResult,
    residuals: &[Residual],
    h: f64,
    mode: Mode,
    refinement: &mut Refinement,
) -> Result<bool> {
    let levels_of = Levels::of(job, result)?;
    let mut levels: Vec<f64> = result
        .passes
        .iter()
        .filter_map(|p| p.points.first())
        .map(|q| levels_of.level(q.uv, q.cc))
        .filter(|l| l.is_finite())
        .collect();
    levels.sort_by(f64::total_cmp);
    let (Some(&lowest), Some(&highest)) = (levels.first(), levels.last()) else {
        return Ok(false);
    };
    // Levels closer than this are one (the sections of one plane, rounding).
    let scale = match levels_of {
        Levels::Cross { range, .. } => range,
        Levels::Plane { .. } => (highest - lowest).abs().max(1.0),
    };
    let resolution = 1e-9 * scale;
    levels.dedup_by(|b, a| *b - *a <= resolution);
    // Highest residual per gap [levels[k], levels[k + 1]].
    let mut worst = vec![0.0f64; levels.len().saturating_sub(1)];
    let (mut below, mut above): (Option<f64>, Option<f64>) = (None, None);
    for r in residuals {
        let x = levels_of.level(r.uv, r.point);
        if !x.is_finite() || r.height.is_nan() || r.height <= h {
            continue;
        }
        if x < lowest - resolution {
            below = Some(below.map_or(x, |b: f64| b.min(x)));
        } else if x > highest + resolution {
            above = Some(above.map_or(x, |a: f64| a.max(x)));
        } else {
            let k = levels.partition_point(|&l| l <= x).saturating_sub(1);
            if let Some(w) = worst.get_mut(k) {
                *w = w.max(r.height);
            }
        }
    }
    let mut changed = false;
    for (k, &s) in worst.iter().enumerate() {
        let (lo, hi) = (levels[k], levels[k + 1]);
        if s <= h || hi - lo <= 2.0 * resolution {
            continue;
        }
        match mode {
            Mode::Tighten => refinement.tightened.push((lo, hi, 0.95 * h / s)),
            Mode::Split => refinement.added.push(0.5 * (lo + hi)),
        }
        changed = true;
    }
    for level in below.into_iter().chain(above) {
        refinement.added.push(level);
        changed = true;
    }
    refinement.added.sort_by(f64::total_cmp);
    Ok(changed)
}

#[cfg(test)]
mod tests {
    use super::*;
    use toolpath_formats::{JobFile, Pass, PathPoint, Shape, Strategy};
    use toolpath_samples::surfaces;

    fn job(strategy: Strategy) -> Job {
        let file: JobFile = serde_json::from_value(serde_json::json!({
            "job_id": "refine",
            "surface": null,
            "strategy": strategy.name(),
            "tool": {"kind": "belt", "width": 10.0, "wheel_radius": 25.0},
            "scallop": 0.01,
        }))
        .unwrap();
        Job::new(file, Shape::Surface(surfaces::sphere_cap())).unwrap()
    }

    fn pass_at(uv: [f64; 2], cc: [f64; 3]) -> Pass {
        Pass {
            region: 0,
            points: vec![PathPoint {
                uv,
                cc,
                ..Default::default()
            }],
            min_strip_width: None,
        }
    }

    fn refined(job: &Job, result: &PlanResult, residuals: &[Residual], mode: Mode) -> Refinement {
        let mut refinement = Refinement::default();
        refine(job, result, residuals, 0.01, mode, &mut refinement).unwrap();
        refinement
    }

    #[test]
    fn iso_parametric_gaps_holding_residuals_are_split_or_tightened() {
        let job = job(Strategy::BeltIsoParametric);
        let mut result = PlanResult::new("refine", "belt_iso_parametric");
        for v in [0.0, 0.2, 0.5, 1.0] {
            result.passes.push(pass_at([0.3, v], [0.0; 3]));
        }
        let residual = |v: f64, height: f64| Residual {
            uv: [0.7, v],
            point: [0.0; 3],
            height,
        };
        // Two residuals in the gap 0.2..0.5, one in 0.5..1.0, one within h in 0..0.2.
        let found = [
            residual(0.3, 0.02),
            residual(0.45, 0.0125),
            residual(0.9, 0.019),
            residual(0.1, 0.009),
        ];
        let split = refined(&job, &result, &found, Mode::Split);
        assert_eq!(split.added, vec![0.35, 0.75]);
        assert!(split.tightened.is_empty());
        let tight = refined(&job, &result, &found, Mode::Tighten);
        assert!(tight.added.is_empty());
        assert_eq!(tight.tightened.len(), 2);
        assert_eq!((tight.tightened[0].0, tight.tightened[0].1), (0.2, 0.5));
        assert!((tight.tightened[0].2 - 0.95 * 0.01 / 0.02).abs() < 1e-15);
        // Steps from inside a gap, up or down, aim lower; elsewhere at h.
        assert!((tight.factor(0.2, true) - 0.475).abs() < 1e-15);
        assert_eq!(tight.factor(0.2, false), 1.0);
        assert!((tight.factor(0.5, false) - 0.475).abs() < 1e-15);
        assert_eq!(tight.factor(0.1, true), 1.0);
        let mut none = Refinement::default();
        assert!(!refine(&job, &result, &[], 0.01, Mode::Split, &mut none).unwrap());
        assert_eq!(none, Refinement::default());
    }

    #[test]
    fn iso_planar_levels_are_offsets_along_the_normal() {
        let job = job(Strategy::BeltIsoPlanar);
        let mut result = PlanResult::new("refine", "belt_iso_planar");
        result.section_normal = Some([0.0, 1.0, 0.0]);
        // Two sections on the plane y = 10, one on y = 20.
        for (x, y) in [(0.0, 10.0), (50.0, 10.0), (0.0, 20.0)] {
            result.passes.push(pass_at([0.0, 0.0], [x, y, 0.0]));
        }
        let residual = |y: f64| Residual {
            uv: [0.0, 0.0],
            point: [3.0, y, 7.0],
            height: 0.02,
        };
        let found = [residual(12.0), residual(4.0), residual(6.0), residual(25.0)];
        // The gap 10..20 halved; beyond the ends, the farthest node's level.
        assert_eq!(
            refined(&job, &result, &found, Mode::Split).added,
            vec![4.0, 15.0, 25.0]
        );
    }
}
