//! JSON Schemas generated from the message types. The checked-in copies in
//! `proto/schemas/` are what other tools (MCAP channels, the web page, robot teams in
//! other languages) read; a test fails when they drift from the types.

use schemars::{JsonSchema, Schema, schema_for};

fn named<T: JsonSchema>(name: &'static str) -> (&'static str, Schema) {
    (name, schema_for!(T))
}

/// Every message's name and schema, in a fixed order.
pub fn all() -> Vec<(&'static str, Schema)> {
    vec![
        named::<crate::Observation>("Observation"),
        named::<crate::RobotStatus>("RobotStatus"),
        named::<crate::BallState>("BallState"),
        named::<crate::Prediction>("Prediction"),
        named::<crate::Intercept>("Intercept"),
        named::<crate::CameraView>("CameraView"),
        named::<crate::Pitch>("Pitch"),
    ]
}

/// The schema of one message as pretty JSON (what `proto/schemas/{name}.json` holds).
pub fn to_pretty_json(schema: &Schema) -> String {
    let mut s = serde_json::to_string_pretty(schema).unwrap_or_default();
    s.push('\n');
    s
}
