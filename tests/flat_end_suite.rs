//! The flat-end strategies on surfaces of the suite (`toolpath compare
//! --suite`, docs/results.md) through the pipeline, which verifies every
//! plan with the scallop simulator and repairs what it finds above h:
//! - tensor_regions is never longer than the shorter of iso_parametric and
//!   iso_scallop; where that baseline is at least 1.15 x the lower bound the
//!   target is 0.90 x the baseline, asserted on the surface here that meets
//!   it (over the whole suite it does not hold everywhere: docs/results.md);
//! - every strategy's plan is within h by the simulator, gouges at most
//!   0.005 mm and leaves nothing unreached, and says so (`within_scallop`);
//!   its passes do not cross each other (docs/methods.md, "Iso-scallop
//!   offsetting"), here and on the suite's most anisotropic surfaces.
//!
//! Plus the repair mechanism itself: a plan with a pass taken out gets it
//! back as repair passes, within h again.

use toolpath_planner::formats::{Job, PlanResult, Strategy};
use toolpath_planner::pipeline::{self, RunOptions};
use toolpath_planner::planners::strip_width::{crossings, lower_bound, tensor_regions};
use toolpath_planner::planners::{self, NoProgress};
use toolpath_planner::samples::{self, random};

const H: f64 = 0.05;
const GOUGE_LIMIT: f64 = 0.005;

fn run(job: &Job, strategy: Strategy) -> PlanResult {
    let mut j = job.clone();
    j.strategy = strategy;
    pipeline::run(&j, &NoProgress, RunOptions::default()).unwrap()
}

/// `room_target`: also assert tensor_regions <= 0.90 x the shorter
/// baseline where that baseline is >= 1.15 x the lower bound.
fn check_surface(name: &str, job: &Job, room_target: bool) {
    let results: Vec<PlanResult> = [
        Strategy::IsoParametric,
        Strategy::IsoScallop,
        Strategy::TensorRegions,
    ]
    .iter()
    .map(|&s| run(job, s))
    .collect();
    for r in &results {
        let s = &r.stats;
        let scallop = s.max_scallop_mm.unwrap();
        let uncovered = s.extra["uncovered_area_mm2"];
        eprintln!(
            "{name} {}: {:.1} mm, scallop {scallop:.4}, gouge {:.4}, uncovered {uncovered:.2}, repair {:.0} mm, {:?}",
            r.strategy,
            s.path_length_mm,
            s.max_gouge_mm.unwrap(),
            s.extra.get("repair_length_mm").copied().unwrap_or(0.0),
            r.plan_choice
        );
        assert!(scallop <= H, "{name} {}: scallop {scallop}", r.strategy);
        assert!(
            s.max_gouge_mm.unwrap() <= GOUGE_LIMIT,
            "{name} {}",
            r.strategy
        );
        assert_eq!(uncovered, 0.0, "{name} {}", r.strategy);
        assert_eq!(r.within_scallop, Some(true), "{name} {}", r.strategy);
        // The planner's own passes (repair passes cross what they repair)
        // do not cross each other.
        let domain = job.surface().unwrap().domain();
        assert_eq!(
            crossings::plan_crossing_pairs(r, domain),
            0,
            "{name} {}: passes cross",
            r.strategy
        );
    }
    let len = |k: usize| results[k].stats.path_length_mm;
    let shorter = len(0).min(len(1));
    let bound = results[2].stats.path_length_lower_bound_mm.unwrap();
    // Passes spaced for 0.9 h cover no more than the widest strip at 0.9 h.
    let floor = lower_bound::job_spacing_lower_bound(job).unwrap();
    for r in &results {
        assert!(
            r.stats.path_length_mm >= floor,
            "{name} {}: {} mm below the floor of passes spaced for 0.9 h, {floor} mm",
            r.strategy,
            r.stats.path_length_mm
        );
    }
    assert!(
        len(2) <= shorter * (1.0 + 1e-9),
        "{name}: tensor_regions {} > shorter baseline {shorter}",
        len(2)
    );
    if room_target {
        assert!(
            shorter >= 1.15 * bound,
            "{name}: no room ({shorter} vs {bound})"
        );
        assert!(
            len(2) <= 0.90 * shorter,
            "{name}: tensor_regions {} > 0.90 x shorter baseline {shorter} (bound {bound})",
            len(2)
        );
    }
}

fn suite_job(seed: u64) -> (String, Job) {
    let params = random::suite()
        .into_iter()
        .find(|p| p.seed == seed)
        .unwrap();
    (params.name(), samples::random_job(&params).unwrap())
}

#[test]
fn isotropic_random_surface() {
    // Seed 1: no trough, three umbilics; shorter baseline 1.13 x the bound,
    // tensor_regions 0.97 x it.
    let (name, job) = suite_job(1);
    check_surface(&name, &job, false);
}

#[test]
fn anisotropic_random_surface_with_room() {
    // Seed 2: six umbilics, shorter baseline 1.27 x the bound.
    let (name, job) = suite_job(2);
    check_surface(&name, &job, true);
}

