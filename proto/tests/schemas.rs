//! The checked-in JSON Schemas in `proto/schemas/` match the types, and the types' sound
//! examples carry everything those schemas require.

mod support;

use serde_json::{Map, Value};
use support::{crate_path, examples, regenerate};

const HOW_TO_REGENERATE: &str = "REGENERATE=1 cargo test -p proto schemas";

#[test]
fn schemas_match_checked_in_files() {
    let dir = crate_path("schemas");
    let mut stale = Vec::new();
    let mut expected_files = Vec::new();
    for (name, schema) in proto::schema::all() {
        let file = format!("{name}.json");
        let path = dir.join(&file);
        expected_files.push(file);
        let want = proto::schema::to_pretty_json(&schema);
        if regenerate() {
            std::fs::create_dir_all(&dir).unwrap_or_else(|e| panic!("create {dir:?}: {e}"));
            std::fs::write(&path, &want).unwrap_or_else(|e| panic!("write {path:?}: {e}"));
            continue;
        }
        match std::fs::read_to_string(&path) {
            Ok(have) if have == want => {}
            Ok(_) => stale.push(format!("{} differs from the {name} type", path.display())),
            Err(e) => stale.push(format!("{} cannot be read: {e}", path.display())),
        }
    }
    // A schema whose type is gone must not linger for other tools to read.
    for entry in std::fs::read_dir(&dir).into_iter().flatten().flatten() {
        let file = entry.file_name().to_string_lossy().into_owned();
        if file.ends_with(".json") && !expected_files.contains(&file) {
            if regenerate() {
                let path = entry.path();
                std::fs::remove_file(&path).unwrap_or_else(|e| panic!("remove {path:?}: {e}"));
            } else {
                stale.push(format!("{} has no message type", entry.path().display()));
            }
        }
    }
    assert!(
        stale.is_empty(),
        "JSON Schemas are out of date:\n  {}\nRegenerate them with `{HOW_TO_REGENERATE}` and \
         check the diff in.",
        stale.join("\n  ")
    );
}

#[test]
fn every_schema_has_a_sound_example() {
    let schema_names: Vec<&str> = proto::schema::all().iter().map(|(n, _)| *n).collect();
    let example_names: Vec<&str> = examples::all_json().iter().map(|(n, _)| *n).collect();
    assert_eq!(schema_names, example_names);
}

#[test]
fn sound_examples_have_every_property_their_schema_requires() {
    let schemas = proto::schema::all();
    for ((name, schema), (_, example)) in schemas.iter().zip(examples::all_json()) {
        let root = schema.as_value();
        let mut problems = Vec::new();
        check(&example, root, root, name, &mut problems);
        assert!(
            problems.is_empty(),
            "{name} example vs schema:\n  {}",
            problems.join("\n  ")
        );
    }
}

/// A small structural check of `value` against `node` (a part of `root`): `$ref`, `anyOf`
/// / `oneOf`, `type`, `const`, `enum`, `required`, `properties`, `additionalProperties:
/// false`, `items` and `minItems`/`maxItems`. Enough to catch a schema and its type drifting
/// apart; not a general JSON-Schema validator.
fn check(value: &Value, node: &Value, root: &Value, at: &str, problems: &mut Vec<String>) {
    if let Some(reference) = node.get("$ref").and_then(Value::as_str) {
        let target = reference
            .strip_prefix('#')
            .and_then(|pointer| root.pointer(pointer));
        match target {
            Some(def) => check(value, def, root, at, problems),
            None => problems.push(format!("{at}: dangling $ref {reference}")),
        }
    }
    for key in ["anyOf", "oneOf"] {
        if let Some(options) = node.get(key).and_then(Value::as_array) {
            let fitting = options
                .iter()
                .filter(|option| {
                    let mut scratch = Vec::new();
                    check(value, option, root, at, &mut scratch);
                    scratch.is_empty()
                })
                .count();
            if fitting == 0 || (key == "oneOf" && fitting > 1) {
                problems.push(format!("{at}: {value} fits {fitting} of {key}"));
            }
        }
    }
    if let Some(ty) = node.get("type") {
        let types: Vec<&str> = match ty {
            Value::String(s) => vec![s.as_str()],
            Value::Array(a) => a.iter().filter_map(Value::as_str).collect(),
            _ => Vec::new(),
        };
        if !types.iter().any(|t| has_type(value, t)) {
            problems.push(format!("{at}: {value} is not of type {ty}"));
        }
    }
    if let Some(constant) = node.get("const")
        && constant != value
    {
        problems.push(format!("{at}: {value} is not {constant}"));
    }
    if let Some(allowed) = node.get("enum").and_then(Value::as_array)
        && !allowed.contains(value)
    {
        problems.push(format!("{at}: {value} is not one of {allowed:?}"));
    }
    if let Value::Object(object) = value {
        check_object(object, node, root, at, problems);
    }
    if let Value::Array(items) = value {
        let len = items.len() as u64;
        if node
            .get("minItems")
            .and_then(Value::as_u64)
            .is_some_and(|n| len < n)
        {
            problems.push(format!("{at}: too few items ({len})"));
        }
        if node
            .get("maxItems")
            .and_then(Value::as_u64)
            .is_some_and(|n| len > n)
        {
            problems.push(format!("{at}: too many items ({len})"));
        }
        if let Some(item_schema) = node.get("items").filter(|s| s.is_object()) {
            for (i, item) in items.iter().enumerate() {
                check(item, item_schema, root, &format!("{at}[{i}]"), problems);
            }
        }
    }
}

