//! `GET /api/docs`: the API reference as a page — every operation with what it takes and
//! answers, every problem code, every schema with its fields — rendered on the server
//! from the same document `/api/v1/openapi.json` serves (no external assets).

use askama::Template;
use askama_web::WebTemplate;
use serde_json::Value;

use axum::Extension;

use super::openapi::{Served, document_value};
use super::operation::Operation;
use crate::problem::ProblemCode;

pub struct OperationView {
    pub method: String,
    /// The path as HTML: escaped, with a line-break opportunity after each `/` (a narrow
    /// screen breaks a long path between its segments, never inside one).
    pub path_html: String,
    pub auth: &'static str,
    /// The summary as HTML: escaped, with `code` spans.
    pub summary_html: String,
    /// What the request body and the success answer are, as HTML (schema links).
    pub takes_html: String,
    pub answers_html: String,
}

/// One field of a documented schema.
pub struct FieldView {
    pub name: String,
    pub type_html: String,
    pub required: bool,
    pub description_html: String,
}

/// A schema of the document, for the reference page.
pub struct SchemaView {
    pub name: String,
    pub description_html: String,
    pub fields: Vec<FieldView>,
    /// For a closed set of strings: its values.
    pub values: Vec<String>,
}

/// A schema as a short type, with links to named schemas.
fn type_html(schema: &Value) -> String {
    if let Some(reference) = schema.get("$ref").and_then(Value::as_str) {
        let name = reference.rsplit('/').next().unwrap_or(reference);
        return format!("<a href=\"#schema-{name}\">{name}</a>");
    }
    if let Some(options) = schema.get("anyOf").or_else(|| schema.get("oneOf")).and_then(Value::as_array) {
        return options.iter().map(type_html).collect::<Vec<_>>().join(" | ");
    }
    if let Some(value) = schema.get("const") {
        return format!("<code>{}</code>", inline_code(&value.to_string()));
    }
    let kinds: Vec<&str> = match schema.get("type") {
        Some(Value::String(t)) => vec![t.as_str()],
        Some(Value::Array(ts)) => ts.iter().filter_map(Value::as_str).collect(),
        _ => vec![],
    };
    let mut parts = Vec::new();
    for kind in &kinds {
        parts.push(match *kind {
            "array" => match (schema.get("items"), schema.get("prefixItems")) {
                (_, Some(Value::Array(pair))) => format!("[{}]", pair.iter().map(type_html).collect::<Vec<_>>().join(", ")),
                (Some(items), _) => format!("array of {}", type_html(items)),
                _ => "array".into(),
            },
            "object" => match (schema.get("properties"), schema.get("additionalProperties")) {
                (Some(Value::Object(keys)), _) if schema.get("additionalProperties") == Some(&Value::Bool(false)) => {
                    let value = keys.values().next().map(type_html).unwrap_or_default();
                    format!("map of {} → {value}", keys.keys().map(|k| format!("<code>{k}</code>")).collect::<Vec<_>>().join(", "))
                }
                (_, Some(values)) if values.is_object() => format!("map of string → {}", type_html(values)),
                _ => "object".into(),
            },
            other => other.to_string(),
        });
    }
    if parts.is_empty() { "any".into() } else { parts.join(" | ") }
}

/// The schemas of `document`, by name.
fn schema_views(document: &Value) -> Vec<SchemaView> {
    let schemas = document["components"]["schemas"].as_object().cloned().unwrap_or_default();
    schemas
        .into_iter()
        .map(|(name, schema)| {
            let required: Vec<&str> = schema["required"].as_array().into_iter().flatten().filter_map(Value::as_str).collect();
            let fields = schema["properties"]
                .as_object()
                .into_iter()
                .flatten()
                .map(|(field, property)| FieldView {
                    name: field.clone(),
                    type_html: type_html(property),
                    required: required.contains(&field.as_str()),
                    description_html: inline_code(property["description"].as_str().unwrap_or("")),
                })
                .collect();
            let values = schema["oneOf"]
                .as_array()
                .into_iter()
                .flatten()
                .chain(schema["enum"].as_array().into_iter().flatten())
                .filter_map(|v| v.get("const").and_then(Value::as_str).or(v.as_str()).map(str::to_string));
            SchemaView { description_html: inline_code(schema["description"].as_str().unwrap_or("")), fields, values: values.collect(), name }
        })
        .collect()
}

/// `text` escaped for HTML, with backtick spans as `<code>`.
fn inline_code(text: &str) -> String {
    let escaped = text.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;").replace('"', "&quot;");
    let mut out = String::new();
    for (i, part) in escaped.split('`').enumerate() {
        if i % 2 == 1 {
            out.push_str("<code>");
            out.push_str(part);
            out.push_str("</code>");
        } else {
            out.push_str(part);
        }
    }
    out
}

#[derive(Template, WebTemplate)]
#[template(path = "api_docs.html")]
pub struct DocsPage {
    pub title: &'static str,
    pub version: &'static str,
    pub description: &'static str,
    pub operations: Vec<OperationView>,
    pub problems: Vec<(&'static str, String)>,
    pub schemas: Vec<SchemaView>,
}

/// `GET /api/docs`: the API reference, rendered on the server (no external assets) from
/// the same document `/api/v1/openapi.json` serves.
pub async fn docs_page(Extension(Served(operations)): Extension<Served>) -> DocsPage {
    let document = document_value(&operations);
    let body_of = |o: &Operation, part: &str| -> String {
        let operation = &document["paths"][o.path()][o.verb.as_str()];
        let content = match part {
            "takes" => &operation["requestBody"]["content"],
            _ => &operation["responses"][o.success.to_string()]["content"],
        };
        match content.as_object() {
            None => "–".into(),
            Some(media) => media
                .iter()
                .map(|(kind, body)| match kind.as_str() {
                    "application/json" => type_html(&body["schema"]),
                    other => format!("<code>{other}</code>"),
                })
                .collect::<Vec<_>>()
                .join(", "),
        }
    };
    DocsPage {
        title: "osmab API",
        version: env!("CARGO_PKG_VERSION"),
        description: "Download the frozen release, upload maps and scene graphs, follow their evaluation, read the leaderboard.",
        operations: operations
            .iter()
            .map(|o| OperationView {
                method: o.verb.as_str().to_uppercase(),
                path_html: inline_code(&o.path()).replace('/', "/<wbr>"),
                auth: o.auth.label(),
                summary_html: inline_code(o.summary),
                takes_html: body_of(o, "takes"),
                answers_html: body_of(o, "answers"),
            })
            .collect(),
        problems: ProblemCode::ALL.iter().map(|code| (code.as_str(), inline_code(code.meaning()))).collect(),
        schemas: schema_views(&document),
    }
}
