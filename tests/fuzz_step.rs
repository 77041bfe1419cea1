//! Property tests of the STEP reader, which takes files from outside: the
//! two STEP sample parts and every part of tests/data/step, mutated at
//! random. A number becomes an edge value (zero, huge, tiny, negative, a
//! degree or count of 10^9), an entity reference points elsewhere (to
//! itself, to a missing id, to an entity of another type), a line is
//! dropped or duplicated, the text is cut and closed again, two entity
//! types are swapped. Whatever comes in, reading the file, listing its faces
//! and importing each face as a trimmed surface returns a value or a
//! one-line error naming where; it never panics, aborts or hangs. proptest
//! keeps any failing case in tests/fuzz_step.proptest-regressions.

use proptest::prelude::*;
use std::path::Path;
use toolpath_planner::formats::step::StepFile;
use toolpath_planner::samples::step_parts;

/// Every STEP text the tests have: the samples the project writes and the
/// parts Open CASCADE wrote (tests/data/step).
fn corpus() -> Vec<(String, String)> {
    let mut out: Vec<(String, String)> = step_parts::STEP_SAMPLES
        .iter()
        .map(|n| (n.to_string(), step_parts::part(n).unwrap().text))
        .collect();
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/step");
    let mut files: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "step"))
        .collect();
    files.sort();
    for p in files {
        let name = p.file_stem().unwrap().to_string_lossy().into_owned();
        out.push((name, std::fs::read_to_string(&p).unwrap()));
    }
    out
}

/// Byte ranges of the tokens `keep` selects in the DATA section: numbers
/// (`is_ref` false) or entity references `#N` (`is_ref` true) inside
/// entity parameters, after the first `=` of a line.
fn tokens(text: &str, is_ref: bool) -> Vec<(usize, usize)> {
    let data = text.find("DATA;").unwrap_or(0);
    let bytes = text.as_bytes();
    let mut out = Vec::new();
    let mut i = data;
    while i < bytes.len() {
        let c = bytes[i];
        let starts_number = !is_ref
            && (c.is_ascii_digit() || c == b'-' || c == b'.')
            && i > 0
            && matches!(bytes[i - 1], b'(' | b',' | b' ');
        let starts_ref = is_ref && c == b'#' && i > 0 && matches!(bytes[i - 1], b'(' | b',' | b' ');
        if starts_number || starts_ref {
            let mut j = i + 1;
            while j < bytes.len()
                && (bytes[j].is_ascii_alphanumeric() || matches!(bytes[j], b'.' | b'-' | b'+'))
            {
                j += 1;
            }
            out.push((i, j));
            i = j;
        } else {
            i += 1;
        }
    }
    out
}

/// Numbers at the edges of what a reader must survive.
fn edge_number() -> impl Strategy<Value = String> {
    prop_oneof![
        Just("0.".to_string()),
        Just("-0.".to_string()),
        Just("-1.".to_string()),
        Just("1.E300".to_string()),
        Just("-1.E300".to_string()),
        Just("1.E-300".to_string()),
        Just("1.E400".to_string()),
        Just("1000000000".to_string()),
        Just("-5".to_string()),
        Just("0".to_string()),
        Just("18446744073709551617".to_string()),
        Just("1.5".to_string()),
        Just("".to_string()),
        Just("$".to_string()),
        Just("*".to_string()),
        Just(".T.".to_string()),
        (-1e3..1e3f64).prop_map(|x| format!("{x:?}")),
        (0u32..40).prop_map(|n| n.to_string()),
    ]
}

/// Entity references: existing ids, missing ones, huge ones.
fn reference() -> impl Strategy<Value = String> {
    prop_oneof![
        (1u64..400).prop_map(|n| format!("#{n}")),
        Just("#0".to_string()),
        Just("#99999999999".to_string()),
        Just("#18446744073709551615".to_string()),
        Just("#".to_string()),
        Just("$".to_string()),
    ]
}

/// Reads `text` as a STEP file, lists its faces, and imports every face as
/// a trimmed surface: each step gives a value or a one-line error.
fn check(text: &str) -> Result<(), TestCaseError> {
    let file = match StepFile::parse(text, "fuzz.step", "fuzz") {
        Ok(f) => f,
        Err(e) => return one_line(&e.to_string()),
    };
    let _ = file.mm_per_unit();
    for id in file.face_ids() {
        match file.face(id).and_then(|f| f.to_surface()) {
            Ok(s) => {
                // The trim is checked and usable: its area integrates (to
                // infinity on a face of 1e300 mm, which the budget refuses
                // before planning).
                if let Some(t) = s.trim() {
                    let a = t.face_area(&s, 16);
                    prop_assert!(a >= 0.0, "face #{id}: area {a}");
                }
            }
            Err(e) => one_line(&e.to_string())?,
        }
    }
    Ok(())
}

