//! Reading a case: file -> `toml::Value` -> `--set` overrides -> typed [`Case`] -> validation.

use crate::scene::keypath::{line_of, resolve_key, split_toml_error};
use crate::scene::schema::Case;
use crate::scene::validate::validate;
use crate::scene::SceneError;
use serde::Deserialize;
use std::path::Path;

/// Read, override, deserialise and validate the case file at `path`.
///
/// `overrides` are `key.path=value` strings as given to `--set`: the path is dotted into tables and
/// indexes arrays by position (`stages.0.steps=10`); the value is parsed as a TOML value
/// (`2`, `1e-3`, `[0.0, -0.2]`, `{ max_cutbacks = 4 }`, `"text"`) and taken as a plain string when it
/// does not parse (`solver.petsc_options=-snes_rtol 1e-8`). Every table on the path must exist; only
/// the last key may be new (its name is then checked by the schema). To set keys of an optional table
/// that the file leaves out, give the whole table inline: `steps={ max_cutbacks = 4 }`.
pub fn load_case(path: &Path, overrides: &[String]) -> Result<Case, SceneError> {
    let text = std::fs::read_to_string(path).map_err(|source| SceneError::Read {
        file: path.to_path_buf(),
        source,
    })?;
    parse_case(&text, path, overrides)
}

/// [`load_case`] on text already in memory; `file` is only used in messages and to resolve relative
/// mesh paths.
pub fn parse_case(text: &str, file: &Path, overrides: &[String]) -> Result<Case, SceneError> {
    let table: toml::Table = toml::from_str(text).map_err(|e| SceneError::Syntax {
        file: file.to_path_buf(),
        line: e.span().map(|s| line_of(text, s.start)),
        message: e.message().to_string(),
    })?;
    let mut root = toml::Value::Table(table);
    let original = root.clone();
    if let Some((key, why)) = retired_key(&original) {
        return Err(SceneError::Schema {
            file: file.to_path_buf(),
            line: locate_line(text, key),
            key: key.to_string(),
            message: format!("{why}; delete this line"),
        });
    }
    if let Some((key, old, new)) = renamed_value(&original) {
        return Err(SceneError::Schema {
            file: file.to_path_buf(),
            line: locate_line(text, &key),
            message: renamed_message(&key, old, new),
            key,
        });
    }

    // Keys created (not replaced) by overrides: a schema error on one of them is a bad override.
    let mut created: Vec<(String, String)> = Vec::new();
    for arg in overrides {
        if let Some(new_key) = apply_override(&mut root, arg, file)? {
            created.push((new_key, arg.clone()));
        }
    }

    if let Some((key, old, new)) = renamed_value(&root) {
        let arg = override_setting(overrides, &key);
        return Err(SceneError::Override {
            file: file.to_path_buf(),
            arg,
            message: renamed_message(&key, old, new),
            key,
        });
    }
    if let Some((key, why)) = retired_key(&root) {
        let arg = override_setting(overrides, key);
        return Err(SceneError::Override {
            file: file.to_path_buf(),
            arg,
            key: key.to_string(),
            message: format!("{why}; drop this override"),
        });
    }

    let mut case = Case::deserialize(root)
        .map_err(|e| schema_error(&e, text, &original, file, overrides, &created))?;
    case.file = file.to_path_buf();
    case.name_default_formulations();
    validate(&case).map_err(|e| match e {
        SceneError::Invalid { file, mut issues } => {
            for issue in &mut issues {
                issue.line = issue_line(text, &issue.key, overrides);
            }
            SceneError::Invalid { file, issues }
        }
        other => other,
    })?;
    Ok(case)
}

/// Keys the schema no longer has, with why (docs/formulations.md, "Retired keys"): a case that
/// sets one is refused with this reason rather than as an unknown key.
const RETIRED: [(&str, &str); 1] = [(
    "solver.contact_freeze_after",
    "removed: on the formulation matrix (docs/formulations.md) it changed no measured result (the \
     same metrics as the runs without it on every row, never fewer Newton iterations)",
)];

/// The override that set `key` (else the last one: a table set whole holds it), for messages.
fn override_setting(overrides: &[String], key: &str) -> String {
    overrides
        .iter()
        .find(|a| a.split_once('=').is_some_and(|(k, _)| k.trim() == key))
        .or(overrides.last())
        .cloned()
        .unwrap_or_default()
}

/// Values of `contact.N.gap` that were renamed, with their names now: the nodally weighted gaps
/// are called what the literature calls them (docs/formulations.md, "Retired keys").
const RENAMED_GAPS: [(&str, &str); 3] = [
    ("mortar", "weighted"),
    ("mortar_linear", "weighted_linear"),
    ("mortar_mean", "weighted_mean"),
];

