//! The JSON Schema of a case file, generated from the schema's types and their doc comments
//! (`schemars`), shipped as `docs/reference/case-schema.json` for editors (taplo / Even Better TOML)
//! and rendered into `docs/reference/case-keys.md` (see `crate::reference`).
//!
//! Most types derive `JsonSchema` beside `Deserialize`. The tables that are dispatched by hand on a
//! tag ([`MeshSpec`] on `generator`, [`BcSpec`] on `kind`) and the element family (a string parsed
//! by [`ElementFamily`]'s `FromStr`) have their schemas written here to match those parsers: a tagged
//! table is a `oneOf` of its variants, each the variant's own table with the tag as a `const`.
//!
//! The schema describes the structure: which keys, of which types, which names and (where the
//! doc comments state them) numeric bounds. What needs the whole case (references between tables,
//! per-stage list lengths, face sets of meshes) stays with [`crate::scene::validate()`].

use crate::scene::element_family::{ElementFamily, MAX_NURBS_ORDER};
use crate::scene::schema::{
    BcSpec, BoxParams, Case, DisplacementBc, FileMesh, FixedBc, HalfDiskParams, HemisphereParams,
    MeshSpec, QuarterSphereParams, RadialBc, RectangleParams, RotationBc, SectorParams, SlidingBc,
};
use schemars::generate::SchemaSettings;
use schemars::{json_schema, JsonSchema, Schema, SchemaGenerator};
use serde_json::Value;
use std::borrow::Cow;

/// `$id` of the shipped schema.
pub const SCHEMA_ID: &str = "urn:nurbs-contact:case";

/// `title` of the shipped schema.
pub const SCHEMA_TITLE: &str = "nurbs-contact case file";

/// The JSON Schema (draft 07, which taplo and most editors read) of a whole case file, with `$id`,
/// `title`, descriptions from the doc comments (rustdoc links reduced to their code text), defaults,
/// allowed values, bounds and units (the extension keyword `x-unit`).
pub fn case_schema() -> Value {
    let generator = SchemaSettings::draft07().into_generator();
    let generated = generator.into_root_schema_for::<Case>().to_value();
    let mut root = serde_json::Map::new();
    root.insert("$schema".into(), generated["$schema"].clone());
    root.insert("$id".into(), Value::String(SCHEMA_ID.into()));
    root.insert("title".into(), Value::String(SCHEMA_TITLE.into()));
    if let Value::Object(rest) = generated {
        for (k, v) in rest {
            root.entry(k).or_insert(v);
        }
    }
    let mut schema = Value::Object(root);
    strip_doc_links(&mut schema);
    schema
}

/// Rustdoc's intra-doc links (``[`Name`]``) become plain code spans (`` `Name` ``) in every
/// `description`: the reader of a case file has no rustdoc to follow them into.
fn strip_doc_links(v: &mut Value) {
    match v {
        Value::Object(map) => {
            for (k, x) in map.iter_mut() {
                match x {
                    Value::String(s) if k == "description" => *s = unlink(s),
                    _ => strip_doc_links(x),
                }
            }
        }
        Value::Array(items) => items.iter_mut().for_each(strip_doc_links),
        _ => {}
    }
}

/// ``[`a`]`` -> `` `a` ``, leaving Markdown links ``[`a`](url)`` alone.
fn unlink(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    let mut rest = s;
    while let Some(start) = rest.find("[`") {
        let after = &rest[start + 2..];
        let Some(end) = after.find("`]") else { break };
        let code = &after[..end];
        let tail = &after[end + 2..];
        out.push_str(&rest[..start]);
        if tail.starts_with('(') || code.contains('\n') {
            out.push_str(&rest[start..start + 2 + end + 2]);
        } else {
            out.push('`');
            out.push_str(code);
            out.push('`');
        }
        rest = tail;
    }
    out.push_str(rest);
    out
}

