//! Property tests of the byte-level readers that take outside input: the
//! CDR payloads the node receives over DDS (decoded exactly as RustDDS hands
//! them to the node, then converted) and recorded bags (MCAP with their
//! rosbag2 metadata) read back by `toolpath replay` and the replay tests.
//! Valid bytes are damaged at random (bytes overwritten, cut, spliced) and
//! whatever comes in gives a value or a one-line error, never a panic or an
//! allocation abort. proptest keeps any failing case in
//! tests/fuzz_bytes.proptest-regressions as a regression case.

use proptest::prelude::*;
use rustdds::no_key::DeserializerAdapter;
use rustdds::{CDRDeserializerAdapter, RepresentationIdentifier};
use serde::de::DeserializeOwned;
use std::path::Path;
use toolpath_planner::messages::{self as msgs, convert};
use toolpath_planner::recording::runs::Recorded;
use toolpath_planner::recording::{from_cdr, to_cdr, CDR_LE_HEADER};
use toolpath_planner::samples;

fn one_line(text: &str) -> Result<(), TestCaseError> {
    prop_assert!(!text.trim().is_empty());
    prop_assert!(!text.contains('\n'), "more than one line: {text}");
    Ok(())
}

/// One damage to `bytes`: overwrite a run, cut at a point, or splice bytes in.
#[derive(Clone, Debug)]
enum Damage {
    Overwrite(prop::sample::Index, Vec<u8>),
    Cut(prop::sample::Index),
    Splice(prop::sample::Index, Vec<u8>),
}

fn damage() -> impl Strategy<Value = Damage> {
    // Lengths and counts are 4-byte words in CDR: 0xff.. runs make them huge.
    let bytes = prop_oneof![
        prop::collection::vec(any::<u8>(), 1..9),
        Just(vec![0xff; 4]),
        Just(vec![0x7f, 0xff, 0xff, 0xff]),
        Just(vec![0; 4]),
    ];
    prop_oneof![
        4 => (any::<prop::sample::Index>(), bytes.clone()).prop_map(|(i, b)| Damage::Overwrite(i, b)),
        1 => any::<prop::sample::Index>().prop_map(Damage::Cut),
        2 => (any::<prop::sample::Index>(), bytes).prop_map(|(i, b)| Damage::Splice(i, b)),
    ]
}

fn apply(bytes: &mut Vec<u8>, d: &Damage) {
    if bytes.is_empty() {
        return;
    }
    match d {
        Damage::Overwrite(at, b) => {
            let start = at.index(bytes.len());
            for (k, x) in b.iter().enumerate() {
                if let Some(slot) = bytes.get_mut(start + k) {
                    *slot = *x;
                }
            }
        }
        Damage::Cut(at) => bytes.truncate(at.index(bytes.len())),
        Damage::Splice(at, b) => {
            let at = at.index(bytes.len());
            bytes.splice(at..at, b.iter().copied());
        }
    }
}

/// The CDR payloads of a surface, a pocket and two jobs the node would receive.
fn valid_payloads() -> Vec<(&'static str, Vec<u8>)> {
    let header = msgs::Header::default();
    let wing = samples::job("wing_mould").unwrap();
    let pocket = samples::job("leaf_pocket").unwrap();
    let surface = convert::surface_to_msg("wing", wing.surface().unwrap(), header.clone());
    let pocket_msg = convert::pocket_to_msg("leaf", pocket.pocket().unwrap(), header.clone());
    vec![
        ("surface", to_cdr(&surface).unwrap()),
        ("pocket", to_cdr(&pocket_msg).unwrap()),
        (
            "job",
            to_cdr(&convert::job_to_msg(&wing, "wing", header.clone())).unwrap(),
        ),
        (
            "job",
            to_cdr(&convert::job_to_msg(&pocket, "leaf", header)).unwrap(),
        ),
    ]
}