/// The first `contact.N.gap` in `root` that holds a renamed value: its key, the old and the new name.
fn renamed_value(root: &toml::Value) -> Option<(String, &'static str, &'static str)> {
    let pairs = root.get("contact")?.as_array()?;
    pairs.iter().enumerate().find_map(|(i, pair)| {
        let gap = pair.get("gap")?.as_str()?;
        RENAMED_GAPS
            .into_iter()
            .find(|(old, _)| *old == gap)
            .map(|(old, new)| (format!("contact.{i}.gap"), old, new))
    })
}

/// Why a renamed value is refused and what to write instead.
fn renamed_message(key: &str, old: &str, new: &str) -> String {
    format!(
        "`{old}` was renamed: the same formulation is now `{key_leaf} = \"{new}\"` (a nodally weighted \
         gap; see docs/formulations.md); write that instead",
        key_leaf = key.rsplit('.').next().unwrap_or(key)
    )
}

/// The first retired key set in `root`, with why it was retired.
fn retired_key(root: &toml::Value) -> Option<(&'static str, &'static str)> {
    RETIRED.into_iter().find(|(key, _)| {
        key.split('.')
            .try_fold(root, |node, seg| node.as_table()?.get(seg))
            .is_some()
    })
}

/// The line of a validation issue's key in the file: its own `name =` line or its closest parent's
/// (`bcs.1.value.0` -> `bcs.1.value`). None when an override set the value, since the file's line
/// would show a different value than the one rejected.
fn issue_line(text: &str, key: &str, overrides: &[String]) -> Option<usize> {
    let overridden = overrides.iter().any(|arg| {
        arg.split_once('=').is_some_and(|(k, _)| {
            let k = k.trim();
            key == k || key.starts_with(&format!("{k}."))
        })
    });
    if overridden {
        return None;
    }
    let mut key = key;
    loop {
        if let Some(l) = locate_line(text, key) {
            return Some(l);
        }
        key = key.rsplit_once('.')?.0;
    }
}

fn schema_error(
    e: &toml::de::Error,
    text: &str,
    original: &toml::Value,
    file: &Path,
    overrides: &[String],
    created: &[(String, String)],
) -> SceneError {
    let (message, path) = split_toml_error(e);
    let (key, message) = resolve_key(path.as_deref(), &message);
    if let Some((_, arg)) = created.iter().find(|(k, _)| *k == key) {
        return SceneError::Override {
            file: file.to_path_buf(),
            arg: arg.clone(),
            key,
            message,
        };
    }
    // The value deserialiser has no spans; deserialising the original text again gives the line
    // whenever the error is already in the file (and not introduced by an override).
    let line = match toml::from_str::<Case>(text) {
        Err(orig) if orig.message() == e.message() => orig.span().map(|s| line_of(text, s.start)),
        _ => None,
    };
    match line {
        Some(span_line) => {
            let key = with_array_indices(&key, original, &message);
            SceneError::Schema {
                file: file.to_path_buf(),
                line: locate_line(text, &key).or(Some(span_line)),
                key,
                message,
            }
        }
        None => {
            // Not in the file, so an override put it there: name that override and its indexed key.
            let bare = without_indices(&key);
            let culprit = overrides.iter().find_map(|arg| {
                let k = arg.split_once('=')?.0.trim();
                let kb = without_indices(k);
                (bare == kb || bare.starts_with(&format!("{kb}."))).then_some((arg, k))
            });
            match culprit {
                Some((arg, k)) => SceneError::Override {
                    file: file.to_path_buf(),
                    arg: arg.clone(),
                    key: k.to_string(),
                    message,
                },
                None => SceneError::Schema {
                    file: file.to_path_buf(),
                    key,
                    line: None,
                    message,
                },
            }
        }
    }
}

/// `stages.0.steps` -> `stages.steps`: the form `toml` reports paths in.
fn without_indices(key: &str) -> String {
    key.split('.')
        .filter(|s| s.parse::<usize>().is_err())
        .collect::<Vec<_>>()
        .join(".")
}

