//! `case-keys.md`: the case-file keys, rendered from the case's JSON Schema
//! ([`crate::scene::json_schema::case_schema`]).
//!
//! One section per table, in the order of the schema's fields: a tagged table (`[meshes.<name>]` by
//! `generator`, `[[bcs]]` by `kind`) gets one section per variant. Each section has a summary table
//! (key, type, default, allowed values, unit) and then every key's description. Keys are written by
//! their dotted path, with `<name>` for a table's own key and `<i>` for a position in an array of
//! tables, as `--set` takes them (`bodies.<name>.material.E`, `stages.<i>.steps`).

use serde_json::{Map, Value};
use std::fmt::Write;

/// The whole page.
pub fn render(schema: &Value) -> String {
    let mut out = String::new();
    out.push_str(HEADER);
    let mut sections = Vec::new();
    walk(schema, &flatten(schema, schema), "", None, &mut sections);
    out.push_str("## Tables\n\n");
    for s in &sections {
        let _ = writeln!(out, "- [{}](#{})", s.title, anchor(&s.title));
    }
    out.push('\n');
    for s in &sections {
        out.push_str(&s.text);
    }
    out
}

const HEADER: &str = "\
# Case file keys

Generated from the case schema's types and doc comments by
`nurbs-contact reference --out docs/reference` (from the repository root:
`cargo run --release -- reference --out docs/reference`); do not edit by hand. A test fails when
this page, `case-schema.json` or `cli.md` differs from a fresh generation.

A case has no fixed system of units: give every quantity in one consistent set. The unit column
names the kind of quantity (`length`, `degrees`, `stress`, ...); a key without one is a count, a
name, a ratio or a switch. Keys are written by their dotted path as `--set` takes them: `<name>` is
a table's own name (`[meshes.block]`), `<i>` the position (from 0) in an array of tables
(`[[stages]]`). A key marked *required* must be given; any other key may be left out, and then takes
its default (or, without one, the behaviour its description states). Unknown keys are errors.

## Checking case files in an editor

`case-schema.json` beside this page is the JSON Schema (draft 07) of a case file: editors that read
JSON Schemas for TOML (taplo, and with it the Even Better TOML extension of VS Code) complete keys,
show these descriptions and mark unknown keys, wrong types and unknown names while typing.

- In this repository, `.taplo.toml` at the root associates the schema with `cases/*.toml` (the
  study files under `cases/studies/` have a different format and are left out).
- For a case file elsewhere, make its first line a schema directive with the path to the schema
  relative to the case file (or a URL), e.g.
  `#:schema ../nurbs-contact/docs/reference/case-schema.json`,
  or add a rule to your own `.taplo.toml`:

  ```toml
  [[rule]]
  include = [\"my-cases/**/*.toml\"]
  schema.path = \"path/to/docs/reference/case-schema.json\"
  ```

- `taplo check my_case.toml` checks on the command line with the same rules.

The schema checks each table on its own: which keys, their types, the names a key accepts and the
numeric bounds stated in the descriptions. `nurbs-contact check` checks everything else (references
between tables, per-stage list lengths, face and node sets of the meshes, combinations of options).

";

struct Section {
    title: String,
    text: String,
}

/// GitHub's heading anchors: lowercase, spaces to `-`, punctuation other than `-` and `_` dropped.
fn anchor(title: &str) -> String {
    title
        .chars()
        .filter_map(|c| match c {
            ' ' => Some('-'),
            c if c.is_alphanumeric() || c == '-' || c == '_' => Some(c.to_ascii_lowercase()),
            _ => None,
        })
        .collect()
}

/// `s` with `$ref`s replaced by their definitions, a one-element `allOf` merged in and
/// `Option`'s `anyOf [X, null]` / `type: [X, "null"]` reduced to `X`; the keys of `s` itself
/// (description, default, bounds) win over those of what it refers to.
fn flatten(root: &Value, s: &Value) -> Map<String, Value> {
    let Some(obj) = s.as_object() else {
        return Map::new();
    };
    let mut out = Map::new();
    let mut inner: Vec<&Value> = Vec::new();
    if let Some(Value::String(r)) = obj.get("$ref") {
        if let Some(target) = r
            .strip_prefix('#')
            .and_then(|pointer| root.pointer(pointer))
        {
            inner.push(target);
        }
    }
    if let Some(Value::Array(all)) = obj.get("allOf") {
        inner.extend(all.iter());
    }
    if let Some(Value::Array(any)) = obj.get("anyOf") {
        let non_null: Vec<&Value> = any.iter().filter(|v| v["type"] != "null").collect();
        if non_null.len() == 1 {
            inner.push(non_null[0]);
        }
    }
    for i in inner {
        for (k, v) in flatten(root, i) {
            out.insert(k, v);
        }
    }
    for (k, v) in obj {
        match k.as_str() {
            "$ref" | "allOf" => {}
            "anyOf" if !out.is_empty() => {}
            "type" => {
                let t = match v {
                    Value::Array(ts) => ts
                        .iter()
                        .find(|t| *t != "null")
                        .cloned()
                        .unwrap_or(Value::Null),
                    t => t.clone(),
                };
                out.insert(k.clone(), t);
            }
            _ => {
                out.insert(k.clone(), v.clone());
            }
        }
    }
    out
}

