//! Tool sizes by the rules of the medial-axis method (docs/methods.md, "Tool
//! sequence"), rounded to the available catalogue (sorted ascending).

use toolpath_kernel::error::{Error, Result};

/// Slack for comparing computed diameters with catalogue sizes, mm.
const EPS: f64 = 1e-9;

/// Roughing: the smallest catalogue diameter in [Dmax/2, Dmax] (one contour
/// pass clears the whole machinable region and the smaller the tool the larger
/// that region); if the catalogue has none there, the largest one below
/// Dmax/2 (several contour passes). A pocket narrower than every tool is an error.
pub(crate) fn roughing_diameter(dmax: f64, catalogue: &[f64]) -> Result<f64> {
    let Some(&smallest) = catalogue.first() else {
        return Err(Error::invalid(
            "tool_catalogue",
            "is empty: list at least one tool diameter",
        ));
    };
    if let Some(&d) = catalogue
        .iter()
        .find(|&&d| d >= 0.5 * dmax - EPS && d <= dmax + EPS)
    {
        return Ok(d);
    }
    catalogue.iter().rev().copied().find(|&d| d <= dmax + EPS).ok_or_else(|| {
        Error::invalid(
            "tool_catalogue",
            format!(
                "the pocket is narrower than the smallest tool: its largest inscribed circle has diameter \
                 {dmax:.3} mm, the smallest catalogue tool {smallest} mm"
            ),
        )
    })
}

/// Corner/neck cleaning after a tool of diameter `previous`: the smallest
/// catalogue diameter D1 with Dmax1/2 <= D1 < previous, where Dmax1 is the
/// largest medial-axis circle diameter left unmachined (one pass then clears
/// the residual); if none satisfies Dmax1/2 <= D1, the largest below `previous`.
pub(crate) fn cleaning_diameter(dmax1: f64, previous: f64, catalogue: &[f64]) -> Option<f64> {
    let smaller = catalogue.iter().copied().filter(|&d| d < previous - EPS);
    let mut fallback = None;
    for d in smaller {
        if d >= 0.5 * dmax1 - EPS {
            return Some(d);
        }
        fallback = Some(d);
    }
    fallback
}

/// Root cleaning: the largest catalogue diameter not above twice the minimum
/// concave-corner radius; the smallest tool when even that is too large
/// (sharp corners: what it cannot reach stays uncut and is reported).
pub(crate) fn root_diameter(min_corner_radius: f64, catalogue: &[f64]) -> Option<f64> {
    catalogue
        .iter()
        .rev()
        .copied()
        .find(|&d| d <= 2.0 * min_corner_radius + EPS)
        .or_else(|| catalogue.first().copied())
}

#[cfg(test)]
mod tests {
    use super::*;
    use toolpath_formats::job::DEFAULT_TOOL_CATALOGUE;

    #[test]
    fn paper_rules_on_the_default_catalogue() {
        let c = DEFAULT_TOOL_CATALOGUE;
        // Rectangle 100 x 60: Dmax = 60 -> 30 mm (R = 15), as in
        // docs/methods.md, "Pocket references".
        assert_eq!(roughing_diameter(60.0, &c).unwrap(), 30.0);
        // Leaf of the paper: Dmax = 46.856 -> 25 in this catalogue (24 in the paper's).
        assert_eq!(roughing_diameter(46.856, &c).unwrap(), 25.0);
        // Only tools below Dmax/2: the largest of them.
        assert_eq!(roughing_diameter(60.0, &[1.0, 5.0, 10.0]).unwrap(), 10.0);
        assert!(roughing_diameter(0.8, &c).is_err());
        assert!(roughing_diameter(10.0, &[]).is_err());
        // Dmax1 = 8.787 after R = 15 -> 5 mm.
        assert_eq!(cleaning_diameter(8.787, 30.0, &c), Some(5.0));
        assert_eq!(cleaning_diameter(8.787, 4.0, &c), Some(3.0));
        assert_eq!(cleaning_diameter(8.787, 1.0, &c), None);
        assert_eq!(root_diameter(0.658, &c), Some(1.0));
        assert_eq!(root_diameter(0.0, &c), Some(1.0));
        assert_eq!(root_diameter(18.0, &c), Some(35.0));
    }
}
