//! Scene settings overridden from the command line (`run --set KEY=VALUE`, `serve --set …`), so
//! that stiffness, cap and mass sweeps need no edited files.
//!
//! An override edits the scene's TOML text before it is built (formatting, comments and every other
//! value are kept, so the builder's located errors still point at the right lines), and then goes
//! through exactly the checks a value written in the file would:
//!
//! | key | sets |
//! |---|---|
//! | `FIELD` | `[scene] FIELD` (e.g. `contact_compliance=1e-10`, `max_pivot_steps=35`, `variant="auto"`) |
//! | `scene.FIELD` | the same |
//! | `TABLE.NAME.FIELD` | `FIELD` of the `[[TABLE]]` entry whose `name = "NAME"` (`body.hook.mass=70`, `joint.slew.compliance=1e-9`, `actuator.winch.max_force=5e4`) |
//!
//! `VALUE` is a TOML value (`1e-10`, `35`, `true`, `"auto"`, `[0, 0, -9.81]`); a bare word that is
//! not one (`auto`) is taken as a string. A key naming no table or entry is an error; a field the
//! table does not know is refused by the scene format itself.

use std::fmt;
use std::str::FromStr;

use thiserror::Error;
use toml_edit::{DocumentMut, Item, Value};

/// One `KEY=VALUE` override.
#[derive(Debug, Clone, PartialEq)]
pub struct SceneOverride {
    /// Path of the setting (see the module docs).
    pub key: String,
    /// The value as written.
    pub value: String,
}

/// Why an override could not be applied.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
pub enum OverrideError {
    /// Not of the form `KEY=VALUE`.
    #[error("`{0}`: expected KEY=VALUE (e.g. contact_compliance=1e-10, body.hook.mass=70)")]
    Syntax(String),
    /// The key has an empty part or too many parts.
    #[error("`{0}`: expected FIELD, scene.FIELD or TABLE.NAME.FIELD")]
    Key(String),
    /// No `[[TABLE]]` entry of that name.
    #[error("`{key}`: the scene has no [[{table}]] named `{name}`")]
    NoEntry {
        /// The override's key.
        key: String,
        /// The table.
        table: String,
        /// The entry name asked for.
        name: String,
    },
    /// The scene text itself is not TOML (reported with its location by the scene loader instead).
    #[error("the scene is not valid TOML: {0}")]
    Scene(String),
}

impl FromStr for SceneOverride {
    type Err = OverrideError;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let (key, value) = s.split_once('=').ok_or_else(|| OverrideError::Syntax(s.to_string()))?;
        let (key, value) = (key.trim(), value.trim());
        if key.is_empty() || value.is_empty() {
            return Err(OverrideError::Syntax(s.to_string()));
        }
        let parts = key.split('.').count();
        if key.split('.').any(str::is_empty) || parts == 2 && !key.starts_with("scene.") || parts > 3 {
            return Err(OverrideError::Key(key.to_string()));
        }
        Ok(SceneOverride { key: key.to_string(), value: value.to_string() })
    }
}

impl fmt::Display for SceneOverride {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}={}", self.key, self.value)
    }
}

impl SceneOverride {
    /// The value as a TOML value (a bare word that does not parse becomes a string).
    fn toml_value(&self) -> Value {
        self.value.parse::<Value>().unwrap_or_else(|_| Value::from(self.value.as_str()))
    }
}

/// The scene text with the overrides applied in order (the text unchanged when there are none).
pub fn apply(text: &str, overrides: &[SceneOverride]) -> Result<String, OverrideError> {
    if overrides.is_empty() {
        return Ok(text.to_string());
    }
    let mut doc: DocumentMut =
        text.parse().map_err(|e: toml_edit::TomlError| OverrideError::Scene(e.to_string()))?;
    for o in overrides {
        let parts: Vec<&str> = o.key.split('.').collect();
        let value = o.toml_value();
        match parts.as_slice() {
            [field] | ["scene", field] => {
                let scene = doc
                    .entry("scene")
                    .or_insert_with(toml_edit::table)
                    .as_table_like_mut()
                    .ok_or_else(|| OverrideError::Key(o.key.clone()))?;
                scene.insert(field, Item::Value(value));
            }
            [table, name, field] => {
                let no_entry = || OverrideError::NoEntry {
                    key: o.key.clone(),
                    table: table.to_string(),
                    name: name.to_string(),
                };
                let entries =
                    doc.get_mut(table).and_then(Item::as_array_of_tables_mut).ok_or_else(no_entry)?;
                let entry = entries
                    .iter_mut()
                    .find(|t| t.get("name").and_then(Item::as_str) == Some(name))
                    .ok_or_else(no_entry)?;
                entry.insert(field, Item::Value(value));
            }
            _ => return Err(OverrideError::Key(o.key.clone())),
        }
    }
    Ok(doc.to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    const TEXT: &str = r#"# a comment
[scene]
name = "t"
max_pivot_steps = 300

[[body]]
name = "hook"
mass = 70.0

[[body]]
name = "pipe"
mass = 2000.0
"#;

    fn set(s: &[&str]) -> Result<String, OverrideError> {
        let o: Vec<SceneOverride> = s.iter().map(|s| s.parse().unwrap()).collect();
        apply(TEXT, &o)
    }

    #[test]
    fn scene_fields_bare_and_qualified() {
        let t = set(&["max_pivot_steps=35", "scene.contact_compliance=1e-10", "variant=auto"]).unwrap();
        let v: toml::Table = toml::from_str(&t).unwrap();
        assert_eq!(v["scene"]["max_pivot_steps"].as_integer(), Some(35));
        assert_eq!(v["scene"]["contact_compliance"].as_float(), Some(1e-10));
        assert_eq!(v["scene"]["variant"].as_str(), Some("auto"));
        assert!(t.starts_with("# a comment"), "comments and layout are kept");
    }

    #[test]
    fn named_entries() {
        let t = set(&["body.pipe.mass=2500"]).unwrap();
        let v: toml::Table = toml::from_str(&t).unwrap();
        let bodies = v["body"].as_array().unwrap();
        assert_eq!(bodies[0]["mass"].as_float(), Some(70.0));
        assert_eq!(bodies[1]["mass"].as_integer(), Some(2500));
    }

    #[test]
    fn bad_overrides_are_typed_errors() {
        assert!(matches!("nokey".parse::<SceneOverride>(), Err(OverrideError::Syntax(_))));
        assert!(matches!("=3".parse::<SceneOverride>(), Err(OverrideError::Syntax(_))));
        assert!(matches!("a..b=3".parse::<SceneOverride>(), Err(OverrideError::Key(_))));
        assert!(matches!("body.mass=3".parse::<SceneOverride>(), Err(OverrideError::Key(_))));
        assert!(matches!("a.b.c.d=3".parse::<SceneOverride>(), Err(OverrideError::Key(_))));
        assert!(matches!(set(&["body.crate.mass=1"]), Err(OverrideError::NoEntry { .. })));
        assert!(matches!(set(&["joint.x.compliance=1"]), Err(OverrideError::NoEntry { .. })));
    }
}