/// The strip width of the plane sample's flat end (R 2.5 mm, lead 5 deg)
/// at scallop `h`: the tilted end's ellipse has half-axes R across and
/// R sin(lead) below the contact, so h leaves the half-width
/// R sqrt(1 - (1 - h / (R sin lead))^2).
fn plane_strip_width(h: f64) -> f64 {
    let (radius, lead) = (2.5_f64, 5f64.to_radians());
    let t = 1.0 - h / (radius * lead.sin());
    2.0 * radius * (1.0 - t * t).sqrt()
}

/// The floor of the spacing rule on the plane sample (100 x 100 mm) is its
/// area over the strip width at 0.9 h, from the tilted flat end's ellipse
/// ([`plane_strip_width`]).
#[test]
fn spacing_floor_of_the_plane_is_area_over_the_strip_at_0_9_h() {
    let job = samples::job("plane").unwrap();
    let width = plane_strip_width(0.9 * job.scallop.unwrap());
    let floor = lower_bound::job_spacing_lower_bound(&job).unwrap();
    assert!(
        (floor - 10_000.0 / width).abs() < 1e-3 * floor,
        "{floor} against {}",
        10_000.0 / width
    );
}

/// The suite surfaces whose fronts folded into crossing passes and
/// fragments before the offsetting learnt to carry each front across its
/// own travel (seeds 6 and 9: tests/offset_sampling.rs) and whose passes
/// meet the top edge at a shallow angle (seed 11): the planners' passes,
/// before verification, do not cross each other.
#[test]
fn offset_passes_of_anisotropic_surfaces_do_not_cross() {
    for seed in [6, 9, 11] {
        let (name, mut job) = suite_job(seed);
        let domain = job.surface().unwrap().domain();
        for strategy in [Strategy::IsoScallop, Strategy::TensorRegions] {
            job.strategy = strategy;
            let plan = planners::plan(&job, &NoProgress).unwrap();
            assert_eq!(
                crossings::crossing_pairs(&plan.passes, domain),
                0,
                "{name} {}: passes cross",
                strategy.name()
            );
        }
    }
}

/// Suite seed 2 at h = 0.055: the fronts from the v = v0 edge turn up the
/// u = u1 edge into L-shaped passes whose concave corner runs along its
/// bisector to the top edge (a shock). Before the offsets' loops were cut
/// out (docs/methods.md, "Iso-scallop offsetting", "Clean fronts") the
/// corner turned back on itself, grew, and collapsed into 21 pairs of
/// crossing passes there. One pair is left: the last pass along the u = u1
/// edge meets the corner of an L pass 0.016 of the side from that edge.
#[test]
fn the_concave_corner_of_a_front_stays_one_corner() {
    let (name, mut job) = suite_job(2);
    job.scallop = Some(0.055);
    job.strategy = Strategy::IsoScallop;
    let domain = job.surface().unwrap().domain();
    let plan = planners::plan(&job, &NoProgress).unwrap();
    let pairs = crossings::crossing_pairs(&plan.passes, domain);
    assert!(
        pairs <= 1,
        "{name} at h = 0.055: {pairs} pairs of passes cross"
    );
}

/// The whole_field candidate of tensor_regions offsets the whole surface
/// from one feed field line. Through the widest-strip sample alone, that
/// line was a 3 mm stub at a corner on 17 of the 26 suite surfaces: its
/// offsets were fragments, and gap passes covered the surface at about half
/// the spacing (seeds 1, 2, 5, 13: 256-318 passes, 2.2-2.5 x the edge offset
/// from v = v0). Started from a seed whose line is no fragment, the cover is
/// a regular one, within 10 % of that edge offset on these surfaces.
#[test]
fn the_whole_field_cover_starts_from_a_field_line_not_a_stub() {
    for seed in [1, 2, 5, 13] {
        let (name, job) = suite_job(seed);
        let build = |label: &str| {
            tensor_regions::candidate(&job, label, &NoProgress)
                .unwrap()
                .unwrap()
        };
        let (field, edge) = (build("whole_field"), build("edge_offset_u"));
        let ratio = field.cl_path_length() / edge.cl_path_length();
        eprintln!(
            "{name}: whole_field {} passes, {:.3} x edge_offset_u ({} passes)",
            field.passes.len(),
            ratio,
            edge.passes.len()
        );
        assert!(
            ratio <= 1.10,
            "{name}: whole_field {ratio} x the edge offset"
        );
        assert!(
            field.passes.len() <= 2 * edge.passes.len(),
            "{name}: whole_field {} passes against {}",
            field.passes.len(),
            edge.passes.len()
        );
    }
}