/// The variants of a tagged table (`oneOf` of tables), if `s` is one.
fn table_variants(s: &Map<String, Value>) -> Option<&Vec<Value>> {
    match s.get("oneOf") {
        Some(Value::Array(vs)) if vs.iter().all(|v| v.get("properties").is_some()) => Some(vs),
        _ => None,
    }
}

/// The names a string key accepts, with their descriptions (empty when undocumented).
fn allowed_names(s: &Map<String, Value>) -> Vec<(String, String)> {
    if let Some(Value::Array(vs)) = s.get("enum") {
        return vs.iter().map(|v| (v.to_string(), String::new())).collect();
    }
    if let Some(c) = s.get("const") {
        return vec![(c.to_string(), String::new())];
    }
    match s.get("oneOf") {
        Some(Value::Array(vs)) if table_variants(s).is_none() => vs
            .iter()
            .flat_map(|v| {
                let desc = v["description"].as_str().unwrap_or("").to_string();
                let names: Vec<Value> = match (v.get("const"), v.get("enum")) {
                    (Some(c), _) => vec![c.clone()],
                    (None, Some(Value::Array(e))) => e.clone(),
                    _ => Vec::new(),
                };
                names
                    .into_iter()
                    .map(move |n| (n.to_string(), desc.clone()))
            })
            .collect(),
        _ => Vec::new(),
    }
}

/// `number`, `integer`, `string`, `boolean`, `table`, `number[2]`, `string[]`, `table[]`, ...
fn type_name(root: &Value, s: &Map<String, Value>) -> String {
    if table_variants(s).is_some() || s.contains_key("properties") {
        return "table".into();
    }
    if !allowed_names(s).is_empty() {
        return "string".into();
    }
    match s.get("type").and_then(Value::as_str) {
        Some("object") => match s.get("additionalProperties") {
            Some(Value::Object(_)) => {
                let value = flatten(root, &s["additionalProperties"]);
                format!("tables of {} by name", type_name(root, &value))
                    .replace("tables of table by name", "tables by name")
            }
            _ => "table".into(),
        },
        Some("array") => {
            let items = flatten(root, s.get("items").unwrap_or(&Value::Null));
            let n = match (s.get("minItems"), s.get("maxItems")) {
                (Some(a), Some(b)) if a == b => a.to_string(),
                _ => String::new(),
            };
            format!("{}[{n}]", type_name(root, &items))
        }
        Some(t) => t.to_string(),
        None => "any".into(),
    }
}

/// A default as a TOML value (`1e-8`, `"secant"`, `[0, 0]`, `true`); tables as their own keys.
fn toml_value(v: &Value) -> String {
    match v {
        Value::Array(items) => {
            let inner: Vec<String> = items.iter().map(toml_value).collect();
            format!("[{}]", inner.join(", "))
        }
        Value::Object(map) => {
            let inner: Vec<String> = map
                .iter()
                .map(|(k, v)| format!("{k} = {}", toml_value(v)))
                .collect();
            format!("{{ {} }}", inner.join(", "))
        }
        other => other.to_string(),
    }
}

/// Numeric bounds and accepted names, for the summary table.
fn allowed_cell(s: &Map<String, Value>, names: &[(String, String)]) -> String {
    if !names.is_empty() {
        let names: Vec<String> = names.iter().map(|(n, _)| format!("`{n}`")).collect();
        return names.join(", ");
    }
    let mut parts = Vec::new();
    for (key, op) in [
        ("minimum", ">="),
        ("exclusiveMinimum", ">"),
        ("exclusiveMaximum", "<"),
        ("maximum", "<="),
    ] {
        if let Some(v) = s.get(key) {
            parts.push(format!("{op} {v}"));
        }
    }
    if let Some(Value::Array(ex)) = s.get("examples") {
        let ex: Vec<String> = ex.iter().map(|e| format!("`{}`", toml_value(e))).collect();
        parts.push(format!("e.g. {}", ex.join(", ")));
    }
    parts.join(", ")
}