fn one_line(text: &str) -> Result<(), TestCaseError> {
    prop_assert!(!text.trim().is_empty());
    prop_assert!(!text.contains('\n'), "more than one line: {text}");
    Ok(())
}

/// Replaces the byte range `r` of `text` by `with`.
fn splice(text: &str, r: (usize, usize), with: &str) -> String {
    format!("{}{}{}", &text[..r.0], with, &text[r.1..])
}

/// The lines of the DATA section that define entities (`#N=...;`).
fn entity_lines(text: &str) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    let mut at = 0;
    for line in text.split_inclusive('\n') {
        if line.starts_with('#') && line.contains('=') {
            out.push((at, at + line.len()));
        }
        at += line.len();
    }
    out
}

/// The entity type name of an entity line (`#12=NAME(...`), as a range.
fn type_name(text: &str, line: (usize, usize)) -> Option<(usize, usize)> {
    let s = &text[line.0..line.1];
    let eq = s.find('=')?;
    let open = s[eq..].find('(')? + eq;
    let name = s[eq + 1..open].trim();
    if name.is_empty() || !name.chars().all(|c| c.is_ascii_uppercase() || c == '_') {
        return None;
    }
    let start = line.0 + eq + 1 + s[eq + 1..].find(name)?;
    Some((start, start + name.len()))
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 160, ..ProptestConfig::default() })]

    #[test]
    fn a_number_set_to_an_edge_value_gives_a_face_or_a_one_line_error(
        part in any::<prop::sample::Index>(),
        at in any::<prop::sample::Index>(),
        value in edge_number(),
    ) {
        let corpus = corpus();
        let (_, text) = &corpus[part.index(corpus.len())];
        let numbers = tokens(text, false);
        prop_assume!(!numbers.is_empty());
        check(&splice(text, numbers[at.index(numbers.len())], &value))?;
    }

    #[test]
    fn a_reference_pointed_elsewhere_gives_a_face_or_a_one_line_error(
        part in any::<prop::sample::Index>(),
        at in any::<prop::sample::Index>(),
        to in reference(),
    ) {
        let corpus = corpus();
        let (_, text) = &corpus[part.index(corpus.len())];
        let refs = tokens(text, true);
        prop_assume!(!refs.is_empty());
        check(&splice(text, refs[at.index(refs.len())], &to))?;
    }

    #[test]
    fn dropped_duplicated_or_swapped_entities_give_a_face_or_a_one_line_error(
        part in any::<prop::sample::Index>(),
        a in any::<prop::sample::Index>(),
        b in any::<prop::sample::Index>(),
        how in 0u8..3,
    ) {
        let corpus = corpus();
        let (_, text) = &corpus[part.index(corpus.len())];
        let lines = entity_lines(text);
        prop_assume!(lines.len() >= 2);
        let (la, lb) = (lines[a.index(lines.len())], lines[b.index(lines.len())]);
        let mutated = match how {
            0 => splice(text, la, ""),
            1 => splice(text, (la.1, la.1), &text[la.0..la.1]),
            _ => {
                let (Some(ta), Some(tb)) = (type_name(text, la), type_name(text, lb)) else {
                    return Ok(());
                };
                // Swap the later name first so the earlier range stays put.
                let (first, second) = if ta.0 < tb.0 { (ta, tb) } else { (tb, ta) };
                let (n1, n2) = (text[first.0..first.1].to_string(), text[second.0..second.1].to_string());
                splice(&splice(text, second, &n1), first, &n2)
            }
        };
        check(&mutated)?;
    }

    #[test]
    fn text_cut_and_closed_again_gives_a_face_or_a_one_line_error(
        part in any::<prop::sample::Index>(),
        cut in any::<prop::sample::Index>(),
    ) {
        let corpus = corpus();
        let (_, text) = &corpus[part.index(corpus.len())];
        let mut at = cut.index(text.len());
        while !text.is_char_boundary(at) {
            at -= 1;
        }
        // Closed again, so the reader goes past its truncation check.
        check(&format!("{}\nENDSEC;\nEND-ISO-10303-21;\n", &text[..at]))?;
        check(&text[..at])?;
    }
}

/// The corpus itself reads without errors: the mutations start from files
/// the reader takes, so what they find is the mutation's doing.
#[test]
fn the_unmutated_corpus_reads_and_every_face_imports() {
    for (name, text) in corpus() {
        let file = StepFile::parse(&text, &name, &name).unwrap_or_else(|e| panic!("{name}: {e}"));
        let ids = file.face_ids();
        assert!(!ids.is_empty(), "{name}: no faces");
        for id in ids {
            file.face(id)
                .and_then(|f| f.to_surface())
                .unwrap_or_else(|e| panic!("{name} face #{id}: {e}"));
        }
    }
}