/// The schema of `T`'s table with the tag `tag = "name"` added as a required `const` key.
/// `what` says what the tag selects, for its description.
fn tagged<T: JsonSchema>(g: &mut SchemaGenerator, tag: &str, name: &str, what: &str) -> Value {
    let mut s = T::json_schema(g).to_value();
    let obj = s
        .as_object_mut()
        .expect("a variant of a tagged table is a struct, whose schema is an object");
    // the tag first, then the variant's own keys
    let mut props = serde_json::Map::new();
    props.insert(
        tag.into(),
        serde_json::json!({
            "type": "string",
            "const": name,
            "description": format!("Selects this {what}."),
        }),
    );
    if let Some(Value::Object(own)) = obj.remove("properties") {
        props.extend(own);
    }
    obj.insert("properties".into(), Value::Object(props));
    let required = obj
        .entry("required")
        .or_insert_with(|| Value::Array(Vec::new()));
    if let Value::Array(required) = required {
        required.insert(0, Value::String(tag.into()));
    }
    s
}

impl JsonSchema for MeshSpec {
    fn schema_name() -> Cow<'static, str> {
        "MeshSpec".into()
    }

    fn json_schema(g: &mut SchemaGenerator) -> Schema {
        let tag = "generator";
        json_schema!({
            "description": "`[meshes.<name>]`: exactly one of `generator = \"...\"` (with that \
                            generator's parameters) or `file`.",
            "type": "object",
            "oneOf": [
                tagged::<RectangleParams>(g, tag, "rectangle", "generator"),
                tagged::<HalfDiskParams>(g, tag, "half_disk", "generator"),
                tagged::<SectorParams>(g, tag, "sector", "generator"),
                tagged::<BoxParams>(g, tag, "box", "generator"),
                tagged::<HemisphereParams>(g, tag, "hemisphere", "generator"),
                tagged::<HemisphereParams>(g, tag, "hemisphere_nurbs", "generator"),
                tagged::<QuarterSphereParams>(g, tag, "quarter_sphere", "generator"),
                tagged::<QuarterSphereParams>(g, tag, "sphere_cap", "generator"),
                FileMesh::json_schema(g).to_value(),
            ],
        })
    }
}

impl JsonSchema for BcSpec {
    fn schema_name() -> Cow<'static, str> {
        "BcSpec".into()
    }

    fn json_schema(g: &mut SchemaGenerator) -> Schema {
        let tag = "kind";
        json_schema!({
            "description": "`[[bcs]]`: a Dirichlet condition on a node set of a body, tagged by `kind`.",
            "type": "object",
            "oneOf": [
                tagged::<FixedBc>(g, tag, "fixed", "kind of condition"),
                tagged::<DisplacementBc>(g, tag, "displacement", "kind of condition"),
                tagged::<RotationBc>(g, tag, "rotation", "kind of condition"),
                tagged::<RadialBc>(g, tag, "radial", "kind of condition"),
                tagged::<SlidingBc>(g, tag, "sliding", "kind of condition"),
            ],
        })
    }
}

impl JsonSchema for ElementFamily {
    fn schema_name() -> Cow<'static, str> {
        "ElementFamily".into()
    }

    fn json_schema(_: &mut SchemaGenerator) -> Schema {
        json_schema!({
            "description": format!(
                "Element family: `Q1C1` (bilinear/trilinear Lagrange), `Q1E4` (2D, enhanced \
                 assumed strain), `Q1N<p>` or `Q1N<p>.<t>` (NURBS-enriched contact layer of order \
                 p in 1..={MAX_NURBS_ORDER}, with t knot insertions per surface element; p + t at \
                 most {}), `Q1C2` (2D, quadratic Lagrange layer), `Q1CH` (2D, Hermite layer).",
                crate::geometry::MAX_ORDER
            ),
            "type": "string",
            "pattern": family_pattern(),
            "examples": ["Q1C1", "Q1N2", "Q1N2.1", "Q1E4", "Q1C2", "Q1CH"],
        })
    }
}

