//! Property tests of the parsers that take outside input: job files
//! (with their embedded surfaces and pockets) mutated at random fields,
//! truncated or spliced job text, result files, and the Surface, Pocket and
//! Job messages the node receives. Whatever comes in, the parser (and, for a
//! job it accepts, the budget estimate made before planning) returns a
//! value or a one-line error; it never panics. proptest keeps any failing
//! case in tests/fuzz_inputs.proptest-regressions as a regression case.

use proptest::prelude::*;
use serde_json::{json, Value};
use toolpath_planner::formats::{self, PlanResult};
use toolpath_planner::messages::{self as msgs, convert};
use toolpath_planner::pipeline::{self, budget, Budget, RunOptions};
use toolpath_planner::planners::NoProgress;
use toolpath_planner::samples;

const SAMPLES: [&str; 6] = [
    "plane",
    "wing_mould",
    "die_saddle",
    "egg_crate",
    "leaf_pocket",
    "pocket_with_hole",
];

fn sample_value(name: &str) -> Value {
    serde_json::to_value(samples::job(name).unwrap().to_file()).unwrap()
}

/// JSON pointers of every leaf and container of `v`.
fn pointers(v: &Value, at: String, out: &mut Vec<String>) {
    match v {
        Value::Object(m) => {
            for (k, x) in m {
                pointers(x, format!("{at}/{k}"), out);
            }
        }
        Value::Array(a) => {
            for (i, x) in a.iter().enumerate() {
                pointers(x, format!("{at}/{i}"), out);
            }
        }
        _ => {}
    }
    out.push(at);
}

/// Numbers at the edges: zeros, signs, the extremes of f64, values just
/// outside the ranges the formats allow, and the scale of the cases that
/// took the node down (1e7 mm, 1e-6 mm).
fn edge_number() -> impl Strategy<Value = f64> {
    prop_oneof![
        Just(0.0),
        Just(-0.0),
        Just(-1.0),
        Just(1.0),
        Just(1e-300),
        Just(1e300),
        Just(-1e300),
        Just(f64::MAX),
        Just(f64::MIN_POSITIVE),
        Just(1e7),
        Just(1e-6),
        Just(4294967296.0),
        -1e3..1e3f64,
    ]
}

fn edge_value() -> impl Strategy<Value = Value> {
    let leaf = prop_oneof![
        edge_number().prop_map(|x| json!(x)),
        any::<i64>().prop_map(|x| json!(x)),
        Just(Value::Null),
        any::<bool>().prop_map(Value::Bool),
        "[a-z_]{0,12}".prop_map(Value::String),
    ];
    leaf.prop_recursive(3, 24, 6, |inner| {
        prop_oneof![
            prop::collection::vec(inner.clone(), 0..6).prop_map(Value::Array),
            prop::collection::btree_map("[a-z_]{1,8}", inner, 0..4)
                .prop_map(|m| Value::Object(m.into_iter().collect())),
        ]
    })
}

/// Replaces (or removes, with `None`) the value at `pointer`.
fn mutate(root: &mut Value, pointer: &str, value: Option<Value>) {
    if pointer.is_empty() {
        *root = value.unwrap_or(Value::Null);
        return;
    }
    let (parent, key) = pointer.rsplit_once('/').unwrap();
    match (root.pointer_mut(parent), value) {
        (Some(Value::Object(m)), Some(v)) => {
            m.insert(key.to_string(), v);
        }
        (Some(Value::Object(m)), None) => {
            m.remove(key);
        }
        (Some(Value::Array(a)), v) => {
            let i: usize = key.parse().unwrap();
            match v {
                Some(v) if i < a.len() => a[i] = v,
                None if i < a.len() => {
                    a.remove(i);
                }
                _ => {}
            }
        }
        _ => {}
    }
}

fn one_line(e: &toolpath_planner::error::Error) -> Result<(), TestCaseError> {
    let text = e.to_string();
    prop_assert!(!text.trim().is_empty());
    prop_assert!(!text.contains('\n'), "more than one line: {text}");
    Ok(())
}

