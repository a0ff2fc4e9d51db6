//! The OpenAPI 3.1 document (`/api/v1/openapi.json`), generated from the operations the
//! router serves (each area declares its own in `routes()`, see [`super::operation`]);
//! `api_docs.rs` renders the same document as a page (`/api/docs`). Every request body,
//! query and JSON response is described by the schema of the Rust type the handler takes
//! or returns (derived with schemars, JSON Schema 2020-12 — OpenAPI 3.1's dialect), and
//! every problem code by [`ProblemCode`], so the document follows the code.

use std::sync::Arc;

use axum::Extension;
use axum::http::header;
use axum::response::{IntoResponse, Response};
use schemars::Schema;
use schemars::generate::{SchemaGenerator, SchemaSettings};
use serde_json::{Map, Value, json};

use super::operation::{ApiRoutes, Auth, Body, Input, Operation, Verb};
use crate::problem::ProblemCode;

/// The operations the router serves, as the document and the reference page read them.
#[derive(Clone)]
pub struct Served(pub Arc<Vec<Operation>>);

fn path_parameters(path: &str) -> Vec<Value> {
    path.split('/')
        .filter_map(|part| part.strip_prefix('{').and_then(|p| p.strip_suffix('}')))
        .map(|name| json!({"name": name, "in": "path", "required": true, "schema": {"type": "string"}}))
        .collect()
}

/// The query parameters of a type's schema: one per property, required where the type requires it.
fn query_parameters(schema: &Schema) -> Vec<Value> {
    let object = schema.as_object().cloned().unwrap_or_default();
    let required: Vec<Value> = object.get("required").and_then(Value::as_array).cloned().unwrap_or_default();
    let properties = object.get("properties").and_then(Value::as_object).cloned().unwrap_or_default();
    properties
        .into_iter()
        .map(|(name, mut property)| {
            let description = property.as_object_mut().and_then(|p| p.remove("description"));
            let mut parameter = json!({"name": name, "in": "query", "required": required.contains(&json!(name)), "schema": property});
            if let Some(description) = description {
                parameter["description"] = description;
            }
            parameter
        })
        .collect()
}

/// Describes answers as the server writes them, request bodies as it reads them, and
/// collects the schemas both name.
struct Schemas {
    answers: SchemaGenerator,
    requests: SchemaGenerator,
}

impl Schemas {
    fn new() -> Self {
        let settings = SchemaSettings::draft2020_12().with(|s| s.definitions_path = "/components/schemas".into());
        Schemas { answers: settings.clone().for_serialize().into_generator(), requests: settings.for_deserialize().into_generator() }
    }

    /// Every named schema, and `Problem` with every [`ProblemCode`].
    fn into_components(mut self) -> Map<String, Value> {
        let mut schemas = self.answers.take_definitions(true);
        for (name, schema) in self.requests.take_definitions(true) {
            let clash = schemas.get(&name).is_some_and(|known| *known != schema);
            assert!(!clash, "{name} is both a request and an answer with different schemas");
            schemas.insert(name, schema);
        }
        schemas.insert("Problem".into(), problem_schema());
        schemas
    }
}

/// The body of every error answer.
fn problem_schema() -> Value {
    json!({
        "type": "object",
        "required": ["type", "title", "status", "detail", "code"],
        "properties": {
            "type": {"type": "string"}, "title": {"type": "string"}, "status": {"type": "integer"}, "detail": {"type": "string"},
            "code": {"type": "string", "enum": ProblemCode::ALL.iter().map(|code| code.as_str()).collect::<Vec<_>>()},
            "errors": {"type": "array", "items": {"type": "object", "properties": {"file": {"type": "string"}, "field": {"type": "string"}, "message": {"type": "string"}}}}
        }
    })
}

/// The success answer of `o`.
fn success_response(o: &Operation, schemas: &mut Schemas) -> Value {
    match o.output {
        Body::Json(schema) => json!({"description": "Success", "content": {"application/json": {"schema": schema(&mut schemas.answers)}}}),
        Body::FreeJson => json!({"description": "Success", "content": {"application/json": {"schema": {"type": "object"}}}}),
        Body::Other(media) => json!({"description": "Success", "content": {media: {"schema": {"type": "string"}}}}),
        Body::Empty => json!({"description": "Success, no content"}),
    }
}

/// The request body of `o`, if it takes one.
fn request_body(o: &Operation, schemas: &mut Schemas) -> Option<Value> {
    let binary = json!({"type": "string", "format": "binary"});
    let content = match o.input {
        Input::None => return None,
        Input::Json(schema) => json!({"application/json": {"schema": schema(&mut schemas.requests)}}),
        Input::Chunk => json!({"application/offset+octet-stream": {"schema": binary}}),
        Input::Archive => json!({"application/x-tar": {"schema": binary}, "application/gzip": {"schema": binary}, "application/zip": {"schema": binary}}),
    };
    Some(json!({"required": true, "content": content}))
}

/// The OpenAPI operation object of `o`.
fn operation_object(o: &Operation, schemas: &mut Schemas) -> Value {
    let mut operation = json!({
        "summary": o.summary,
        "operationId": format!("{}_{}", o.verb.as_str(), o.path().trim_start_matches('/').replace(['/', '{', '}', '.'], "_")),
        "responses": {
            o.success.to_string(): success_response(o, schemas),
            "default": {"description": "An error", "content": {"application/problem+json": {"schema": {"$ref": "#/components/schemas/Problem"}}}}
        }
    });
    let mut parameters = path_parameters(&o.path());
    if let Some(query) = o.query {
        parameters.extend(query_parameters(&query()));
    }
    if !parameters.is_empty() {
        operation["parameters"] = Value::Array(parameters);
    }
    match o.auth {
        Auth::Team | Auth::Admin | Auth::TeamOrAdmin => operation["security"] = json!([{"bearer": []}]),
        Auth::Optional => operation["security"] = json!([{}, {"bearer": []}]),
        Auth::Public => {}
    }
    operation["x-osmab-caller"] = json!(o.auth.name());
    if let Some(body) = request_body(o, schemas) {
        operation["requestBody"] = body;
    }
    operation
}

/// The OpenAPI 3.1 document of `operations`.
pub fn document_value(operations: &[Operation]) -> Value {
    let mut schemas = Schemas::new();
    let mut paths = Map::new();
    for o in operations {
        let entry = paths.entry(o.path()).or_insert_with(|| json!({}));
        entry[o.verb.as_str()] = operation_object(o, &mut schemas);
    }
    json!({
        "openapi": "3.1.0",
        "jsonSchemaDialect": "https://json-schema.org/draft/2020-12/schema",
        "info": {
            "title": "osmab: the OSMa-Bench++ evaluation service",
            "version": env!("CARGO_PKG_VERSION"),
            "description": "Download the frozen release, upload maps and scene graphs, follow their evaluation, read the leaderboard."
        },
        "paths": paths,
        "components": {
            "securitySchemes": {"bearer": {"type": "http", "scheme": "bearer", "description": "An API token (`osmab_` + 32 characters)."}},
            "schemas": schemas.into_components()
        }
    })
}

/// `GET /api/v1/openapi.json`.
pub async fn document(Extension(Served(operations)): Extension<Served>) -> Response {
    ([(header::CONTENT_TYPE, "application/json")], serde_json::to_string_pretty(&document_value(&operations)).expect("json")).into_response()
}

/// The document itself.
pub fn routes() -> ApiRoutes {
    ApiRoutes::new().operation(Operation::new(Verb::Get, "/api/v1/openapi.json", Auth::Public, "This document.", 200).returns_free_json(), document)
}