/// `toml` reports `bcs.kind` for an error in the second `[[bcs]]`; find the index (`bcs.1.kind`) by
/// deserialising the array's entries one by one and taking the first that fails the same way.
fn with_array_indices(key: &str, root: &toml::Value, message: &str) -> String {
    fn first_failing<T: serde::de::DeserializeOwned>(
        items: &[toml::Value],
        message: &str,
    ) -> Option<usize> {
        items
            .iter()
            .position(|item| match T::deserialize(item.clone()) {
                Ok(_) => false,
                Err(e) => resolve_key(split_toml_error(&e).1.as_deref(), e.message()).1 == message,
            })
    }
    let (array, rest) = match key.split_once('.') {
        Some(("output", r)) if r.starts_with("reactions.") => {
            ("output.reactions", &r["reactions".len()..])
        }
        Some((a, _)) => (a, &key[a.len()..]),
        None => return key.to_string(),
    };
    let items = match array
        .split('.')
        .try_fold(root, |n, s| n.get(s))
        .and_then(|v| v.as_array())
    {
        Some(items) => items,
        None => return key.to_string(),
    };
    let index = match array {
        "bcs" => first_failing::<crate::scene::BcSpec>(items, message),
        "ties" => first_failing::<crate::scene::TieSpec>(items, message),
        "stages" => first_failing::<crate::scene::StageSpec>(items, message),
        "output.reactions" => first_failing::<crate::scene::ReactionSpec>(items, message),
        _ => None,
    };
    match index {
        Some(i) => format!("{array}.{i}{rest}"),
        None => key.to_string(),
    }
}

/// The line of `key` (with array indices) in `text`: the line assigning its last segment inside the
/// table named by the rest, else that table's header. A plain scan of `[table]` / `[[array]]` headers
/// and `name = ` lines; `None` for keys written as dotted keys or inline tables.
fn locate_line(text: &str, key: &str) -> Option<usize> {
    let (table, leaf) = key.rsplit_once('.').unwrap_or(("", key));
    let mut current = String::new();
    let mut counts: std::collections::BTreeMap<String, usize> = Default::default();
    let mut header_line = None;
    for (i, raw) in text.lines().enumerate() {
        let l = raw.trim();
        if let Some(h) = l
            .strip_prefix("[[")
            .and_then(|r| r.split_once("]]"))
            .map(|(h, _)| h.trim())
        {
            let n = counts.entry(h.to_string()).or_insert(0);
            current = format!("{h}.{n}");
            *n += 1;
        } else if let Some(h) = l
            .strip_prefix('[')
            .and_then(|r| r.split_once(']'))
            .map(|(h, _)| h.trim())
        {
            current = h.to_string();
        } else {
            if current == table {
                if let Some((k, _)) = l.split_once('=') {
                    if k.trim() == leaf {
                        return Some(i + 1);
                    }
                }
            }
            continue;
        }
        if current == table || current == key {
            header_line = Some(i + 1);
        }
    }
    header_line
}

/// Top-level tables with defaults, which `--set` may create (`--set steps.max_cutbacks=3`).
const DEFAULTED_TABLES: [&str; 3] = ["steps", "solver", "output"];

/// Apply one `key.path=value` override. Returns the key path when the last key did not exist before.
fn apply_override(
    root: &mut toml::Value,
    arg: &str,
    file: &Path,
) -> Result<Option<String>, SceneError> {
    let err = |key: &str, message: String| SceneError::Override {
        file: file.to_path_buf(),
        arg: arg.to_string(),
        key: key.to_string(),
        message,
    };
    let Some((key_path, raw)) = arg.split_once('=') else {
        return Err(err(arg, "expected `key.path=value`".to_string()));
    };
    let key_path = key_path.trim();
    let segments: Vec<&str> = key_path.split('.').collect();
    if segments.iter().any(|s| s.is_empty()) {
        return Err(err(key_path, "empty key in path".to_string()));
    }
    let value = parse_value(raw.trim());

    let (last, parents) = segments
        .split_last()
        .ok_or_else(|| err(key_path, "empty key path".to_string()))?;
    let mut node: &mut toml::Value = root;
    let mut walked = String::new();
    for seg in parents {
        if !walked.is_empty() {
            walked.push('.');
        }
        walked.push_str(seg);
        // a top-level table that the schema fills with defaults when a case leaves it out is
        // created; any other missing key is an error naming the override
        let top_level = !walked.contains('.') && DEFAULTED_TABLES.contains(seg);
        node = match node {
            toml::Value::Table(t) => {
                if top_level && !t.contains_key(*seg) {
                    t.insert(seg.to_string(), toml::Value::Table(toml::Table::new()));
                }
                t.get_mut(*seg)
                    .ok_or_else(|| err(&walked, "no such key in the case".to_string()))?
            }
            toml::Value::Array(a) => {
                let len = a.len();
                let i = array_index(seg).ok_or_else(|| {
                    err(
                        &walked,
                        "an array must be indexed by position, e.g. `stages.0`".to_string(),
                    )
                })?;
                a.get_mut(i).ok_or_else(|| {
                    err(
                        &walked,
                        format!("index {i} out of range (array has {len} entries)"),
                    )
                })?
            }
            other => {
                return Err(err(
                    &walked,
                    format!("cannot descend into a {}", other.type_str()),
                ))
            }
        };
    }
    match node {
        toml::Value::Table(t) => {
            let created = t.insert(last.to_string(), value).is_none();
            Ok(created.then(|| key_path.to_string()))
        }
        toml::Value::Array(a) => {
            let len = a.len();
            let i = array_index(last)
                .ok_or_else(|| err(key_path, "an array must be indexed by position".to_string()))?;
            let slot = a.get_mut(i).ok_or_else(|| {
                err(
                    key_path,
                    format!("index {i} out of range (array has {len} entries)"),
                )
            })?;
            *slot = value;
            Ok(None)
        }
        other => Err(err(
            key_path,
            format!("cannot set a key inside a {}", other.type_str()),
        )),
    }
}