/// A job parsed from `text` (or its error), then the estimate a job must
/// pass before planning.
fn check_job_text(text: &str) -> Result<(), TestCaseError> {
    match formats::parse_job(text, None) {
        Ok(job) => {
            if let Err(e) = budget::estimate(&job) {
                one_line(&e)?;
            }
            if let Err(e) = Budget::DEFAULT.check(&job) {
                one_line(&e)?;
            }
        }
        Err(e) => one_line(&e)?,
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 400, ..ProptestConfig::default() })]

    #[test]
    fn mutated_job_files_give_a_job_or_a_one_line_error(
        sample in 0..SAMPLES.len(),
        edits in prop::collection::vec((any::<prop::sample::Index>(), prop::option::weighted(0.9, edge_value())), 1..4),
    ) {
        let mut job = sample_value(SAMPLES[sample]);
        for (at, value) in edits {
            let mut all = Vec::new();
            pointers(&job, String::new(), &mut all);
            let pointer = all[at.index(all.len())].clone();
            mutate(&mut job, &pointer, value);
        }
        check_job_text(&job.to_string())?;
    }

    #[test]
    fn cut_and_spliced_job_text_gives_a_one_line_error(
        sample in 0..SAMPLES.len(),
        cut in any::<prop::sample::Index>(),
        splice in prop::collection::vec(any::<u8>(), 0..16),
    ) {
        let text = sample_value(SAMPLES[sample]).to_string();
        let at = cut.index(text.len());
        let mut bytes = text.as_bytes()[..at].to_vec();
        bytes.extend_from_slice(&splice);
        bytes.extend_from_slice(&text.as_bytes()[at..]);
        // The readers refuse non-UTF-8 before parsing; the parser gets text.
        let text = String::from_utf8_lossy(&bytes);
        check_job_text(&text)?;
    }

    #[test]
    fn random_surface_messages_give_a_surface_or_a_one_line_error(
        degree_u in prop_oneof![0..12u32, Just(u32::MAX)],
        degree_v in 0..12u32,
        knots_u in prop::collection::vec(edge_number(), 0..16),
        knots_v in prop::collection::vec(0.0..1.0f64, 0..16),
        count_u in prop_oneof![0..8u32, Just(u32::MAX), Just(1 << 16)],
        count_v in prop_oneof![0..8u32, Just(u32::MAX)],
        points in prop::collection::vec((edge_number(), edge_number(), edge_number()), 0..40),
        weights in prop::collection::vec(edge_number(), 0..40),
    ) {
        let m = msgs::Surface {
            surface_id: "fuzz".into(),
            degree_u,
            degree_v,
            knots_u,
            knots_v,
            count_u,
            count_v,
            control_points: points.into_iter().map(|(x, y, z)| msgs::Point { x, y, z }).collect(),
            weights,
            ..Default::default()
        };
        match convert::surface_from_msg(&m) {
            Ok(s) => {
                let ((u0, u1), (v0, v1)) = s.domain();
                let _ = s.point(0.5 * (u0 + u1), 0.5 * (v0 + v1));
            }
            Err(e) => one_line(&e)?,
        }
    }

    #[test]
    fn random_pocket_and_job_messages_give_a_value_or_a_one_line_error(
        outer in prop::collection::vec((edge_number(), edge_number()), 0..12),
        holes in prop::collection::vec(prop::collection::vec((edge_number(), edge_number()), 0..6), 0..3),
        strategy in prop_oneof![Just("tensor_regions".to_string()), Just("pocket_mat".to_string()), "[a-z_]{0,10}"],
        kind in prop_oneof![Just("flat_end".to_string()), Just("torus".to_string()), Just("belt".to_string()), "[a-z]{0,6}"],
        sizes in (edge_number(), edge_number(), edge_number(), edge_number()),
        figures in (edge_number(), edge_number(), edge_number(), edge_number()),
    ) {
        let to_loop = |l: &[(f64, f64)]| msgs::PocketLoop {
            points: l.iter().map(|&(x, y)| msgs::Point { x, y, z: 0.0 }).collect(),
        };
        let p = msgs::Pocket {
            pocket_id: "fuzz".into(),
            outer: to_loop(&outer),
            holes: holes.iter().map(|h| to_loop(h)).collect(),
            ..Default::default()
        };
        if let Err(e) = convert::pocket_from_msg(&p) {
            one_line(&e)?;
        }
        let j = msgs::Job {
            job_id: "fuzz".into(),
            surface_id: "fuzz".into(),
            machine: String::new(),
            strategy,
            tool: msgs::Tool {
                kind,
                radius: sizes.0,
                corner_radius: sizes.1,
                width: sizes.2,
                length: sizes.3,
            },
            scallop: figures.0,
            tolerance: figures.1,
            lead_angle_deg: figures.2,
            feed_rate: figures.3,
            feed_direction: String::new(),
            ..Default::default()
        };
        if let Err(e) = convert::prevalidate_job(&j) {
            one_line(&e)?;
        }
    }
}

/// A result file of the plane sample, mutated: read back or refused.
#[test]
fn mutated_result_files_give_a_result_or_a_one_line_error() {
    let job = samples::job("plane").unwrap();
    let result = pipeline::run(&job, &NoProgress, RunOptions::PLAN_ONLY).unwrap();
    let base = serde_json::to_value(&result).unwrap();
    let mut all = Vec::new();
    pointers(&base, String::new(), &mut all);
    // Every field of the first pass and of the header (the rest repeats it).
    all.retain(|p| !p.contains("/passes/") || p.contains("/passes/0/"));
    all.truncate(400);
    let mut runner = proptest::test_runner::TestRunner::new(ProptestConfig {
        cases: 300,
        ..ProptestConfig::default()
    });
    runner
        .run(
            &(
                any::<prop::sample::Index>(),
                prop::option::weighted(0.9, edge_value()),
            ),
            |(at, value)| {
                let mut r = base.clone();
                mutate(&mut r, &all[at.index(all.len())], value);
                let parsed: Result<PlanResult, _> = formats::from_value(r);
                if let Err(e) = parsed {
                    one_line(&e)?;
                }
                Ok(())
            },
        )
        .unwrap();
}