/// A regular expression of the names [`ElementFamily`] parses, except for the bound on `p + t`.
fn family_pattern() -> String {
    // p in 1..=MAX_NURBS_ORDER (the parser reads digits, so leading zeros pass)
    let orders: Vec<String> = (1..=MAX_NURBS_ORDER).rev().map(|p| p.to_string()).collect();
    format!(
        "^(Q1C1|Q1E4|Q1C2|Q1CH|Q1N0*({})(\\.[0-9]+)?)$",
        orders.join("|")
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn validator() -> jsonschema::Validator {
        jsonschema::validator_for(&case_schema()).expect("the case schema compiles")
    }

    #[test]
    fn schema_has_id_title_and_draft07() {
        let s = case_schema();
        assert_eq!(s["$id"], SCHEMA_ID);
        assert_eq!(s["title"], SCHEMA_TITLE);
        assert_eq!(s["$schema"], "http://json-schema.org/draft-07/schema#");
        assert_eq!(s["additionalProperties"], false);
    }

    #[test]
    fn doc_links_become_code_spans() {
        assert_eq!(unlink("see [`StepControl`]."), "see `StepControl`.");
        assert_eq!(unlink("[`a`](http://x) [`b`]"), "[`a`](http://x) `b`");
        assert_eq!(unlink("no [`end"), "no [`end");
        let text = case_schema().to_string();
        assert!(
            !text.contains("[`"),
            "an intra-doc link is left in the schema"
        );
    }

    #[test]
    fn element_family_pattern_accepts_exactly_the_parsed_names_up_to_the_order_bound() {
        let schema = ElementFamily::json_schema(&mut SchemaSettings::draft07().into_generator());
        let v = jsonschema::validator_for(schema.as_value()).unwrap();
        let mut names: Vec<String> = [
            "Q1C1", "Q1E4", "Q1C2", "Q1CH", "Q1N", "Q1C3", "q1c1", "Q1N2.",
        ]
        .map(String::from)
        .to_vec();
        for p in [
            "0", "00", "01", "1", "2", "9", "10", "16", "016", "17", "20", "x",
        ] {
            names.push(format!("Q1N{p}"));
            for t in ["0", "1", "3", "4", "5", "99999999999", "x", ""] {
                names.push(format!("Q1N{p}.{t}"));
            }
        }
        for n in &names {
            let parsed = n.parse::<ElementFamily>();
            // the pattern leaves the bound on p + t to the parser
            let over_order = matches!(&parsed, Err(e) if e.reason.starts_with("refinement level")
                && !e.reason.contains("not a non-negative integer"));
            assert_eq!(
                v.is_valid(&Value::String(n.clone())),
                parsed.is_ok() || over_order,
                "{n}: parser says {parsed:?}"
            );
        }
    }

    #[test]
    fn tagged_tables_need_their_tag_and_reject_other_variants_keys() {
        let v = validator();
        let case = |mesh: Value, bc: Value| {
            serde_json::json!({
                "case": { "name": "t", "dim": 2 },
                "meshes": { "m": mesh },
                "bodies": { "b": { "mesh": "m", "element": "Q1C1",
                    "material": { "model": "neo_hookean", "E": 1.0, "nu": 0.3 } } },
                "bcs": [bc],
                "stages": [{ "name": "s", "steps": 1 }],
            })
        };
        let rect = serde_json::json!({ "generator": "rectangle", "size": [1.0, 1.0], "divisions": [1, 1] });
        let fixed = serde_json::json!({ "kind": "fixed", "body": "b", "set": "left" });
        assert!(v.is_valid(&case(rect.clone(), fixed.clone())));
        assert!(v.is_valid(&case(serde_json::json!({ "file": "m.msh" }), fixed.clone())));
        let bad_meshes = [
            serde_json::json!({ "generator": "disk", "size": [1.0, 1.0], "divisions": [1, 1] }),
            serde_json::json!({ "size": [1.0, 1.0], "divisions": [1, 1] }),
            serde_json::json!({ "generator": "rectangle", "file": "m.msh", "size": [1.0, 1.0], "divisions": [1, 1] }),
            serde_json::json!({ "generator": "rectangle", "size": [1.0, 1.0], "divisions": [1, 1], "radius": 1.0 }),
            serde_json::json!({ "generator": "box", "size": [1.0, 1.0], "divisions": [1, 1] }),
        ];
        for m in bad_meshes {
            assert!(!v.is_valid(&case(m.clone(), fixed.clone())), "{m}");
        }
        let bad_bcs = [
            serde_json::json!({ "body": "b", "set": "left" }),
            serde_json::json!({ "kind": "clamped", "body": "b", "set": "left" }),
            serde_json::json!({ "kind": "fixed", "body": "b", "set": "left", "value": [[0.0]] }),
            serde_json::json!({ "kind": "displacement", "body": "b", "set": "left" }),
        ];
        for b in bad_bcs {
            assert!(!v.is_valid(&case(rect.clone(), b.clone())), "{b}");
        }
    }
}
