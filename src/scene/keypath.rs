//! Key paths in deserialisation errors.
//!
//! `toml`'s value deserialiser reports the table path of an error as a trailing ``in `a.b` `` line but
//! leaves the offending field name inside the message (``unknown field `foo` ``). Tables that we dispatch
//! by hand on a tag (`generator`, `kind`) deserialise their body from a fresh value, so their inner path
//! is carried up as an ``at `sub.path`: `` prefix. This file turns all of that into one dotted key path.

/// Split a `toml` deserialisation error into its bare message and the table path it reported.
pub(crate) fn split_toml_error(e: &toml::de::Error) -> (String, Option<String>) {
    let shown = e.to_string();
    let path = shown
        .lines()
        .rev()
        .find_map(|l| l.strip_prefix("in `").and_then(|r| r.strip_suffix('`')))
        .map(str::to_string);
    (e.message().to_string(), path)
}

/// Render an inner error so that [`resolve_key`] can rebuild the full path once the outer deserialiser
/// has added its own prefix.
pub(crate) fn nest_message(message: &str, inner_path: Option<&str>) -> String {
    match inner_path {
        Some(p) if !p.is_empty() => format!("at `{p}`: {message}"),
        _ => message.to_string(),
    }
}

/// Combine the outer table path and the message into `(full key path, message)`: unwraps the
/// ``at `sub`: `` prefixes of [`nest_message`] and appends the field named by serde's
/// ``unknown field `x` `` / ``missing field `x` `` messages.
pub(crate) fn resolve_key(outer: Option<&str>, message: &str) -> (String, String) {
    let mut key: Vec<String> = outer
        .filter(|p| !p.is_empty())
        .map(|p| vec![p.to_string()])
        .unwrap_or_default();
    let mut msg = message;
    while let Some(rest) = msg.strip_prefix("at `") {
        match rest.split_once("`: ") {
            Some((sub, tail)) => {
                key.push(sub.to_string());
                msg = tail;
            }
            None => break,
        }
    }
    for marker in ["unknown field `", "missing field `"] {
        if let Some(rest) = msg.strip_prefix(marker) {
            if let Some((field, _)) = rest.split_once('`') {
                key.push(field.to_string());
            }
        }
    }
    let key = if key.is_empty() {
        "<root>".to_string()
    } else {
        key.join(".")
    };
    (key, msg.to_string())
}

/// 1-based line of a byte offset in `text`.
pub(crate) fn line_of(text: &str, offset: usize) -> usize {
    let end = offset.min(text.len());
    text.as_bytes()[..end]
        .iter()
        .filter(|&&b| b == b'\n')
        .count()
        + 1
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn resolve_key_unwraps_nested_prefix_and_field_name() {
        let (k, m) = resolve_key(Some("meshes.a"), "at `size`: invalid type");
        assert_eq!(k, "meshes.a.size");
        assert_eq!(m, "invalid type");
        let (k, _) = resolve_key(
            Some("bodies.b.material"),
            "unknown field `foo`, expected `E`",
        );
        assert_eq!(k, "bodies.b.material.foo");
        let (k, _) = resolve_key(None, "missing field `case`");
        assert_eq!(k, "case");
    }

    #[test]
    fn line_of_counts_newlines_before_offset() {
        assert_eq!(line_of("a\nb\nc", 0), 1);
        assert_eq!(line_of("a\nb\nc", 2), 2);
        assert_eq!(line_of("a\nb\nc", 4), 3);
    }
}
