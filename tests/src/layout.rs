//! Foxglove layouts checked against what a viewer path publishes: the topics a layout's panels
//! name and its Plot panels' message paths, resolved against real messages (as JSON values).
//!
//! A message path is a topic followed by accessors, the subset of Foxglove's message-path syntax
//! the shipped layouts use: `.field`, `[i]` (an array element), `[:]` (every element) and
//! `{field==value}` (keep the elements whose `field` equals `value`, a quoted string, a number or
//! `true`/`false`), e.g. `/pivotsim/diagnostics.status[:]{name=="pivotsim: solver"}.values[:]{key=="solve_us"}.value`.
//! The topic is everything before the first `.`, `[` or `{`.

use serde_json::Value;

/// An accessor of a message path.
#[derive(Debug, Clone, PartialEq)]
pub enum Step {
    /// `.name`.
    Field(String),
    /// `[i]`.
    Index(usize),
    /// `[:]`.
    All,
    /// `{field==value}`.
    Filter(String, Value),
}

/// A message path: its topic and accessors.
#[derive(Debug, Clone, PartialEq)]
pub struct MessagePath {
    /// The topic (`/pivotsim/stats`).
    pub topic: String,
    /// The accessors after it.
    pub steps: Vec<Step>,
}

/// A message path that does not parse, with the reason.
#[derive(Debug, Clone, PartialEq)]
pub struct PathError {
    /// The path.
    pub path: String,
    /// What is wrong.
    pub why: String,
}

impl std::fmt::Display for PathError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "message path {:?}: {}", self.path, self.why)
    }
}

impl std::error::Error for PathError {}

fn is_ident(c: char) -> bool {
    c.is_ascii_alphanumeric() || c == '_'
}

/// Parses a message path.
pub fn parse(path: &str) -> Result<MessagePath, PathError> {
    let err = |why: &str| PathError { path: path.to_string(), why: why.to_string() };
    let end = path.find(['.', '[', '{']).unwrap_or(path.len());
    let topic = &path[..end];
    if !topic.starts_with('/') || topic.len() < 2 {
        return Err(err("no topic (a name starting with /) before the first accessor"));
    }
    let mut steps = Vec::new();
    let mut rest = &path[end..];
    while let Some(c) = rest.chars().next() {
        match c {
            '.' => {
                let n = rest[1..].find(|c: char| !is_ident(c)).map_or(rest.len(), |i| i + 1);
                if n == 1 {
                    return Err(err("an empty field name"));
                }
                steps.push(Step::Field(rest[1..n].to_string()));
                rest = &rest[n..];
            }
            '[' => {
                let close = rest.find(']').ok_or_else(|| err("an unclosed ["))?;
                let inner = &rest[1..close];
                steps.push(if inner == ":" {
                    Step::All
                } else {
                    Step::Index(inner.parse().map_err(|_| err("an index that is not a number or :"))?)
                });
                rest = &rest[close + 1..];
            }
            '{' => {
                let close = rest.find('}').ok_or_else(|| err("an unclosed {"))?;
                let inner = &rest[1..close];
                let (field, value) = inner.split_once("==").ok_or_else(|| err("a filter without =="))?;
                if field.is_empty() || !field.chars().all(is_ident) {
                    return Err(err("a filter on a field that is no name"));
                }
                let value = match value.as_bytes() {
                    [b'"', .., b'"'] | [b'\'', .., b'\''] if value.len() >= 2 => {
                        Value::String(value[1..value.len() - 1].to_string())
                    }
                    _ => serde_json::from_str(value).map_err(|_| err("a filter value that is no literal"))?,
                };
                steps.push(Step::Filter(field.to_string(), value));
                rest = &rest[close + 1..];
            }
            _ => return Err(err("an accessor that is not .field, [i], [:] or {field==value}")),
        }
    }
    Ok(MessagePath { topic: topic.to_string(), steps })
}

/// Whether `v` equals a filter's literal (a number compared as a number).
fn matches(v: &Value, want: &Value) -> bool {
    match (v, want) {
        (Value::Number(a), Value::Number(b)) => a.as_f64() == b.as_f64(),
        _ => v == want,
    }
}

/// The values `steps` reach in `message` (none when a field or an element is missing).
pub fn resolve<'a>(message: &'a Value, steps: &[Step]) -> Vec<&'a Value> {
    let mut at = vec![message];
    for s in steps {
        at = match s {
            Step::Field(name) => at.into_iter().filter_map(|v| v.get(name)).collect(),
            Step::Index(i) => at.into_iter().filter_map(|v| v.get(*i)).collect(),
            Step::All => at.into_iter().filter_map(Value::as_array).flatten().collect(),
            Step::Filter(field, want) => {
                // Foxglove filters an array's elements (after `[:]`) or a single message.
                at.into_iter().filter(|v| v.get(field).is_some_and(|x| matches(x, want))).collect()
            }
        };
    }
    at
}