/// Merging the partition where a region boundary costs more than it saves
/// (docs/methods.md, "Merging regions") shortens its cover: exact builds of
/// the merged partition (the whole field where every region merged) against
/// the partition as traced, with fewer regions; the merged plan, repaired
/// as the pipeline does, holds h in the simulator.
#[test]
fn merging_the_partition_shortens_its_cover() {
    for seed in [2, 12, 20] {
        let (name, job) = suite_job(seed);
        let build = |label: &str| tensor_regions::candidate(&job, label, &NoProgress).unwrap();
        let traced = build("partitioned_as_traced").unwrap();
        let merged = build("partitioned")
            .or_else(|| build("whole_field"))
            .unwrap();
        let regions = |r: &PlanResult| r.regions.as_ref().map_or(1, Vec::len);
        let ratio = merged.cl_path_length() / traced.cl_path_length();
        eprintln!(
            "{name}: {} regions -> {}, {:.3} x the traced partition's cover; {:?}",
            regions(&traced),
            regions(&merged),
            ratio,
            merged.plan_choice
        );
        assert!(regions(&merged) < regions(&traced), "{name}");
        assert!(ratio <= 0.95, "{name}: merged {ratio} x as traced");
        let length = merged.cl_path_length();
        let (repaired, report, _) = pipeline::verify_and_repair(&job, merged).unwrap();
        assert!(
            report.max_scallop_mm <= H,
            "{name}: {}",
            report.max_scallop_mm
        );
        assert!(report.max_gouge_mm <= GOUGE_LIMIT, "{name}");
        assert_eq!(repaired.within_scallop, Some(true), "{name}");
        assert!(repaired.cl_path_length() <= 1.02 * length, "{name}: repair");
    }
}

#[test]
fn monkey_saddle_sample() {
    check_surface(
        "monkey_saddle",
        &samples::job("monkey_saddle").unwrap(),
        false,
    );
}

#[test]
fn a_missing_pass_comes_back_as_repair_passes() {
    let mut job = samples::job("plane").unwrap();
    job.strategy = Strategy::IsoParametric;
    let mut plan = planners::plan(&job, &NoProgress).unwrap();
    let removed = plan.passes.remove(plan.passes.len() / 2);
    let removed_len: f64 = removed
        .points
        .windows(2)
        .map(|w| {
            (0..3)
                .map(|k| (w[1].cl[k] - w[0].cl[k]).powi(2))
                .sum::<f64>()
                .sqrt()
        })
        .sum();
    let before = pipeline::verify_milling(&job, &plan).unwrap();
    assert!(before.max_scallop_mm > 3.0 * H, "{}", before.max_scallop_mm);
    let (repaired, report, _) = pipeline::verify_and_repair(&job, plan.clone()).unwrap();
    assert!(report.max_scallop_mm <= H, "{}", report.max_scallop_mm);
    assert_eq!(report.uncovered_area_mm2, 0.0);
    assert_eq!(repaired.within_scallop, Some(true));
    // An independent run of the simulator on the repaired plan agrees.
    let again = pipeline::verify_milling(&job, &repaired).unwrap();
    assert!(again.max_scallop_mm <= H && again.max_gouge_mm <= GOUGE_LIMIT);
    // One pass along the gap (with its run-in and run-out) does it: the
    // repair is about as long as the pass taken out, not a carpet of passes.
    let added = repaired.stats.extra["repair_length_mm"];
    assert!(
        added >= 0.9 * removed_len && added <= 1.3 * removed_len,
        "repair {added} mm for a {removed_len} mm pass"
    );
}

/// `compare --suite --scallop H` plans the suite for another height: the
/// plane's lower bound is its area over the strip width at H (the tilted
/// flat end's ellipse, as above), every plan holds H, and no passes cross.
/// A height that is no positive number, or the option with a job file, is
/// refused with a message naming the option.
#[test]
fn suite_plans_for_another_scallop_height() {
    let exe = env!("CARGO_BIN_EXE_toolpath");
    let run = |args: &[&str]| {
        std::process::Command::new(exe)
            .arg("compare")
            .args(args)
            .output()
            .unwrap()
    };
    let h = 0.08;
    let out = run(&["--suite", "--only", "plane", "--scallop", "0.08"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8(out.stdout).unwrap();
    let row: Vec<&str> = text
        .lines()
        .find(|l| l.starts_with("| plane |"))
        .unwrap_or_else(|| panic!("no plane row in\n{text}"))
        .split('|')
        .map(str::trim)
        .collect();
    let width = plane_strip_width(h);
    let bound: f64 = row[3].parse().unwrap();
    assert!(
        (bound - 10_000.0 / width).abs() <= 1.0,
        "bound {bound} against {}",
        10_000.0 / width
    );
    for (k, s) in row[11].split(", ").enumerate() {
        let s: f64 = s.parse().unwrap();
        assert!(s <= h && s > 0.5 * h, "strategy {k}: scallop {s} at h {h}");
    }
    assert_eq!(row[14], "0, 0, 0", "{text}");
    for (args, option) in [
        (
            &["--suite", "--only", "plane", "--scallop=-0.05"][..],
            "--scallop",
        ),
        (
            &["--suite", "--only", "plane", "--scallop", "inf"][..],
            "--scallop",
        ),
        (&["job.json", "--scallop", "0.05"][..], "--scallop"),
        (&["job.json", "--only", "plane"][..], "--only"),
    ] {
        let out = run(args);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(
            !out.status.success() && err.contains(option),
            "{args:?}: {err}"
        );
    }
}
