//! Islands of a scallop simulation: the samples above the job's limit (or
//! never reached) grouped by what one repair pass covers, for the repair
//! passes and the warning that says where a plan falls short.

use crate::ABOVE_LIMIT;
use toolpath_planners as planners;
use toolpath_simulation::scallop::ScallopReport;

/// The warning for a plan the simulator finds above `h` (or not reaching
/// part of the surface): the largest islands, their area and where they are.
pub(crate) fn above_limit_warning(report: &ScallopReport, h: f64, radius: f64) -> String {
    const LISTED: usize = 5;
    let mut found = map_islands(report, h, radius);
    let cell = report.resolution_mm * report.resolution_mm;
    found.sort_by_key(|island| std::cmp::Reverse(island.uv.len()));
    let mut parts = Vec::new();
    for island in found.iter().take(LISTED) {
        let n = island.uv.len() as f64;
        let centre = island.xyz.iter().fold([0.0; 3], |acc, p| {
            [acc[0] + p[0] / n, acc[1] + p[1] / n, acc[2] + p[2] / n]
        });
        parts.push(format!(
            "{:.2} mm^2 around ({:.1}, {:.1}, {:.1}) mm",
            n * cell,
            centre[0],
            centre[1],
            centre[2]
        ));
    }
    if found.len() > LISTED {
        parts.push(format!("and {} more", found.len() - LISTED));
    }
    format!(
        "{ABOVE_LIMIT} {h} mm: the simulator finds {:.4} mm at most and {:.2} mm^2 the tool never reached; {}",
        report.max_scallop_mm,
        report.uncovered_area_mm2,
        if parts.is_empty() {
            "between grid samples".to_string()
        } else {
            parts.join("; ")
        }
    )
}

/// One island of the residual map: samples above the threshold (or not
/// reached), grouped.
pub(crate) struct MapIsland {
    pub uv: Vec<nalgebra::Vector2<f64>>,
    pub xyz: Vec<[f64; 3]>,
}

/// Groups the map's samples above h, or not reached, into islands:
/// samples closer than half the tool radius are one island (a pass over
/// one covers the other). A refined peak above h between the samples
/// joins the island within that reach, or is an island of its own.
pub(crate) fn islands(
    report: &ScallopReport,
    h: f64,
    radius: f64,
) -> Vec<planners::strip_width::repair::Island> {
    map_islands(report, h, radius)
        .iter()
        .map(|m| planners::strip_width::repair::Island {
            uv: m.uv.clone(),
            spacing_mm: report.resolution_mm,
        })
        .collect()
}

