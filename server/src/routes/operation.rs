//! An operation of the API is declared once: its method, path, handler and documentation
//! together. Each area's `routes()` lists its operations into [`ApiRoutes`]; the router
//! serves that list and the OpenAPI document and `/api/docs` describe the same list, so
//! adding a route is one place and a documented route cannot be missing from the router.

use axum::Router;
use axum::handler::Handler;
use axum::routing::{MethodFilter, on};
use schemars::generate::{SchemaGenerator, SchemaSettings};
use schemars::{JsonSchema, Schema};

use crate::state::AppState;

/// Who may call an operation.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Auth {
    Public,
    Team,
    Admin,
    /// A team's token (for its own) or an admin's (for any team's).
    TeamOrAdmin,
    /// Public, with more visible to the owning team or an admin.
    Optional,
}

impl Auth {
    /// How the reference page names it.
    pub fn label(self) -> &'static str {
        match self {
            Auth::Public => "none",
            Auth::Team => "team token",
            Auth::Admin => "admin token",
            Auth::TeamOrAdmin => "team or admin token",
            Auth::Optional => "optional",
        }
    }

    /// Its name in the OpenAPI document (`x-osmab-caller`), which a test holds every
    /// handler to: the extractor enforces who may call, this only says it.
    pub fn name(self) -> &'static str {
        match self {
            Auth::Public => "public",
            Auth::Team => "team",
            Auth::Admin => "admin",
            Auth::TeamOrAdmin => "team_or_admin",
            Auth::Optional => "optional",
        }
    }
}

/// The HTTP method of an operation.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Verb {
    Get,
    Head,
    Options,
    Post,
    Put,
    Patch,
    Delete,
}

impl Verb {
    /// Lower case, as OpenAPI keys operations.
    pub fn as_str(self) -> &'static str {
        match self {
            Verb::Get => "get",
            Verb::Head => "head",
            Verb::Options => "options",
            Verb::Post => "post",
            Verb::Put => "put",
            Verb::Patch => "patch",
            Verb::Delete => "delete",
        }
    }

    fn filter(self) -> MethodFilter {
        match self {
            Verb::Get => MethodFilter::GET,
            Verb::Head => MethodFilter::HEAD,
            Verb::Options => MethodFilter::OPTIONS,
            Verb::Post => MethodFilter::POST,
            Verb::Put => MethodFilter::PUT,
            Verb::Patch => MethodFilter::PATCH,
            Verb::Delete => MethodFilter::DELETE,
        }
    }
}

/// What a successful response carries.
#[derive(Debug, Clone, Copy)]
pub enum Body {
    /// JSON described by a type's schema.
    Json(fn(&mut SchemaGenerator) -> Schema),
    /// JSON whose shape a release defines (its manifest).
    FreeJson,
    /// Another media type (`text/csv`, a file, Prometheus text).
    Other(&'static str),
    /// Nothing (204).
    Empty,
}

/// What a request carries besides its path.
#[derive(Debug, Clone, Copy)]
pub enum Input {
    /// Nothing.
    None,
    /// A JSON body of a type.
    Json(fn(&mut SchemaGenerator) -> Schema),
    /// A submission archive.
    Archive,
    /// A chunk of a resumable upload (`application/offset+octet-stream`).
    Chunk,
}

/// One documented operation.
#[derive(Debug, Clone, Copy)]
pub struct Operation {
    pub verb: Verb,
    /// The route as the router matches it (`{*path}` for the rest of a path).
    pub route: &'static str,
    pub auth: Auth,
    pub summary: &'static str,
    pub input: Input,
    /// Query parameters: the properties of a type's schema.
    pub query: Option<fn() -> Schema>,
    /// Success status.
    pub success: u16,
    pub output: Body,
}

/// The schema of `T`, as a reference into the document's components.
fn schema_of<T: JsonSchema>(generator: &mut SchemaGenerator) -> Schema {
    generator.subschema_for::<T>()
}

/// The whole schema of `T` (for query parameters).
fn root_of<T: JsonSchema>() -> Schema {
    SchemaSettings::draft2020_12().for_deserialize().into_generator().into_root_schema_for::<T>()
}

impl Operation {
    /// `verb route`, open to `auth`, answering `success` with no body until told otherwise.
    pub const fn new(verb: Verb, route: &'static str, auth: Auth, summary: &'static str, success: u16) -> Self {
        Operation { verb, route, auth, summary, input: Input::None, query: None, success, output: Body::Empty }
    }
    /// Answers JSON of type `T`.
    pub const fn returns<T: JsonSchema>(self) -> Self {
        Operation { output: Body::Json(schema_of::<T>), ..self }
    }
    /// Answers JSON whose shape the data defines.
    pub const fn returns_free_json(self) -> Self {
        Operation { output: Body::FreeJson, ..self }
    }
    /// Answers another media type.
    pub const fn returns_other(self, media: &'static str) -> Self {
        Operation { output: Body::Other(media), ..self }
    }
    /// Takes a JSON body of type `T`.
    pub const fn takes<T: JsonSchema>(self) -> Self {
        Operation { input: Input::Json(schema_of::<T>), ..self }
    }
    /// Takes another kind of body.
    pub const fn takes_body(self, input: Input) -> Self {
        Operation { input, ..self }
    }
    /// Takes the query parameters of `T`.
    pub const fn query<T: JsonSchema>(self) -> Self {
        Operation { query: Some(root_of::<T>), ..self }
    }

    /// The path as OpenAPI writes it (`{path}` for the router's `{*path}`).
    pub fn path(&self) -> String {
        self.route.replace("{*", "{")
    }
}

/// Routes of the API with their documentation: what an area's `routes()` returns.
pub struct ApiRoutes {
    router: Router<AppState>,
    operations: Vec<Operation>,
}

impl Default for ApiRoutes {
    fn default() -> Self {
        ApiRoutes { router: Router::new(), operations: Vec::new() }
    }
}

impl ApiRoutes {
    pub fn new() -> Self {
        Self::default()
    }

    /// Serve `operation` with `handler` (several methods of one path merge).
    pub fn operation<H, T>(mut self, operation: Operation, handler: H) -> Self
    where
        H: Handler<T, AppState>,
        T: 'static,
    {
        self.router = self.router.route(operation.route, on(operation.verb.filter(), handler));
        self.operations.push(operation);
        self
    }

    /// Another area's routes after these.
    pub fn merge(mut self, other: ApiRoutes) -> Self {
        self.router = self.router.merge(other.router);
        self.operations.extend(other.operations);
        self
    }

    /// Wrap these routes (and only these) in middleware: `|router| router.layer(…)`.
    pub fn wrap(mut self, wrap: impl FnOnce(Router<AppState>) -> Router<AppState>) -> Self {
        self.router = wrap(self.router);
        self
    }

    /// The router and the operations it serves, in the order they were declared.
    pub fn into_parts(self) -> (Router<AppState>, Vec<Operation>) {
        (self.router, self.operations)
    }
}
