//! A small JSON Schema 2020-12 checker for the service's own OpenAPI document: enough of
//! the vocabulary the derived schemas use (`$ref`, `type`, `enum`, `const`, `properties`,
//! `required`, `additionalProperties`, `items`, `prefixItems`, `anyOf`, `oneOf`, `allOf`)
//! to tell whether an answer of the API is what the document promises.

use serde_json::Value;

/// Where `value` breaks `schema` (empty: it conforms); `$ref`s resolve in `document`.
pub fn violations(document: &Value, schema: &Value, value: &Value) -> Vec<String> {
    let mut found = Vec::new();
    check(document, schema, value, "$", &mut found);
    found
}

fn type_matches(name: &str, value: &Value) -> bool {
    match name {
        "null" => value.is_null(),
        "boolean" => value.is_boolean(),
        "integer" => value.is_i64() || value.is_u64(),
        "number" => value.is_number(),
        "string" => value.is_string(),
        "array" => value.is_array(),
        "object" => value.is_object(),
        _ => false,
    }
}

fn check(document: &Value, schema: &Value, value: &Value, at: &str, found: &mut Vec<String>) {
    let schema = match schema {
        Value::Bool(true) => return,
        Value::Bool(false) => return found.push(format!("{at}: nothing is allowed here")),
        Value::Object(schema) => schema,
        other => return found.push(format!("{at}: the schema {other} is not a schema")),
    };
    if let Some(reference) = schema.get("$ref").and_then(Value::as_str) {
        let pointer = reference.trim_start_matches('#');
        match document.pointer(pointer) {
            Some(target) => check(document, target, value, at, found),
            None => found.push(format!("{at}: unresolved {reference}")),
        }
    }
    match schema.get("type") {
        Some(Value::String(name)) if !type_matches(name, value) => found.push(format!("{at}: expected {name}, found {value}")),
        Some(Value::Array(names)) if !names.iter().filter_map(Value::as_str).any(|n| type_matches(n, value)) => {
            found.push(format!("{at}: expected one of {names:?}, found {value}"))
        }
        _ => {}
    }
    if let Some(options) = schema.get("enum").and_then(Value::as_array)
        && !options.contains(value)
    {
        found.push(format!("{at}: {value} is not one of {options:?}"));
    }
    if let Some(expected) = schema.get("const")
        && expected != value
    {
        found.push(format!("{at}: expected {expected}, found {value}"));
    }
    if let Value::Object(object) = value {
        let properties = schema.get("properties").and_then(Value::as_object);
        for name in schema.get("required").and_then(Value::as_array).into_iter().flatten().filter_map(Value::as_str) {
            if !object.contains_key(name) {
                found.push(format!("{at}: the required '{name}' is missing"));
            }
        }
        for (name, item) in object {
            match properties.and_then(|p| p.get(name)) {
                Some(property) => check(document, property, item, &format!("{at}.{name}"), found),
                None => {
                    if let Some(extra) = schema.get("additionalProperties") {
                        check(document, extra, item, &format!("{at}.{name}"), found);
                    }
                }
            }
        }
    }
    if let Value::Array(items) = value {
        let prefix = schema.get("prefixItems").and_then(Value::as_array).map_or(&[][..], Vec::as_slice);
        for (k, item) in items.iter().enumerate() {
            let at = format!("{at}[{k}]");
            match prefix.get(k) {
                Some(first) => check(document, first, item, &at, found),
                None => {
                    if let Some(rest) = schema.get("items") {
                        check(document, rest, item, &at, found);
                    }
                }
            }
        }
    }
    let passing = |options: &Vec<Value>| options.iter().filter(|o| violations(document, o, value).is_empty()).count();
    if let Some(options) = schema.get("anyOf").and_then(Value::as_array)
        && passing(options) == 0
    {
        found.push(format!("{at}: matches none of anyOf"));
    }
    if let Some(options) = schema.get("oneOf").and_then(Value::as_array)
        && passing(options) != 1
    {
        found.push(format!("{at}: matches {} of oneOf, not exactly one", passing(options)));
    }
    for part in schema.get("allOf").and_then(Value::as_array).into_iter().flatten() {
        check(document, part, value, at, found);
    }
}

/// The schema the document gives the success answer of `method path` (a path template).
pub fn response_schema<'a>(document: &'a Value, method: &str, path: &str) -> &'a Value {
    let responses = &document["paths"][path][method]["responses"];
    let success = responses.as_object().and_then(|r| r.iter().find(|(code, _)| code.starts_with('2'))).map(|(_, r)| r);
    success.and_then(|r| r.pointer("/content/application~1json/schema")).unwrap_or_else(|| panic!("{method} {path} has no JSON schema"))
}

#[cfg(test)]
mod tests {
    use serde_json::json;

    use super::violations;

    #[test]
    fn the_checker_finds_what_breaks_a_schema() {
        let document = json!({"components": {"schemas": {"Pair": {"type": "array", "prefixItems": [{"type": "number"}, {"type": "number"}]}}}});
        let schema = json!({
            "type": "object", "required": ["id", "state"],
            "properties": {"id": {"type": "string"}, "state": {"enum": ["queued", "scored"]}, "ci": {"anyOf": [{"$ref": "#/components/schemas/Pair"}, {"type": "null"}]}},
            "additionalProperties": {"type": "integer"}
        });
        assert!(violations(&document, &schema, &json!({"id": "a", "state": "queued", "ci": [0.1, 0.2], "n": 3})).is_empty());
        let broken = violations(&document, &schema, &json!({"state": "lost", "ci": ["x"], "n": 0.5}));
        assert_eq!(broken.len(), 4, "{broken:?}");
    }
}