fn map_islands(report: &ScallopReport, h: f64, radius: f64) -> Vec<MapIsland> {
    let map = &report.map;
    let (nu, nv) = (map.nu, map.nv);
    let flagged: Vec<bool> = map
        .residual
        .iter()
        .enumerate()
        .map(|(k, r)| map.on_face(k) && r.is_none_or(|r| r > h))
        .collect();
    let reach = ((0.5 * radius / report.resolution_mm.max(1e-9)).round() as i64).max(1);
    let mut seen = vec![false; flagged.len()];
    let mut out = Vec::new();
    for start in 0..flagged.len() {
        if !flagged[start] || seen[start] {
            continue;
        }
        seen[start] = true;
        let mut stack = vec![start];
        let mut island = MapIsland {
            uv: Vec::new(),
            xyz: Vec::new(),
        };
        while let Some(k) = stack.pop() {
            island
                .uv
                .push(nalgebra::Vector2::new(map.uv[k][0], map.uv[k][1]));
            island.xyz.push(map.xyz[k]);
            let (i, j) = ((k / nv) as i64, (k % nv) as i64);
            for a in (i - reach).max(0)..=(i + reach).min(nu as i64 - 1) {
                for b in (j - reach).max(0)..=(j + reach).min(nv as i64 - 1) {
                    let q = a as usize * nv + b as usize;
                    if flagged[q] && !seen[q] {
                        seen[q] = true;
                        stack.push(q);
                    }
                }
            }
        }
        out.push(island);
    }
    // Peaks between the samples: only where the refined residual itself is
    // above h (lowering the grid threshold instead flags every sample
    // near that level, on a whole surface spaced for 0.9 h).
    let reach_mm = 0.5 * radius;
    for peak in report.peaks.iter().filter(|p| p.residual > h) {
        let at = nalgebra::Point3::from(peak.xyz);
        let near = out.iter_mut().find(|island| {
            island
                .xyz
                .iter()
                .any(|q| (nalgebra::Point3::from(*q) - at).norm() <= reach_mm)
        });
        match near {
            Some(island) => {
                island
                    .uv
                    .push(nalgebra::Vector2::new(peak.uv[0], peak.uv[1]));
                island.xyz.push(peak.xyz);
            }
            None => out.push(MapIsland {
                uv: vec![nalgebra::Vector2::new(peak.uv[0], peak.uv[1])],
                xyz: vec![peak.xyz],
            }),
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ABOVE_LIMIT;
    use toolpath_simulation::scallop::ResidualMap;

    /// A 10 x 10 map with 1 mm cells at (i, j, 0), residual 0.01 mm except
    /// where `set` says.
    fn report(set: &[((usize, usize), Option<f64>)], max_scallop: f64) -> ScallopReport {
        let (nu, nv) = (10, 10);
        let mut map = ResidualMap {
            nu,
            nv,
            uv: Vec::new(),
            xyz: Vec::new(),
            residual: Vec::new(),
            off_face: Vec::new(),
        };
        for i in 0..nu {
            for j in 0..nv {
                map.uv
                    .push([(i as f64 + 0.5) / 10.0, (j as f64 + 0.5) / 10.0]);
                map.xyz.push([i as f64, j as f64, 0.0]);
                let r = set
                    .iter()
                    .find(|(k, _)| *k == (i, j))
                    .map_or(Some(0.01), |(_, r)| *r);
                map.residual.push(r);
            }
        }
        ScallopReport {
            max_scallop_mm: max_scallop,
            max_gouge_mm: 0.0,
            uncovered_area_mm2: 1.0,
            machined_area_mm2: 99.0,
            resolution_mm: 1.0,
            map,
            peaks: Vec::new(),
        }
    }

    #[test]
    fn islands_group_near_samples_and_the_warning_says_where() {
        let high = Some(0.08);
        let r = report(
            &[
                ((2, 2), high),
                ((2, 3), high),
                ((3, 2), high),
                ((3, 3), high),
                ((8, 8), None),
            ],
            0.08,
        );
        // Reach: half the 2.5 mm radius = 1 cell; the block and the unreached
        // sample are 5 cells apart.
        let found = islands(&r, 0.05, 2.5);
        let mut sizes: Vec<usize> = found.iter().map(|i| i.uv.len()).collect();
        sizes.sort();
        assert_eq!(sizes, [1, 4]);
        let w = above_limit_warning(&r, 0.05, 2.5);
        assert!(w.starts_with(ABOVE_LIMIT), "{w}");
        assert!(
            w.contains("4.00 mm^2 around (2.5, 2.5, 0.0) mm; 1.00 mm^2 around (8.0, 8.0, 0.0) mm"),
            "{w}"
        );
        assert!(w.contains("0.0800 mm at most and 1.00 mm^2"), "{w}");
    }

    #[test]
    fn a_peak_above_h_between_samples_is_an_island_of_its_own() {
        use toolpath_simulation::scallop::RefinedPeak;
        let peak = |xyz: [f64; 3], residual| RefinedPeak {
            uv: [(xyz[0] + 0.5) / 10.0, (xyz[1] + 0.5) / 10.0],
            xyz,
            residual,
        };
        // Grid samples just below h near the peak and far from it: only
        // the refined peak's own place is repaired, not every sample near
        // the grid maximum.
        let mut r = report(
            &[
                ((5, 5), Some(0.049)),
                ((5, 6), Some(0.048)),
                ((1, 1), Some(0.0485)),
            ],
            0.052,
        );
        r.peaks = vec![peak([5.3, 5.4, 0.0], 0.052), peak([1.0, 1.0, 0.0], 0.0485)];
        let found = islands(&r, 0.05, 2.5);
        assert_eq!(found.len(), 1);
        assert_eq!(found[0].uv.len(), 1);
        assert!((found[0].uv[0].x - 0.58).abs() < 1e-12);
        assert!((found[0].uv[0].y - 0.59).abs() < 1e-12);
        // A peak within half the radius of a grid island joins it.
        let mut r = report(&[((2, 2), Some(0.08))], 0.09);
        r.peaks = vec![peak([2.6, 2.7, 0.0], 0.09)];
        let found = islands(&r, 0.05, 2.5);
        assert_eq!(found.len(), 1);
        assert_eq!(found[0].uv.len(), 2);
        // Within h on the grid and refined: no island.
        let mut r = report(&[((5, 5), Some(0.049))], 0.0495);
        r.peaks = vec![peak([5.2, 5.0, 0.0], 0.0495)];
        assert!(islands(&r, 0.05, 2.5).is_empty());
    }
}
