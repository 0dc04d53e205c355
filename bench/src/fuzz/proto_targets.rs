//! proto: `decode` of every wire message followed by `validate`, and the key builders.

use proto::{
    BallState, Intercept, KeySpace, Observation, Pitch, Prediction, RobotStatus, Validate,
    ValidationContext,
};
use serde::de::DeserializeOwned;

use super::seeds::{self, BASE};
use super::{Target, Verdict};

fn context() -> ValidationContext {
    ValidationContext::new(Pitch::default(), BASE)
}

/// Decodes and, when it decodes, validates.
fn decode_validate<T: DeserializeOwned + Validate>(bytes: &[u8]) -> Verdict {
    let ctx = context();
    Verdict::of(proto::decode::<T>(bytes).is_ok_and(|m| m.validate(&ctx).is_ok()))
}

/// A message type's target: decode then validate.
fn message<T: DeserializeOwned + Validate + 'static>(
    name: &'static str,
    seeds: Vec<Vec<u8>>,
) -> Target {
    Target::new(name, seeds, decode_validate::<T>)
}

pub fn targets() -> Vec<Target> {
    let observations: Vec<Vec<u8>> = seeds::rolling_ball(6).iter().map(proto::encode).collect();
    let statuses = vec![
        proto::encode(&seeds::status("miro1")),
        proto::encode(&proto::RobotStatus {
            timings: vec![],
            footprints: vec![],
            ..seeds::status("robot_7-b")
        }),
    ];
    let outputs = seeds::fusion_outputs();
    let output = |name: &str| -> Vec<Vec<u8>> {
        outputs
            .iter()
            .filter(|(n, _)| *n == name)
            .map(|(_, b)| b.clone())
            .collect()
    };
    vec![
        message::<Observation>("proto_observation", observations),
        message::<RobotStatus>("proto_robot_status", statuses),
        message::<BallState>("proto_ball_state", output("BallState")),
        message::<Prediction>("proto_prediction", output("Prediction")),
        Target::new("proto_intercept", output("Intercept"), |b| {
            Verdict::of(proto::decode::<Intercept>(b).is_ok())
        }),
        message::<Pitch>("proto_pitch", vec![proto::encode(&Pitch::default())]),
        keys_target(),
    ]
}

/// The key builders and parsers on arbitrary text: what a builder makes, the parser
/// reads back.
fn keys_target() -> Target {
    let seeds = [
        "rf/robots/miro1/obs",
        "rf/robots/miro2/status",
        "rf/robots/miro_3-x/alive",
        "rf/servers/server-1",
        "team/a/robots/miro1/obs",
        "miro1",
    ];
    Target::new(
        "proto_keys",
        seeds.iter().map(|s| s.as_bytes().to_vec()).collect(),
        |bytes| {
            let text = String::from_utf8_lossy(bytes);
            let default = KeySpace::default();
            default.robot_chunk_of(&text);
            let id = default.robot_id_of(&text);
            assert!(id.is_none_or(proto::is_valid_id));
            let built = [
                default.robot_obs(&text),
                default.robot_status(&text),
                default.robot_liveliness(&text),
            ];
            for key in built.iter().flatten() {
                assert_eq!(default.robot_id_of(key), Some(&*text), "key {key:?}");
            }
            default.server_liveliness(&text).ok();
            let space = KeySpace::new(&text);
            if let Ok(space) = &space {
                let key = space.robot_obs("miro1");
                assert_eq!(
                    key.as_deref().ok().and_then(|k| space.robot_id_of(k)),
                    Some("miro1")
                );
            }
            Verdict::of(space.is_ok() || built.iter().any(Result::is_ok))
        },
    )
}
