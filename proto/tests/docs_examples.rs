//! `docs/protocol.md` stays true to the code: its example payloads are the serialised sound
//! examples, and it names every key expression, field, enum value and rejection reason.

mod support;

use serde_json::Value;
use std::collections::BTreeSet;
use support::{crate_path, examples, regenerate};

const DOC: &str = "../docs/protocol.md";
const HOW_TO_REGENERATE: &str = "REGENERATE=1 cargo test -p proto docs_examples";

fn read_doc() -> String {
    let path = crate_path(DOC);
    std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("read {}: {e}", path.display()))
}

/// What belongs between `<!-- example:{name} -->` and `<!-- /example:{name} -->`.
fn block(json: &str) -> String {
    format!("\n```json\n{json}\n```\n")
}

/// The byte range between the markers of `name`, if both are present in order.
fn block_range(doc: &str, name: &str) -> Option<std::ops::Range<usize>> {
    let open = format!("<!-- example:{name} -->");
    let close = format!("<!-- /example:{name} -->");
    let start = doc.find(&open)? + open.len();
    let end = start + doc[start..].find(&close)?;
    Some(start..end)
}

#[test]
fn docs_examples_are_current() {
    let mut doc = read_doc();
    let mut problems = Vec::new();
    for (name, json) in examples::all_pretty() {
        let want = block(&json);
        match block_range(&doc, name) {
            None => problems.push(format!(
                "no <!-- example:{name} --> ... <!-- /example:{name} --> markers"
            )),
            Some(range) if doc[range.clone()] == want => {}
            Some(range) if regenerate() => doc.replace_range(range, &want),
            Some(_) => problems.push(format!("the {name} example differs from the code")),
        }
    }
    if regenerate() {
        let path = crate_path(DOC);
        std::fs::write(&path, &doc).unwrap_or_else(|e| panic!("write {}: {e}", path.display()));
    }
    assert!(
        problems.is_empty(),
        "{DOC}:\n  {}\nRegenerate the examples with `{HOW_TO_REGENERATE}` (markers must exist).",
        problems.join("\n  ")
    );
}

#[test]
fn docs_examples_decode_and_validate() {
    if regenerate() {
        return; // the blocks are being rewritten from the examples by the test above
    }
    let doc = read_doc();
    let ctx = examples::ctx();
    for (name, _) in examples::all_pretty() {
        let Some(range) = block_range(&doc, name) else {
            continue; // reported by docs_examples_are_current
        };
        let json = doc[range]
            .trim()
            .trim_start_matches("```json")
            .trim_end_matches("```")
            .as_bytes()
            .to_vec();
        let result = match name {
            "Observation" => decode_validate::<proto::Observation>(&json, &ctx),
            "RobotStatus" => decode_validate::<proto::RobotStatus>(&json, &ctx),
            "BallState" => decode_validate::<proto::BallState>(&json, &ctx),
            "Prediction" => decode_validate::<proto::Prediction>(&json, &ctx),
            "Pitch" => decode_validate::<proto::Pitch>(&json, &ctx),
            "CameraView" => decode_validate::<proto::CameraView>(&json, &ctx),
            "Intercept" => proto::decode::<proto::Intercept>(&json)
                .map(drop)
                .map_err(|e| e.to_string()),
            other => Err(format!("no type for example {other}")),
        };
        if let Err(e) = result {
            panic!("{DOC}: the {name} example: {e}");
        }
    }
}

fn decode_validate<T>(json: &[u8], ctx: &proto::ValidationContext) -> Result<(), String>
where
    T: serde::de::DeserializeOwned + proto::Validate,
{
    let msg: T = proto::decode(json).map_err(|e| e.to_string())?;
    msg.validate(ctx).map_err(|e| e.to_string())
}

#[test]
fn docs_name_every_key_expression() {
    let doc = read_doc();
    let keys = proto::KeySpace::default();
    let robot = "miro1";
    let mut wanted = vec![
        keys.robot_obs(robot).expect("valid id"),
        keys.robot_status(robot).expect("valid id"),
        keys.robot_liveliness(robot).expect("valid id"),
        keys.server_liveliness("server-a").expect("valid id"),
        keys.all_obs(),
        keys.all_status(),
        keys.all_robot_liveliness(),
        keys.ball_state(),
        keys.ball_predict(),
    ];
    // The patterns with placeholders, as the tables write them.
    wanted.extend(
        [
            "{prefix}/robots/{id}/obs",
            "{prefix}/robots/{id}/status",
            "{prefix}/robots/{id}",
            "{prefix}/ball/state",
            "{prefix}/ball/predict",
            "{prefix}/servers/{id}",
        ]
        .map(String::from),
    );
    wanted.push(format!("`{}`", proto::DEFAULT_PREFIX));
    let missing: Vec<&String> = wanted
        .iter()
        .filter(|k| !doc.contains(k.as_str()))
        .collect();
    assert!(missing.is_empty(), "{DOC} does not mention {missing:?}");
}

/// Every property name and enum value in the schemas (nested types included).
fn schema_words(node: &Value, out: &mut BTreeSet<String>) {
    match node {
        Value::Object(map) => {
            if let Some(Value::Object(props)) = map.get("properties") {
                out.extend(props.keys().cloned());
            }
            if let Some(Value::String(c)) = map.get("const") {
                out.insert(c.clone());
            }
            if let Some(Value::Array(values)) = map.get("enum") {
                out.extend(values.iter().filter_map(Value::as_str).map(String::from));
            }
            map.values().for_each(|v| schema_words(v, out));
        }
        Value::Array(items) => items.iter().for_each(|v| schema_words(v, out)),
        _ => {}
    }
}

#[test]
fn docs_describe_every_field_and_enum_value() {
    let doc = read_doc();
    let mut words = BTreeSet::new();
    for (name, schema) in proto::schema::all() {
        words.insert(name.to_string());
        schema_words(schema.as_value(), &mut words);
    }
    // A nested field may be written as a path: `pixel.u_px`, `samples[].t_s`.
    let described = |w: &str| {
        [
            format!("`{w}`"),
            format!(".{w}`"),
            format!("`{w}."),
            format!("`{w}["),
        ]
        .iter()
        .any(|form| doc.contains(form.as_str()))
    };
    let missing: Vec<&String> = words.iter().filter(|w| !described(w)).collect();
    assert!(missing.is_empty(), "{DOC} does not describe {missing:?}");
}

#[test]
fn docs_list_every_rejection_reason_and_the_version() {
    let doc = read_doc();
    for e in examples::one_error_of_each_kind() {
        let label = format!("`{}`", e.reason());
        assert!(doc.contains(&label), "{DOC} does not list reason {label}");
    }
    let version = format!("`VERSION` = {}", proto::VERSION);
    assert!(doc.contains(&version), "{DOC} does not say {version:?}");
    let ctx = examples::ctx();
    for default in [
        format!("{} s", ctx.max_clock_skew_s),
        format!("{} m", ctx.max_outside_m),
    ] {
        assert!(
            doc.contains(&default),
            "{DOC} does not give the default {default:?}"
        );
    }
}