fn check_object(
    object: &Map<String, Value>,
    node: &Value,
    root: &Value,
    at: &str,
    problems: &mut Vec<String>,
) {
    for required in node
        .get("required")
        .and_then(Value::as_array)
        .into_iter()
        .flatten()
    {
        let key = required.as_str().unwrap_or_default();
        if !object.contains_key(key) {
            problems.push(format!("{at}: required property {key:?} is missing"));
        }
    }
    let properties = node.get("properties").and_then(Value::as_object);
    if let Some(properties) = properties {
        for (key, sub) in properties {
            if let Some(v) = object.get(key) {
                check(v, sub, root, &format!("{at}.{key}"), problems);
            }
        }
    }
    if node.get("additionalProperties") == Some(&Value::Bool(false)) {
        for key in object.keys() {
            if !properties.is_some_and(|p| p.contains_key(key)) {
                problems.push(format!("{at}: property {key:?} is not in the schema"));
            }
        }
    }
}

fn has_type(value: &Value, ty: &str) -> bool {
    match ty {
        "null" => value.is_null(),
        "boolean" => value.is_boolean(),
        "integer" => value.is_u64() || value.is_i64(),
        "number" => value.is_number(),
        "string" => value.is_string(),
        "array" => value.is_array(),
        "object" => value.is_object(),
        _ => false,
    }
}

#[test]
fn structural_check_notices_drift() {
    let (_, schema) = proto::schema::all()
        .into_iter()
        .find(|(n, _)| *n == "Observation")
        .expect("Observation schema");
    let mut example = serde_json::to_value(examples::observation()).expect("json");
    let object = example.as_object_mut().expect("object");
    object.remove("stamp");
    object.insert("colour".to_string(), Value::from("orange"));
    example["robot_pose"]["x_m"] = Value::from("left");
    let mut problems = Vec::new();
    let root = schema.as_value();
    check(&example, root, root, "Observation", &mut problems);
    let text = problems.join("\n");
    assert!(text.contains("\"stamp\" is missing"), "{text}");
    assert!(text.contains("\"colour\" is not in the schema"), "{text}");
    assert!(text.contains("robot_pose.x_m"), "{text}");

    let (_, schema) = proto::schema::all()
        .into_iter()
        .find(|(n, _)| *n == "BallState")
        .expect("BallState schema");
    let mut example = serde_json::to_value(examples::ball_state()).expect("json");
    example["status"] = Value::from("flying");
    example["prediction"]["bounces"][0]["wall"] = Value::from("ceiling");
    example["covariance"] = Value::from(vec![0.0; 3]);
    let mut problems = Vec::new();
    let root = schema.as_value();
    check(&example, root, root, "BallState", &mut problems);
    let text = problems.join("\n");
    assert!(text.contains("BallState.status"), "{text}");
    assert!(text.contains("prediction.bounces[0].wall"), "{text}");
    assert!(text.contains("too few items"), "{text}");
}
