//! TOML scene text to `Scene` (stub until the loader lands).
use super::{Scene, SceneError};
use std::path::Path;

pub fn load_file(path: &Path) -> Result<Scene, SceneError> {
    let text = std::fs::read_to_string(path).map_err(|e| SceneError {
        file: path.to_path_buf(),
        line: 0,
        message: format!("cannot read: {e}"),
    })?;
    parse_text(&text, path)
}

pub fn parse_text(_text: &str, path: &Path) -> Result<Scene, SceneError> {
    Err(SceneError {
        file: path.to_path_buf(),
        line: 0,
        message: "scene loading is not implemented yet".into(),
    })
}
