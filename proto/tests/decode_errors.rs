//! One test per kind of malformed input to `proto::decode`.

mod support;

use proto::{
    BallState, DecodeError, Intercept, Observation, Pitch, Prediction, RobotStatus, VERSION,
    decode, encode,
};
use serde_json::{Value, json};
use support::examples;

fn example_json() -> Value {
    serde_json::to_value(examples::observation()).expect("serialises")
}

/// The example observation with `edit` applied to its JSON, as bytes.
fn edited(edit: impl FnOnce(&mut Value)) -> Vec<u8> {
    let mut v = example_json();
    edit(&mut v);
    serde_json::to_vec(&v).expect("serialises")
}

fn assert_json_error<T: std::fmt::Debug>(r: Result<T, DecodeError>, needle: &str) {
    match r {
        Err(DecodeError::Json(e)) => {
            assert!(e.to_string().contains(needle), "{e} lacks {needle:?}")
        }
        other => panic!("expected a JSON error containing {needle:?}, got {other:?}"),
    }
}

#[test]
fn sound_example_decodes() {
    let back: Observation = decode(&encode(&examples::observation())).expect("decodes");
    assert_eq!(back, examples::observation());
}

#[test]
fn not_json_is_rejected() {
    for bytes in [
        &b""[..],
        b"hello",
        b"{\"version\": 1,",
        b"\xff\xfe\x00",
        b"{\"version\": 1} trailing",
    ] {
        let r = decode::<Observation>(bytes);
        assert!(matches!(r, Err(DecodeError::Json(_))), "{bytes:?}: {r:?}");
    }
}

#[test]
fn json_of_the_wrong_shape_is_rejected() {
    for bytes in [
        &b"[1, 2, 3]"[..],
        b"\"observation\"",
        b"42",
        b"null",
        b"true",
    ] {
        let r = decode::<Observation>(bytes);
        assert!(matches!(r, Err(DecodeError::Json(_))), "{bytes:?}: {r:?}");
    }
}

#[test]
fn a_different_message_is_rejected() {
    let status = encode(&examples::robot_status());
    assert_json_error(decode::<Observation>(&status), "unknown field");
    let ball = encode(&examples::ball_state());
    assert_json_error(decode::<Intercept>(&ball), "unknown field");
}

#[test]
fn missing_required_field_is_rejected() {
    let bytes = edited(|v| {
        v.as_object_mut().expect("object").remove("stamp");
    });
    assert_json_error(decode::<Observation>(&bytes), "missing field `stamp`");
}

#[test]
fn optional_field_may_be_absent() {
    let bytes = edited(|v| {
        v.as_object_mut().expect("object").remove("pixel");
    });
    let back: Observation = decode(&bytes).expect("pixel is optional");
    assert_eq!(back.pixel, None);
}

#[test]
fn wrong_field_type_is_rejected() {
    let bytes = edited(|v| v["seq"] = json!("1842"));
    assert_json_error(decode::<Observation>(&bytes), "invalid type");
    let bytes = edited(|v| v["stamp"] = json!(-5));
    assert_json_error(decode::<Observation>(&bytes), "invalid value");
    let bytes = edited(|v| v["stamp"] = json!(1.5e18));
    assert_json_error(decode::<Observation>(&bytes), "invalid type");
}

#[test]
fn wrong_array_length_is_rejected() {
    let bytes = edited(|v| v["position_m"] = json!([0.1, 0.2, 0.3]));
    assert_json_error(decode::<Observation>(&bytes), "trailing");
    let bytes = edited(|v| v["covariance_m2"] = json!([0.1, 0.0, 0.1]));
    assert_json_error(decode::<Observation>(&bytes), "invalid length");
}

#[test]
fn unknown_enum_value_is_rejected() {
    let bytes = edited(|v| v["camera"] = json!("centre"));
    assert_json_error(decode::<Observation>(&bytes), "unknown variant");
}

#[test]
fn non_finite_float_does_not_survive_the_wire() {
    // JSON has no NaN: serde_json writes it as `null`, which no float field accepts.
    let mut msg = examples::observation();
    msg.confidence = f64::NAN;
    assert_json_error(decode::<Observation>(&encode(&msg)), "invalid type: null");
}

#[test]
fn missing_version_is_rejected() {
    let bytes = edited(|v| {
        v.as_object_mut().expect("object").remove("version");
    });
    assert!(matches!(
        decode::<Observation>(&bytes),
        Err(DecodeError::MissingVersion)
    ));
    for version in [json!(null), json!("1"), json!(1.0), json!(-1), json!([1])] {
        let bytes = edited(|v| v["version"] = version.clone());
        let r = decode::<Observation>(&bytes);
        assert!(
            matches!(r, Err(DecodeError::MissingVersion)),
            "{version}: {r:?}"
        );
    }
}

