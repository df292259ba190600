//! Property-based tests: the case loader (read, validate, build the model) and the Gmsh
//! reader, called in-process on mutated copies of valid files (lines or bytes deleted or
//! duplicated, lines swapped, numbers replaced by others, truncations), return a model or an
//! error with a message, and never panic. A bounded number of cases per property keeps the suite
//! fast; proptest shrinks and prints any failing input.

use nurbs_contact::mesh::gmsh::parse_gmsh;
use nurbs_contact::model::Model;
use nurbs_contact::scene::{parse_case, validate};
use proptest::prelude::*;
use proptest::sample::Index;
use std::path::{Path, PathBuf};

/// One mutation of a text.
#[derive(Debug, Clone)]
enum Mutation {
    DeleteLine(Index),
    DuplicateLine(Index),
    SwapLines(Index, Index),
    DeleteBytes(Index, usize),
    DuplicateBytes(Index, usize),
    Truncate(Index),
    /// Replace the k-th number of the text.
    Number(Index, &'static str),
}

/// Replacement numbers: edge values, signs, huge and tiny, and malformed ones.
const NUMBERS: &[&str] = &[
    "0",
    "-1",
    "1",
    "2",
    "3",
    "7",
    "-0.5",
    "1e308",
    "-1e308",
    "1e-320",
    "4294967296",
    "18446744073709551617",
    "nan",
    "inf",
    "1.5",
    "00",
    "1e",
    "-",
    "99999999999",
];

fn mutation() -> impl Strategy<Value = Mutation> {
    prop_oneof![
        any::<Index>().prop_map(Mutation::DeleteLine),
        any::<Index>().prop_map(Mutation::DuplicateLine),
        (any::<Index>(), any::<Index>()).prop_map(|(a, b)| Mutation::SwapLines(a, b)),
        (any::<Index>(), 1usize..40).prop_map(|(a, n)| Mutation::DeleteBytes(a, n)),
        (any::<Index>(), 1usize..40).prop_map(|(a, n)| Mutation::DuplicateBytes(a, n)),
        any::<Index>().prop_map(Mutation::Truncate),
        (any::<Index>(), proptest::sample::select(NUMBERS))
            .prop_map(|(a, n)| Mutation::Number(a, n)),
    ]
}

/// Byte ranges of the numbers in `text` (digits with sign, point and exponent).
fn numbers(text: &str) -> Vec<(usize, usize)> {
    let b = text.as_bytes();
    let mut out = Vec::new();
    let mut i = 0;
    while i < b.len() {
        let starts =
            b[i].is_ascii_digit() || (b[i] == b'-' && i + 1 < b.len() && b[i + 1].is_ascii_digit());
        let after_word = i > 0 && (b[i - 1].is_ascii_alphabetic() || b[i - 1] == b'_');
        if starts && !after_word {
            let s = i;
            i += 1;
            while i < b.len() && (b[i].is_ascii_digit() || b".eE-+".contains(&b[i])) {
                i += 1;
            }
            out.push((s, i));
        } else {
            i += 1;
        }
    }
    out
}

/// `text` with the mutations applied; byte edits keep UTF-8 (the inputs are ASCII).
fn apply(text: &str, muts: &[Mutation]) -> String {
    let mut t = text.to_string();
    for m in muts {
        let mut lines: Vec<String> = t.lines().map(str::to_string).collect();
        let n = t.len().max(1);
        match m {
            Mutation::DeleteLine(i) if !lines.is_empty() => {
                lines.remove(i.index(lines.len()));
                t = lines.join("\n") + "\n";
            }
            Mutation::DuplicateLine(i) if !lines.is_empty() => {
                let k = i.index(lines.len());
                lines.insert(k, lines[k].clone());
                t = lines.join("\n") + "\n";
            }
            Mutation::SwapLines(a, b) if !lines.is_empty() => {
                let (a, b) = (a.index(lines.len()), b.index(lines.len()));
                lines.swap(a, b);
                t = lines.join("\n") + "\n";
            }
            Mutation::DeleteBytes(a, len) => {
                let s = a.index(n).min(t.len());
                let e = (s + len).min(t.len());
                t.replace_range(s..e, "");
            }
            Mutation::DuplicateBytes(a, len) => {
                let s = a.index(n).min(t.len());
                let e = (s + len).min(t.len());
                let piece = t[s..e].to_string();
                t.insert_str(e, &piece);
            }
            Mutation::Truncate(a) => t.truncate(a.index(n).min(t.len())),
            Mutation::Number(k, v) => {
                let nums = numbers(&t);
                if !nums.is_empty() {
                    let (s, e) = nums[k.index(nums.len())];
                    t.replace_range(s..e, v);
                }
            }
            _ => {}
        }
    }
    t
}

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// Valid case files, small enough that a mutation rarely makes a big model (2D, or a Gmsh mesh).
const CASES: &[&str] = &[
    "friction_block_2d.toml",
    "contact_patch_2d.toml",
    "dcb_2d.toml",
    "block_compression_gmsh_3d.toml",
];

/// The loader's whole path on a case text: read, validate, build the model.
fn load(text: &str, file: &Path) -> Result<Model, String> {
    let case = parse_case(text, file, &[]).map_err(|e| e.to_string())?;
    validate(&case).map_err(|e| e.to_string())?;
    Model::build(&case).map_err(|e| e.to_string())
}

fn config(cases: u32) -> ProptestConfig {
    ProptestConfig {
        cases,
        failure_persistence: None,
        ..ProptestConfig::default()
    }
}

#[test]
fn the_unmutated_files_load() {
    for c in CASES {
        let file = root().join("cases").join(c);
        let text = std::fs::read_to_string(&file).unwrap();
        load(&text, &file).unwrap_or_else(|e| panic!("{c}: {e}"));
    }
    for m in ["box_4x4x4.msh", "plate_hole.msh"] {
        let text = std::fs::read_to_string(root().join("cases/meshes").join(m)).unwrap();
        parse_gmsh(&text, m).unwrap_or_else(|e| panic!("{m}: {e}"));
    }
}

#[test]
fn numbers_are_found_where_a_mutation_can_replace_them() {
    let t = "divisions = [8, 4]\nE = 1.5e-3\nQ1N2 x_2 = -0.5";
    let found: Vec<&str> = numbers(t).into_iter().map(|(s, e)| &t[s..e]).collect();
    assert_eq!(found, ["8", "4", "1.5e-3", "-0.5"]);
}

proptest! {
    #![proptest_config(config(256))]

    #[test]
    fn mutated_cases_load_or_fail_with_a_message(
        which in 0..CASES.len(),
        muts in proptest::collection::vec(mutation(), 1..4),
    ) {
        let file = root().join("cases").join(CASES[which]);
        let text = std::fs::read_to_string(&file).unwrap();
        let mutated = apply(&text, &muts);
        if let Err(e) = load(&mutated, &file) {
            prop_assert!(!e.trim().is_empty(), "empty message for {muts:?}");
        }
    }

    #[test]
    fn mutated_gmsh_files_read_or_fail_with_a_message(
        which in 0..2usize,
        muts in proptest::collection::vec(mutation(), 1..4),
    ) {
        let name = ["box_4x4x4.msh", "plate_hole.msh"][which];
        let text = std::fs::read_to_string(root().join("cases/meshes").join(name)).unwrap();
        let mutated = apply(&text, &muts);
        if let Err(e) = parse_gmsh(&mutated, name) {
            prop_assert!(!e.to_string().trim().is_empty(), "empty message for {muts:?}");
        }
    }
}