/// One summary row and the description block of key `path` (schema `s`).
fn describe_key(
    root: &Value,
    path: &str,
    s: &Map<String, Value>,
    required: bool,
    rows: &mut String,
    details: &mut String,
) {
    let ty = type_name(root, s);
    // a list of names (`output.fields`) accepts its items' names
    let names = match (s.get("type").and_then(Value::as_str), s.get("items")) {
        (Some("array"), Some(items)) => allowed_names(&flatten(root, items)),
        _ => allowed_names(s),
    };
    let default = if required {
        "*required*".to_string()
    } else {
        match s.get("default") {
            Some(Value::Object(_)) => "see its table".to_string(),
            Some(v) => format!("`{}`", toml_value(v)),
            None => String::new(),
        }
    };
    let unit = s.get("x-unit").and_then(Value::as_str).unwrap_or("");
    let _ = writeln!(
        rows,
        "| `{path}` | {} | {} | {} | {} |",
        cell(&ty),
        cell(&default),
        cell(&allowed_cell(s, &names)),
        cell(unit)
    );
    let desc = s.get("description").and_then(Value::as_str).unwrap_or("");
    let _ = write!(details, "- `{path}`");
    if desc.is_empty() {
        details.push('\n');
    } else {
        details.push_str(": ");
        details.push_str(paragraphs(desc, "  ").trim_start());
    }
    if names.iter().any(|(_, d)| !d.is_empty()) {
        for (n, d) in names {
            // variant docs often open with their own name: "`\"exact\"` (default): ..."
            let d = d
                .strip_prefix(&format!("`{n}`"))
                .map_or(d.as_str(), |r| r.trim_start_matches([':', ' ']))
                .to_string();
            let _ = write!(details, "  - `{n}`");
            if d.is_empty() {
                details.push('\n');
            } else {
                details.push_str(": ");
                details.push_str(paragraphs(&d, "    ").trim_start());
            }
        }
    }
}

/// Markdown table cells: no line breaks, `|` escaped.
fn cell(text: &str) -> String {
    super::escape_prose(&text.replace('|', "\\|").replace('\n', " "))
}

/// A doc comment as Markdown under `indent`: the lines of each paragraph joined (rustdoc wraps
/// them), fenced code kept verbatim, paragraphs separated by blank lines.
fn paragraphs(text: &str, indent: &str) -> String {
    let mut out = String::new();
    let mut para: Vec<&str> = Vec::new();
    let mut in_code = false;
    let flush = |para: &mut Vec<&str>, out: &mut String| {
        if !para.is_empty() {
            if !out.is_empty() {
                out.push('\n');
            }
            let _ = writeln!(out, "{indent}{}", super::escape_prose(&para.join(" ")));
            para.clear();
        }
    };
    for line in text.lines() {
        let trimmed = line.trim();
        if trimmed.starts_with("```") {
            if !in_code {
                flush(&mut para, &mut out);
                if !out.is_empty() {
                    out.push('\n');
                }
            }
            in_code = !in_code;
            let _ = writeln!(out, "{indent}{line}");
            continue;
        }
        if in_code {
            let _ = writeln!(out, "{indent}{line}");
        } else if trimmed.is_empty() {
            flush(&mut para, &mut out);
        } else {
            para.push(trimmed);
        }
    }
    flush(&mut para, &mut out);
    out
}

/// Sections of the table `s` at `path` (`""` for the top level), then of the tables below it.
/// `variant` names the tag of a tagged table's variant (`generator = "box"`).
fn walk(
    root: &Value,
    s: &Map<String, Value>,
    path: &str,
    variant: Option<String>,
    sections: &mut Vec<Section>,
) {
    if let Some(vs) = table_variants(s) {
        for v in vs {
            let v = flatten(root, v);
            walk(root, &v, path, Some(variant_label(&v)), sections);
        }
        return;
    }
    let Some(Value::Object(props)) = s.get("properties") else {
        return;
    };
    let required: Vec<&str> = match s.get("required") {
        Some(Value::Array(r)) => r.iter().filter_map(Value::as_str).collect(),
        _ => Vec::new(),
    };
    let title = match (path, &variant) {
        ("", _) => "Top level".to_string(),
        (p, None) => format!("`{p}`"),
        (p, Some(v)) => format!("`{p}` with {v}"),
    };
    let mut text = format!("### {title}\n\n");
    if let Some(Value::String(d)) = s.get("description") {
        text.push_str(&paragraphs(d, ""));
        text.push('\n');
    }
    let mut rows = String::from(
        "| Key | Type | Default | Allowed values | Unit |\n| --- | --- | --- | --- | --- |\n",
    );
    let mut details = String::new();
    let mut below = Vec::new();
    for (key, prop) in props {
        let child = flatten(root, prop);
        let child_path = if path.is_empty() {
            key.clone()
        } else {
            format!("{path}.{key}")
        };
        describe_key(
            root,
            &child_path,
            &child,
            required.contains(&key.as_str()),
            &mut rows,
            &mut details,
        );
        below.push((child_path, child));
    }
    let _ = write!(text, "{rows}\n{details}\n");
    sections.push(Section { title, text });
    for (child_path, child) in below {
        descend(root, &child, &child_path, sections);
    }
}