/// Decodes a payload's `body` (after the encapsulation header) as the
/// node's DDS reader does, with RustDDS's CDR adapter, and converts it as
/// the node does: `None` where RustDDS refuses the bytes.
fn node_decode(kind: &str, body: &[u8]) -> Option<Result<(), String>> {
    fn go<T: DeserializeOwned, U>(
        body: &[u8],
        convert: impl Fn(&T) -> toolpath_planner::Result<U>,
    ) -> Option<Result<(), String>> {
        let m =
            CDRDeserializerAdapter::<T>::from_bytes(body, RepresentationIdentifier::CDR_LE).ok()?;
        Some(convert(&m).map(|_| ()).map_err(|e| e.to_string()))
    }
    match kind {
        "surface" => go(body, convert::surface_from_msg),
        "pocket" => go(body, convert::pocket_from_msg),
        _ => go(body, convert::prevalidate_job),
    }
}

/// Decodes a whole payload as the bag reader does.
fn bag_decode(kind: &str, payload: &[u8]) -> Result<(), String> {
    let decoded = match kind {
        "surface" => from_cdr::<msgs::Surface>(payload).map(|_| ()),
        "pocket" => from_cdr::<msgs::Pocket>(payload).map(|_| ()),
        _ => from_cdr::<msgs::Job>(payload).map(|_| ()),
    };
    decoded.map_err(|e| e.to_string())
}

/// A golden bag's storage file and metadata, read once.
fn golden_bag() -> (Vec<u8>, Vec<u8>) {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("bags/iso_parametric_plane");
    (
        std::fs::read(dir.join("iso_parametric_plane_0.mcap")).unwrap(),
        std::fs::read(dir.join("metadata.yaml")).unwrap(),
    )
}

#[test]
fn the_valid_payloads_decode() {
    for (kind, payload) in valid_payloads() {
        assert_eq!(payload[..4], CDR_LE_HEADER);
        assert_eq!(node_decode(kind, &payload[4..]), Some(Ok(())), "{kind}");
        assert_eq!(bag_decode(kind, &payload), Ok(()), "{kind}");
    }
    let (mcap, _) = golden_bag();
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("plane.mcap");
    std::fs::write(&file, mcap).unwrap();
    assert!(!Recorded::read(&file).unwrap().jobs.is_empty());
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 300, ..ProptestConfig::default() })]

    #[test]
    fn damaged_cdr_payloads_give_a_message_or_a_one_line_error(
        which in 0..4usize,
        damages in prop::collection::vec(damage(), 1..4),
    ) {
        let (kind, mut payload) = valid_payloads().swap_remove(which);
        for d in &damages {
            apply(&mut payload, d);
        }
        if let Some(Err(e)) = node_decode(kind, payload.get(4..).unwrap_or(&[])) {
            one_line(&e)?;
        }
        if let Err(e) = bag_decode(kind, &payload) {
            one_line(&e)?;
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 120, ..ProptestConfig::default() })]

    #[test]
    fn damaged_bags_give_runs_or_a_one_line_error(
        in_metadata in prop::bool::weighted(0.25),
        damages in prop::collection::vec(damage(), 1..4),
    ) {
        let (mut mcap, mut metadata) = golden_bag();
        for d in &damages {
            apply(if in_metadata { &mut metadata } else { &mut mcap }, d);
        }
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("iso_parametric_plane_0.mcap"), &mcap).unwrap();
        std::fs::write(dir.path().join("metadata.yaml"), &metadata).unwrap();
        // As a bag directory (metadata first) and as the bare storage file.
        for path in [dir.path().to_path_buf(), dir.path().join("iso_parametric_plane_0.mcap")] {
            match Recorded::read(&path) {
                Ok(r) => {
                    for j in &r.jobs {
                        if let Err(e) = convert::prevalidate_job(j) {
                            one_line(&e.to_string())?;
                        }
                    }
                }
                Err(e) => one_line(&e.to_string())?,
            }
        }
    }
}
