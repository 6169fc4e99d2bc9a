use std::path::Path;

use crate::model::SceneFile;
use crate::SceneError;

/// Reads and parses a scene file, choosing the syntax by extension (`.ron`, `.json`).
/// Syntax errors, unknown fields and wrong types name the file, line and column.
pub fn parse_file(path: &Path) -> Result<SceneFile, SceneError> {
    let text = volga_core::input::read_input_text(path).map_err(|source| SceneError::Read {
        path: path.to_owned(),
        source,
    })?;
    match path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
        .as_deref()
    {
        Some("ron") => parse_ron(path, &text),
        Some("json") => parse_json(path, &text),
        _ => Err(SceneError::Extension { path: path.to_owned() }),
    }
}

/// Parses a scene from RON text; `path` only names it in errors. Optional fields may be
/// written without `Some(…)`. Syntax errors, unknown fields and wrong types are
/// [`SceneError::Parse`] with line and column.
pub fn parse_ron(path: &Path, text: &str) -> Result<SceneFile, SceneError> {
    // `implicit_some` lets users write `name: "ball"` for optional fields.
    ron::Options::default()
        .with_default_extension(ron::extensions::Extensions::IMPLICIT_SOME)
        .from_str(text)
        .map_err(|e| SceneError::Parse {
            path: path.to_owned(),
            line: e.position.line,
            column: e.position.col,
            message: match e.code {
                ron::Error::ExceededRecursionLimit => NESTING.to_string(),
                code => code.to_string(),
            },
        })
}

/// What a scene nested deeper than its parser allows is told.
const NESTING: &str = "the scene nests deeper than the 128 levels its parser allows (each \
    operator node such as Cvg, Union, Sculpt or Hypertexture takes several: 19 nested \
    operators fit in RON, 40 in JSON): flatten the tree (a Union takes any number of \
    children) or build deeper trees from code";

/// Parses a scene from JSON text; `path` only names it in errors. Syntax errors, unknown
/// fields and wrong types are [`SceneError::Parse`] with line and column.
pub fn parse_json(path: &Path, text: &str) -> Result<SceneFile, SceneError> {
    serde_json::from_str(text).map_err(|e| SceneError::Parse {
        path: path.to_owned(),
        line: e.line(),
        column: e.column(),
        message: match strip_json_position(&e.to_string()) {
            m if m == "recursion limit exceeded" => NESTING.to_string(),
            m => m,
        },
    })
}

/// serde_json appends " at line L column C" to its messages; we print our own.
fn strip_json_position(msg: &str) -> String {
    match msg.rfind(" at line ") {
        Some(i) => msg[..i].to_string(),
        None => msg.to_string(),
    }
}