/// Tables under the key `path` of schema `s`: a table, a tagged table, tables by name or an array
/// of tables.
fn descend(root: &Value, s: &Map<String, Value>, path: &str, sections: &mut Vec<Section>) {
    if s.contains_key("properties") || table_variants(s).is_some() {
        walk(root, s, path, None, sections);
    } else if let Some(v @ Value::Object(_)) = s.get("additionalProperties") {
        descend(root, &flatten(root, v), &format!("{path}.<name>"), sections);
    } else if s.get("type").and_then(Value::as_str) == Some("array") {
        if let Some(items) = s.get("items") {
            descend(
                root,
                &flatten(root, items),
                &format!("{path}.<i>"),
                sections,
            );
        }
    }
}

/// `` `generator = "box"` `` for a variant with a `const` tag, else `` `file` `` (its required
/// keys).
fn variant_label(v: &Map<String, Value>) -> String {
    if let Some(Value::Object(props)) = v.get("properties") {
        for (k, p) in props {
            if let Some(c) = p.get("const") {
                return format!("`{k} = {c}`");
            }
        }
    }
    let required: Vec<String> = match v.get("required") {
        Some(Value::Array(r)) => r
            .iter()
            .filter_map(Value::as_str)
            .map(|k| format!("`{k}`"))
            .collect(),
        _ => Vec::new(),
    };
    required.join(", ")
}

#[cfg(test)]
mod tests {
    use super::*;

    fn page() -> String {
        render(&crate::scene::json_schema::case_schema())
    }

    #[test]
    fn every_key_of_every_table_has_a_row() {
        let p = page();
        for key in [
            "`case.dim`",
            "`meshes.<name>.generator`",
            "`meshes.<name>.file`",
            "`meshes.<name>.grading`",
            "`bodies.<name>.material.E`",
            "`bodies.<name>.node_sets.<name>.within`",
            "`bcs.<i>.kind`",
            "`bcs.<i>.free_translation`",
            "`contact.<i>.rigid.rotation_axis`",
            "`contact.<i>.augmented.tol`",
            "`contact.<i>.region.min`",
            "`stages.<i>.steps`",
            "`steps.pseudo_steps`",
            "`solver.predictor`",
            "`output.reactions.<i>.moment_about`",
        ] {
            assert!(p.contains(&format!("| {key} |")), "no row for {key}");
        }
    }

    #[test]
    fn rows_carry_types_defaults_allowed_values_and_units() {
        let p = page();
        for row in [
            "| `solver.predictor` | string | `\"secant\"` | `\"none\"`, `\"secant\"` |  |",
            "| `ties.<i>.tolerance` | number | `1e-8` |  | length |",
            "| `stages.<i>.steps` | integer | *required* | >= 1 |  |",
            "| `meshes.<name>.origin` | number[3] | `[0.0, 0.0, 0.0]` |  | length |",
            "| `bodies.<name>.material.nu` | number | *required* | > -1, &lt; 0.5 |  |",
            "| `case.dim` | integer | *required* | >= 2, &lt;= 3 |  |",
            "| `contact.<i>.gap` | string | `\"pointwise\"` | `\"pointwise\"`, `\"element_mean\"`, `\"weighted\"`, `\"weighted_linear\"`, `\"weighted_mean\"` |  |",
            "| `output.fields` | string[] | `[\"displacement\"]` | `\"displacement\"`, `\"I1\"`, `\"von_mises\"`, `\"rank\"` |  |",
            "| `meshes` | tables by name | *required* |  |  |",
            "| `contact.<i>.rigid.rotation_deg` | number[] |  |  | degrees |",
        ] {
            assert!(p.contains(row), "missing row {row}");
        }
        assert!(p.contains("### `meshes.<name>` with `generator = \"quarter_sphere\"`"));
        assert!(p.contains("### `bcs.<i>` with `kind = \"radial\"`"));
        assert!(p.contains("### `meshes.<name>` with `file`"));
        // every key is described (a field without a doc comment would show a bare key)
        let bare: Vec<&str> = p
            .lines()
            .filter(|l| l.starts_with("- `") && l.ends_with('`') && l.matches('`').count() == 2)
            .collect();
        assert!(bare.is_empty(), "keys without a description: {bare:?}");
    }

    #[test]
    fn doc_comment_paragraphs_join_their_lines_and_keep_code() {
        let text = "one\ntwo\n\n```toml\na = 1\n```\nthree";
        assert_eq!(
            paragraphs(text, "  "),
            "  one two\n\n  ```toml\n  a = 1\n  ```\n\n  three\n"
        );
        assert_eq!(
            anchor("`bcs.<i>` with `kind = \"radial\"`"),
            "bcsi-with-kind--radial"
        );
    }
}