#[test]
fn wrong_version_is_rejected_before_the_fields() {
    for found in [0_u64, 2, u64::from(u32::MAX) + 1] {
        // The rest of the payload is garbage: the version is checked first.
        let bytes = serde_json::to_vec(&json!({"version": found, "what": "ever"})).expect("json");
        match decode::<Observation>(&bytes) {
            Err(DecodeError::Version { found: f, expected }) => {
                assert_eq!(f, found);
                assert_eq!(expected, VERSION);
            }
            other => panic!("version {found}: {other:?}"),
        }
    }
    let bytes = edited(|v| v["version"] = json!(2));
    let err = decode::<Observation>(&bytes).expect_err("version 2");
    assert!(matches!(err, DecodeError::Version { found: 2, .. }));
    assert!(err.to_string().contains("version 2"), "{err}");
}

/// `msg` with an extra field added at the JSON pointer `at` is rejected by `decode::<T>`.
fn assert_unknown_field_rejected<T>(msg: &T, at: &str)
where
    T: serde::Serialize + serde::de::DeserializeOwned + std::fmt::Debug,
{
    let mut v = serde_json::to_value(msg).expect("serialises");
    v.pointer_mut(at)
        .and_then(Value::as_object_mut)
        .unwrap_or_else(|| panic!("no object at {at:?}"))
        .insert("colour".to_string(), json!("orange"));
    let bytes = serde_json::to_vec(&v).expect("serialises");
    assert_json_error(decode::<T>(&bytes), "unknown field `colour`");
}

#[test]
fn unknown_top_level_field_is_rejected_for_every_message() {
    assert_unknown_field_rejected(&examples::observation(), "");
    assert_unknown_field_rejected(&examples::robot_status(), "");
    assert_unknown_field_rejected(&examples::ball_state(), "");
    assert_unknown_field_rejected(&examples::prediction(), "");
    assert_unknown_field_rejected(&examples::intercept(), "");
    assert_unknown_field_rejected(&examples::pitch(), "");
}

#[test]
fn unknown_nested_field_is_rejected() {
    assert_unknown_field_rejected(&examples::observation(), "/robot_pose");
    assert_unknown_field_rejected(&examples::observation(), "/pixel");
    assert_unknown_field_rejected(&examples::robot_status(), "/head");
    assert_unknown_field_rejected(&examples::robot_status(), "/timings/0");
    assert_unknown_field_rejected(&examples::robot_status(), "/footprints/1");
    assert_unknown_field_rejected(&examples::ball_state(), "/model");
    assert_unknown_field_rejected(&examples::ball_state(), "/prediction");
    assert_unknown_field_rejected(&examples::ball_state(), "/prediction/samples/0");
    assert_unknown_field_rejected(&examples::prediction(), "/bounces/0");
    assert_unknown_field_rejected(&examples::prediction(), "/stop");
}

#[test]
fn every_message_type_checks_its_version() {
    fn bumped<T: serde::Serialize>(msg: &T) -> Vec<u8> {
        let mut v = serde_json::to_value(msg).expect("serialises");
        v["version"] = json!(VERSION + 1);
        serde_json::to_vec(&v).expect("serialises")
    }
    let v = |r: Result<(), DecodeError>| matches!(r, Err(DecodeError::Version { .. }));
    assert!(v(
        decode::<Observation>(&bumped(&examples::observation())).map(drop)
    ));
    assert!(v(
        decode::<RobotStatus>(&bumped(&examples::robot_status())).map(drop)
    ));
    assert!(v(
        decode::<BallState>(&bumped(&examples::ball_state())).map(drop)
    ));
    assert!(v(
        decode::<Prediction>(&bumped(&examples::prediction())).map(drop)
    ));
    assert!(v(
        decode::<Intercept>(&bumped(&examples::intercept())).map(drop)
    ));
    assert!(v(decode::<Pitch>(&bumped(&examples::pitch())).map(drop)));
}

#[test]
fn nested_prediction_version_is_not_checked_by_decode() {
    // `decode` looks at the outer version only; a BallState's inner Prediction carries its
    // own version, which `validate` checks.
    let mut v = serde_json::to_value(examples::ball_state()).expect("serialises");
    v["prediction"]["version"] = json!(2);
    let back: BallState = decode(&serde_json::to_vec(&v).expect("json")).expect("decodes");
    assert_eq!(back.prediction.version, 2);
}