fn array_index(seg: &str) -> Option<usize> {
    seg.parse().ok()
}

/// A TOML value from override text; plain string when it is not valid TOML.
fn parse_value(raw: &str) -> toml::Value {
    match toml::from_str::<toml::Table>(&format!("v = {raw}")) {
        Ok(mut t) => t
            .remove("v")
            .unwrap_or_else(|| toml::Value::String(raw.to_string())),
        Err(_) => toml::Value::String(raw.to_string()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::examples::{BLOCK_COMPRESSION_3D, IRONING_2D, STRIP_BENDING_2D};
    use crate::scene::{BcSpec, ElementFamily, Generator, MaterialModel, MeshSpec, OutputField};

    const FILE: &str = "cases/example.toml";

    fn parse(text: &str, overrides: &[&str]) -> Result<Case, SceneError> {
        let o: Vec<String> = overrides.iter().map(|s| s.to_string()).collect();
        parse_case(text, Path::new(FILE), &o)
    }

    /// Replace one exact snippet of a fixture, failing loudly if the fixture changed.
    fn edit(text: &str, from: &str, to: &str) -> String {
        assert_eq!(text.matches(from).count(), 1, "fixture snippet `{from}`");
        text.replacen(from, to, 1)
    }

    fn line_containing(text: &str, needle: &str) -> usize {
        text.lines().position(|l| l.contains(needle)).unwrap() + 1
    }

    /// The message must name the file and the key path.
    fn assert_names(e: &SceneError, key: &str) -> String {
        let shown = e.to_string();
        assert!(shown.contains(FILE), "no file name in: {shown}");
        assert!(
            shown.contains(&format!("`{key}`")),
            "no key `{key}` in: {shown}"
        );
        shown
    }

    #[test]
    fn block_compression_example_parses() {
        let c = parse(BLOCK_COMPRESSION_3D, &[]).unwrap();
        assert_eq!(c.case.dim, 3);
        assert!(matches!(
            &c.meshes["block"],
            MeshSpec::Generated(Generator::Box(p)) if p.divisions == [4, 4, 4]
        ));
        assert_eq!(c.bodies["block"].element, ElementFamily::Q1C1);
        assert_eq!(c.bcs.len(), 2);
        let BcSpec::Displacement(d) = &c.bcs[1] else {
            panic!("expected displacement bc")
        };
        assert_eq!(d.value, vec![vec![-0.2]]);
        assert_eq!(c.steps.max_cutbacks, 8, "default max_cutbacks");
        assert_eq!(c.output.fields.len(), 4);
        assert_eq!(c.output.fields[1], OutputField::I1);
        assert_eq!(c.file, Path::new(FILE));
    }

    #[test]
    fn strip_bending_example_parses_with_rotation_bc() {
        let c = parse(STRIP_BENDING_2D, &[]).unwrap();
        assert_eq!(c.bodies["strip"].element, ElementFamily::Q1E4);
        let BcSpec::Rotation(r) = &c.bcs[1] else {
            panic!("expected rotation bc")
        };
        assert_eq!(r.angle_deg, vec![45.0, 90.0]);
        assert_eq!(r.axis, None);
        assert_eq!(c.steps.max_cutbacks, 6);
        assert_eq!(c.steps.growth, 1.5, "default growth");
        assert_eq!(c.output.every, 1, "default every");
    }

    #[test]
    fn ironing_example_parses_with_two_bodies_and_tie() {
        let c = parse(IRONING_2D, &[]).unwrap();
        assert_eq!(c.bodies.len(), 2);
        assert_eq!(
            c.bodies["cylinder"].element,
            ElementFamily::Q1N { p: 2, t: 1 }
        );
        assert_eq!(c.bodies["block"].enriched_surface.as_deref(), Some("ymax"));
        assert_eq!(c.ties[0].offset, vec![10.0, 0.0]);
        assert_eq!(c.ties[0].tolerance, 1e-8, "default tolerance");
        assert_eq!(c.stages[1].steps, 60);
        assert_eq!(c.output.reactions.len(), 2);
    }

    #[test]
    fn resolved_case_round_trips_through_toml() {
        for text in [BLOCK_COMPRESSION_3D, STRIP_BENDING_2D, IRONING_2D] {
            let c = parse(text, &["stages.0.steps=7"]).unwrap();
            let stored = c.to_toml_string().unwrap();
            let back = parse(&stored, &[]).unwrap();
            assert_eq!(back, c);
            assert_eq!(back.stages[0].steps, 7);
        }
    }

    #[test]
    fn scene_rejects_unknown_key_with_path_and_line() {
        let text = edit(
            BLOCK_COMPRESSION_3D,
            "nu = 0.3\n",
            "nu = 0.3\npoisson = 0.3\n",
        );
        let e = parse(&text, &[]).unwrap_err();
        let shown = assert_names(&e, "bodies.block.material.poisson");
        let line = line_containing(&text, "poisson");
        assert!(shown.contains(&format!("{FILE}:{line}:")), "{shown}");
    }

    #[test]
    fn scene_rejects_a_retired_key_with_path_line_and_reason() {
        let text = edit(
            BLOCK_COMPRESSION_3D,
            "[solver]\n",
            "[solver]\ncontact_freeze_after = 4\n",
        );
        let e = parse(&text, &[]).unwrap_err();
        let shown = assert_names(&e, "solver.contact_freeze_after");
        let line = line_containing(&text, "contact_freeze_after");
        assert!(shown.contains(&format!("{FILE}:{line}:")), "{shown}");
        assert!(
            shown.contains("docs/formulations.md") && shown.contains("delete this line"),
            "{shown}"
        );
        let e = parse(BLOCK_COMPRESSION_3D, &["solver.contact_freeze_after=0"]).unwrap_err();
        let shown = assert_names(&e, "solver.contact_freeze_after");
        assert!(
            shown.contains("override `solver.contact_freeze_after=0`")
                && shown.contains("changed no measured result"),
            "{shown}"
        );
    }

    #[test]
    fn scene_rejects_a_renamed_gap_naming_its_new_name() {
        let case = include_str!("../../cases/ironing_2d.toml");
        for (old, new) in RENAMED_GAPS {
            let text = edit(
                case,
                "law = \"penalty\"\n",
                &format!("law = \"penalty\"\ngap = \"{old}\"\n"),
            );
            let e = parse(&text, &[]).unwrap_err();
            let shown = assert_names(&e, "contact.0.gap");
            let line = line_containing(&text, "gap =");
            assert!(shown.contains(&format!("{FILE}:{line}:")), "{shown}");
            assert!(shown.contains(&format!("gap = \"{new}\"")), "{shown}");
            let set = format!("contact.0.gap={old}");
            let e = parse(case, &[set.as_str()]).unwrap_err();
            let shown = assert_names(&e, "contact.0.gap");
            assert!(
                shown.contains(&format!("override `{set}`")) && shown.contains(new),
                "{shown}"
            );
            // the new name parses
            let text = edit(
                case,
                "law = \"penalty\"\n",
                &format!("law = \"penalty\"\ngap = \"{new}\"\n"),
            );
            parse(&text, &[]).unwrap();
        }
    }

    #[test]
    fn linear_elastic_material_parses_and_is_validated_like_neo_hookean() {
        let text = edit(
            BLOCK_COMPRESSION_3D,
            "model = \"neo_hookean\"",
            "model = \"linear_elastic\"",
        );
        let c = parse(&text, &[]).unwrap();
        assert_eq!(
            c.bodies["block"].material.model,
            MaterialModel::LinearElastic
        );
        let e = parse(&text, &["bodies.block.material.nu=0.5"]).unwrap_err();
        assert_names(&e, "bodies.block.material.nu");
        let e = parse(&text, &["bodies.block.material.E=0"]).unwrap_err();
        assert_names(&e, "bodies.block.material.E");
    }

    #[test]
    fn scene_rejects_misspelt_material_model_listing_the_models() {
        let text = edit(
            BLOCK_COMPRESSION_3D,
            "model = \"neo_hookean\"",
            "model = \"linear_elastc\"",
        );
        let e = parse(&text, &[]).unwrap_err();
        let shown = assert_names(&e, "bodies.block.material.model");
        let line = line_containing(&text, "linear_elastc");
        assert!(shown.contains(&format!("{FILE}:{line}:")), "{shown}");
        for accepted in ["`linear_elastc`", "`neo_hookean`", "`linear_elastic`"] {
            assert!(shown.contains(accepted), "no {accepted} in: {shown}");
        }
    }

    #[test]
    fn scene_rejects_unknown_generator_parameter_with_path() {
        let text = edit(
            BLOCK_COMPRESSION_3D,
            "divisions = [4, 4, 4]",
            "divisions = [4, 4, 4]\nradius = 2.0",
        );
        let e = parse(&text, &[]).unwrap_err();
        assert_names(&e, "meshes.block.radius");
    }

    #[test]
    fn scene_rejects_wrong_type_with_path_and_line() {
        let text = edit(BLOCK_COMPRESSION_3D, "nu = 0.3", "nu = \"soft\"");
        let e = parse(&text, &[]).unwrap_err();
        let shown = assert_names(&e, "bodies.block.material.nu");
        let line = line_containing(&text, "soft");
        assert!(shown.contains(&format!("{FILE}:{line}:")), "{shown}");
        assert!(shown.contains("invalid type"), "{shown}");
    }

    #[test]
    fn scene_rejects_wrong_type_inside_generator_with_path() {
        let text = edit(BLOCK_COMPRESSION_3D, "size = [1.0, 1.0, 1.0]", "size = 1.0");
        let e = parse(&text, &[]).unwrap_err();
        assert_names(&e, "meshes.block.size");
    }

    #[test]
    fn scene_rejects_missing_required_value_with_path() {
        let text = edit(BLOCK_COMPRESSION_3D, "E = 1.0\n", "");
        let e = parse(&text, &[]).unwrap_err();
        let shown = assert_names(&e, "bodies.block.material.E");
        assert!(shown.contains("missing field"), "{shown}");
        assert!(
            matches!(e, SceneError::Schema { line: Some(_), .. }),
            "{e:?}"
        );
    }

    #[test]
    fn scene_rejects_mesh_with_both_generator_and_file() {
        let text = edit(
            BLOCK_COMPRESSION_3D,
            "generator = \"box\"",
            "generator = \"box\"\nfile = \"a.msh\"",
        );
        let e = parse(&text, &[]).unwrap_err();
        let shown = assert_names(&e, "meshes.block");
        assert!(
            shown.contains("exactly one of `generator` or `file`"),
            "{shown}"
        );
    }

    #[test]
    fn scene_rejects_unknown_bc_kind() {
        let text = edit(
            BLOCK_COMPRESSION_3D,
            "kind = \"fixed\"",
            "kind = \"clamped\"",
        );
        let e = parse(&text, &[]).unwrap_err();
        let shown = assert_names(&e, "bcs.0.kind");
        assert!(shown.contains("clamped"), "{shown}");
    }

    #[test]
    fn scene_rejects_undefined_mesh_reference() {
        let text = edit(BLOCK_COMPRESSION_3D, "mesh = \"block\"", "mesh = \"brick\"");
        let e = parse(&text, &[]).unwrap_err();
        let shown = assert_names(&e, "bodies.block.mesh");
        assert!(shown.contains("undefined mesh `brick`"), "{shown}");
    }

    #[test]
    fn scene_rejects_undefined_body_reference() {
        let text = edit(
            BLOCK_COMPRESSION_3D,
            "set = \"zmin\"\nkind = \"fixed\"",
            "set = \"zmin\"\nkind = \"fixed\"\n",
        );
        let text = text.replacen(
            "body = \"block\"\nset = \"zmin\"",
            "body = \"bock\"\nset = \"zmin\"",
            1,
        );
        let e = parse(&text, &[]).unwrap_err();
        let shown = assert_names(&e, "bcs.0.body");
        assert!(shown.contains("undefined body `bock`"), "{shown}");
    }

    #[test]
    fn scene_rejects_nu_at_one_half() {
        let text = edit(BLOCK_COMPRESSION_3D, "nu = 0.3", "nu = 0.5");
        let e = parse(&text, &[]).unwrap_err();
        let shown = assert_names(&e, "bodies.block.material.nu");
        assert!(shown.contains("(-1, 0.5)"), "{shown}");
        let line = line_containing(&text, "nu = 0.5");
        assert!(
            shown.contains(&format!("line {line}: `bodies.block.material.nu`")),
            "{shown}"
        );
    }

    #[test]
    fn scene_rejects_non_positive_young_modulus() {
        let e = parse(BLOCK_COMPRESSION_3D, &["bodies.block.material.E=0"]).unwrap_err();
        // TOML `0` is an integer; the f64 field accepts it, so this is a value error, not a type error.
        let shown = assert_names(&e, "bodies.block.material.E");
        assert!(shown.contains("must be > 0"), "{shown}");
        let text = edit(BLOCK_COMPRESSION_3D, "E = 1.0", "E = -2.0");
        let e = parse(&text, &[]).unwrap_err();
        assert_names(&e, "bodies.block.material.E");
    }

    #[test]
    fn scene_rejects_zero_steps() {
        let text = edit(BLOCK_COMPRESSION_3D, "steps = 5", "steps = 0");
        let e = parse(&text, &[]).unwrap_err();
        let shown = assert_names(&e, "stages.0.steps");
        let line = line_containing(&text, "steps = 0");
        assert!(
            shown.contains(&format!("line {line}: `stages.0.steps`")),
            "{shown}"
        );
        // Set by an override: the file's line (which says 5) is not shown.
        let e = parse(BLOCK_COMPRESSION_3D, &["stages.0.steps=0"]).unwrap_err();
        let shown = assert_names(&e, "stages.0.steps");
        assert!(!shown.contains("line "), "{shown}");
    }

    #[test]
    fn scene_rejects_bad_element_name_with_line() {
        for bad in ["Q1N0", "Q1X"] {
            let text = edit(
                BLOCK_COMPRESSION_3D,
                "element = \"Q1C1\"",
                &format!("element = \"{bad}\""),
            );
            let e = parse(&text, &[]).unwrap_err();
            let shown = assert_names(&e, "bodies.block.element");
            assert!(shown.contains(bad), "{shown}");
            let line = line_containing(&text, bad);
            assert!(shown.contains(&format!("{FILE}:{line}:")), "{shown}");
        }
    }

    #[test]
    fn override_creates_a_top_level_table_the_case_left_at_defaults() {
        let c = parse(BLOCK_COMPRESSION_3D, &["steps.max_cutbacks=3"]).unwrap();
        assert_eq!(c.steps.max_cutbacks, 3);
        let e = parse(BLOCK_COMPRESSION_3D, &["stpes.max_cutbacks=3"]).unwrap_err();
        assert!(matches!(e, SceneError::Override { .. }), "{e:?}");
    }

    #[test]
    fn scene_rejects_override_of_unknown_path() {
        let e = parse(BLOCK_COMPRESSION_3D, &["bodies.brick.material.E=2"]).unwrap_err();
        assert!(matches!(e, SceneError::Override { .. }), "{e:?}");
        assert_names(&e, "bodies.brick");
        let e = parse(BLOCK_COMPRESSION_3D, &["case.nmae=foo"]).unwrap_err();
        assert!(matches!(e, SceneError::Override { .. }), "{e:?}");
        let shown = assert_names(&e, "case.nmae");
        assert!(shown.contains("unknown field"), "{shown}");
        let e = parse(BLOCK_COMPRESSION_3D, &["stages.3.steps=1"]).unwrap_err();
        let shown = assert_names(&e, "stages.3");
        assert!(shown.contains("out of range"), "{shown}");
        let e = parse(BLOCK_COMPRESSION_3D, &["no_equals_sign"]).unwrap_err();
        assert!(e.to_string().contains("key.path=value"), "{e}");
    }

    #[test]
    fn scene_rejects_wrong_number_of_stage_values() {
        // Two stages, but the displacement bc gives one value.
        let text = edit(
            BLOCK_COMPRESSION_3D,
            "name = \"compress\"\nsteps = 5\n",
            "name = \"compress\"\nsteps = 5\n\n[[stages]]\nname = \"hold\"\nsteps = 1\n",
        );
        let e = parse(&text, &[]).unwrap_err();
        let shown = assert_names(&e, "bcs.1.value");
        assert!(
            shown.contains("one vector per stage (2 stages), got 1"),
            "{shown}"
        );
        // Right count, wrong length per vector.
        let text = edit(
            BLOCK_COMPRESSION_3D,
            "value = [[-0.2]]",
            "value = [[0.0, -0.2]]",
        );
        let e = parse(&text, &[]).unwrap_err();
        assert_names(&e, "bcs.1.value.0");
        // The issue points at the `value = ` line of the second [[bcs]].
        let line = line_containing(&text, "value = [[0.0, -0.2]]");
        assert!(
            e.to_string()
                .contains(&format!("line {line}: `bcs.1.value.0`")),
            "{e}"
        );
    }

    #[test]
    fn scene_reports_syntax_error_line() {
        let text = edit(BLOCK_COMPRESSION_3D, "nu = 0.3", "nu = = 0.3");
        let e = parse(&text, &[]).unwrap_err();
        let line = line_containing(&text, "nu = =");
        let shown = e.to_string();
        assert!(matches!(e, SceneError::Syntax { .. }), "{e:?}");
        assert!(shown.contains(&format!("{FILE}:{line}:")), "{shown}");
    }

    #[test]
    fn missing_case_file_error_names_the_path() {
        let p = Path::new("/nonexistent/dir/case_xyz.toml");
        let e = load_case(p, &[]).unwrap_err();
        assert!(matches!(e, SceneError::Read { .. }));
        assert!(
            e.to_string().contains("/nonexistent/dir/case_xyz.toml"),
            "{e}"
        );
    }

    #[test]
    fn load_case_reads_file_and_resolves_relative_paths() {
        let dir = std::env::temp_dir().join(format!("scene_load_{}", std::process::id()));
        std::fs::create_dir_all(dir.join("meshes")).unwrap();
        std::fs::write(
            dir.join("meshes/foo.msh"),
            "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n",
        )
        .unwrap();
        let text = edit(
            STRIP_BENDING_2D,
            "generator = \"rectangle\"\norigin = [0.0, 0.0]\nsize = [20.0, 1.0]\ndivisions = [40, 2]",
            "file = \"meshes/foo.msh\"",
        );
        let path = dir.join("strip.toml");
        std::fs::write(&path, &text).unwrap();
        let c = load_case(&path, &[]).unwrap();
        let MeshSpec::File(f) = &c.meshes["strip"] else {
            panic!("expected a file mesh")
        };
        assert_eq!(c.resolve_path(&f.file), dir.join("meshes/foo.msh"));
        // A mesh file that does not exist is a validation error naming the key.
        let e = load_case(&path, &["meshes.strip.file=meshes/bar.msh".to_string()]).unwrap_err();
        let shown = e.to_string();
        assert!(
            shown.contains("`meshes.strip.file`") && shown.contains("bar.msh"),
            "{shown}"
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn overrides_replace_values_and_fall_back_to_strings() {
        let c = parse(
            BLOCK_COMPRESSION_3D,
            &[
                "bodies.block.material.nu=0.25",
                "solver.petsc_options=-snes_rtol 1e-8 -ksp_type preonly",
                "steps={ max_cutbacks = 3 }",
                "stages.0.steps=12",
                "output.fields=[\"displacement\"]",
                "case.description=\"quoted text\"",
            ],
        )
        .unwrap();
        assert_eq!(c.bodies["block"].material.nu, 0.25);
        assert_eq!(c.solver.petsc_options, "-snes_rtol 1e-8 -ksp_type preonly");
        assert_eq!(c.steps.max_cutbacks, 3);
        assert_eq!(c.steps.growth, 1.5);
        assert_eq!(c.stages[0].steps, 12);
        assert_eq!(c.output.fields, vec![OutputField::Displacement]);
        assert_eq!(c.case.description, "quoted text");
    }

    #[test]
    fn override_wrong_type_is_reported_at_its_key() {
        let e = parse(BLOCK_COMPRESSION_3D, &["stages.0.steps=many"]).unwrap_err();
        assert!(matches!(e, SceneError::Override { .. }), "{e:?}");
        let shown = assert_names(&e, "stages.0.steps");
        assert!(
            shown.contains("invalid type") && shown.contains("stages.0.steps=many"),
            "{shown}"
        );
    }

    #[test]
    fn schema_error_in_second_array_table_names_its_index() {
        let text = edit(
            BLOCK_COMPRESSION_3D,
            "kind = \"displacement\"",
            "kind = \"displacement\"\nscale = 2.0",
        );
        let e = parse(&text, &[]).unwrap_err();
        let shown = assert_names(&e, "bcs.1.scale");
        let line = line_containing(&text, "scale");
        assert!(shown.contains(&format!("{FILE}:{line}:")), "{shown}");
    }

    #[test]
    fn scene_rejects_unknown_output_field() {
        let text = edit(BLOCK_COMPRESSION_3D, "\"rank\"]", "\"pressure\"]");
        let e = parse(&text, &[]).unwrap_err();
        let shown = assert_names(&e, "output.fields");
        assert!(shown.contains("pressure"), "{shown}");
    }
}
