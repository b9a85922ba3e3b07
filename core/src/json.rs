//! JSON scenes: load with errors that name the JSON path, save with
//! round-trip f64. Unknown keys are errors: a silently ignored field would
//! silently change the physics.

use crate::{Scene, SceneError};

impl Scene {
    /// Parses a scene document and validates it.
    pub fn from_json_str(text: &str) -> Result<Scene, SceneError> {
        let scene = Scene::parse_json(text)?;
        scene.validate()?;
        Ok(scene)
    }

    /// Parses a scene document without validating it.
    pub fn parse_json(text: &str) -> Result<Scene, SceneError> {
        let mut de = serde_json::Deserializer::from_str(text);
        let scene: Scene =
            serde_path_to_error::deserialize(&mut de).map_err(|e| SceneError::Json {
                path: json_path(e.path()),
                message: e.inner().to_string(),
            })?;
        de.end().map_err(|e| SceneError::Json {
            path: "(document)".into(),
            message: e.to_string(),
        })?;
        Ok(scene)
    }

    /// Reads, parses and validates a scene file.
    pub fn from_json_file(path: &std::path::Path) -> Result<Scene, SceneError> {
        let text = std::fs::read_to_string(path).map_err(|e| SceneError::Io {
            file: path.display().to_string(),
            message: e.to_string(),
        })?;
        Scene::from_json_str(&text)
    }

    /// The scene as JSON, one particle / family / obstacle per line (f64
    /// values round-trip exactly).
    pub fn to_json_string(&self) -> String {
        use serde_json::{Value, to_string};
        // Serializing plain data with string keys cannot fail.
        let Ok(Value::Object(map)) = serde_json::to_value(self) else {
            return String::new();
        };
        let mut out = String::from("{\n");
        let count = map.len();
        for (n, (key, value)) in map.iter().enumerate() {
            out.push_str(&format!("  {}: ", to_string(key).unwrap_or_default()));
            match value {
                Value::Array(items) if items.iter().any(Value::is_object) => {
                    out.push_str("[\n");
                    for (m, item) in items.iter().enumerate() {
                        out.push_str("    ");
                        out.push_str(&to_string(item).unwrap_or_default());
                        out.push_str(if m + 1 < items.len() { ",\n" } else { "\n" });
                    }
                    out.push_str("  ]");
                }
                _ => out.push_str(&to_string(value).unwrap_or_default()),
            }
            out.push_str(if n + 1 < count { ",\n" } else { "\n" });
        }
        out.push('}');
        out
    }
}

/// `particles[3].mass` rather than serde_path_to_error's `particles.3.mass`.
fn json_path(path: &serde_path_to_error::Path) -> String {
    use serde_path_to_error::Segment;
    let mut out = String::new();
    for segment in path.iter() {
        match segment {
            Segment::Seq { index } => out.push_str(&format!("[{index}]")),
            Segment::Map { key } | Segment::Enum { variant: key } => {
                if !out.is_empty() {
                    out.push('.');
                }
                out.push_str(key);
            }
            Segment::Unknown => out.push_str(".?"),
        }
    }
    if out.is_empty() {
        "(document)".into()
    } else {
        out
    }
}