/// A value a Plot panel can chart: a number, a boolean or a string holding a number (Foxglove
/// plots numeric strings, such as `diagnostic_msgs/KeyValue` values).
pub fn plottable(v: &Value) -> bool {
    match v {
        Value::Number(_) | Value::Bool(_) => true,
        Value::String(s) => s.trim().parse::<f64>().is_ok(),
        _ => false,
    }
}

/// What a layout refers to.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct LayoutRefs {
    /// Topics named by its 3D panels (`topics` keys), in panel order.
    pub topics: Vec<String>,
    /// Its Plot panels' message paths, with their `timestampMethod`.
    pub plot_paths: Vec<(String, String)>,
    /// The frames its 3D panels follow or display (`followTf`, layers' `frameId`).
    pub frames: Vec<String>,
}

/// The topics, plot paths and frames of a Foxglove layout file (`configById`).
pub fn layout_refs(layout: &Value) -> LayoutRefs {
    let mut r = LayoutRefs::default();
    let Some(panels) = layout.get("configById").and_then(Value::as_object) else { return r };
    for (id, config) in panels {
        if let Some(t) = config.get("topics").and_then(Value::as_object) {
            r.topics.extend(t.keys().cloned());
        }
        if let Some(f) = config.get("followTf").and_then(Value::as_str) {
            r.frames.push(f.to_string());
        }
        if let Some(layers) = config.get("layers").and_then(Value::as_object) {
            r.frames.extend(layers.values().filter_map(|l| l.get("frameId")?.as_str().map(str::to_string)));
        }
        if id.starts_with("Plot!")
            && let Some(paths) = config.get("paths").and_then(Value::as_array)
        {
            for p in paths {
                let value = p.get("value").and_then(Value::as_str).unwrap_or_default().to_string();
                let method =
                    p.get("timestampMethod").and_then(Value::as_str).unwrap_or("receiveTime").to_string();
                r.plot_paths.push((value, method));
            }
        }
    }
    r
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn paths_parse_into_topic_and_accessors() {
        let p =
            parse(r#"/pivotsim/diagnostics.status[:]{name=="pivotsim: solver"}.values[2].value"#).unwrap();
        assert_eq!(p.topic, "/pivotsim/diagnostics");
        assert_eq!(
            p.steps,
            [
                Step::Field("status".into()),
                Step::All,
                Step::Filter("name".into(), json!("pivotsim: solver")),
                Step::Field("values".into()),
                Step::Index(2),
                Step::Field("value".into()),
            ]
        );
        assert_eq!(parse("/a/b.c{k==3}").unwrap().steps[1], Step::Filter("k".into(), json!(3)));
        assert_eq!(parse("/a/b.c{k=='x'}").unwrap().steps[1], Step::Filter("k".into(), json!("x")));
        for bad in ["stats.x", "/a.", "/a[", "/a[x]", "/a{k}", "/a{k==}", "/a{==1}", "/a.b c", ""] {
            assert!(parse(bad).is_err(), "{bad:?} parsed");
        }
    }

    #[test]
    fn resolution_follows_fields_elements_and_filters() {
        let m = json!({"status": [
            {"name": "a", "values": [{"key": "x", "value": "1.5"}, {"key": "y", "value": "n/a"}]},
            {"name": "b", "values": [{"key": "x", "value": "7"}]},
        ], "n": 3});
        let get =
            |p: &str| -> Vec<Value> { resolve(&m, &parse(p).unwrap().steps).into_iter().cloned().collect() };
        assert_eq!(get(r#"/t.status[:]{name=="a"}.values[:]{key=="x"}.value"#), [json!("1.5")]);
        assert_eq!(get(r#"/t.status[:].values[:]{key=="x"}.value"#), [json!("1.5"), json!("7")]);
        assert_eq!(get("/t.status[1].name"), [json!("b")]);
        assert!(get("/t.status[2].name").is_empty());
        assert!(get(r#"/t.status[:]{name=="c"}.values"#).is_empty());
        assert!(get("/t.nope").is_empty());
        assert_eq!(get("/t.n"), [json!(3)]);
        assert!(plottable(&json!("1.5")) && plottable(&json!(3)) && plottable(&json!(true)));
        assert!(!plottable(&json!("n/a")) && !plottable(&json!(null)) && !plottable(&json!({})));
    }

    #[test]
    fn a_layout_names_its_topics_paths_and_frames() {
        let l = json!({"configById": {
            "3D!a": {"followTf": "world", "topics": {"/m": {"visible": true}}, "layers": {"g": {"frameId": "world"}}},
            "Plot!b": {"paths": [{"value": "/s.x", "timestampMethod": "headerStamp"}, {"value": "/s.y"}]},
        }});
        let r = layout_refs(&l);
        assert_eq!(r.topics, ["/m"]);
        assert_eq!(r.frames, ["world", "world"]);
        assert_eq!(
            r.plot_paths,
            [("/s.x".into(), "headerStamp".into()), ("/s.y".into(), "receiveTime".into())]
        );
    }
}
