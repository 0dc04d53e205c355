//! Property round-trips: any valid message → `encode` → `decode` gives back an equal message.

mod support;

use proptest::prelude::*;
use std::fmt::Debug;
use support::strategies;

/// Encodes, decodes and compares; also checks the encoding is stable (a second trip gives
/// the same bytes), which catches floats that print differently after one round.
fn round_trip<T>(msg: &T) -> Result<(), TestCaseError>
where
    T: serde::Serialize + serde::de::DeserializeOwned + PartialEq + Debug,
{
    let bytes = proto::encode(msg);
    let back: T =
        proto::decode(&bytes).map_err(|e| TestCaseError::fail(format!("decode failed: {e}")))?;
    prop_assert_eq!(&back, msg);
    prop_assert_eq!(proto::encode(&back), bytes);
    Ok(())
}

proptest! {
    #[test]
    fn observation_round_trips(msg in strategies::observation()) {
        round_trip(&msg)?;
    }

    #[test]
    fn robot_status_round_trips(msg in strategies::robot_status()) {
        round_trip(&msg)?;
    }

    #[test]
    fn ball_state_with_prediction_round_trips(msg in strategies::ball_state()) {
        round_trip(&msg)?;
    }

    #[test]
    fn prediction_round_trips(msg in strategies::prediction()) {
        round_trip(&msg)?;
    }

    #[test]
    fn intercept_round_trips(msg in strategies::intercept()) {
        round_trip(&msg)?;
    }

    #[test]
    fn pitch_round_trips(msg in strategies::pitch()) {
        round_trip(&msg)?;
    }
}

#[test]
fn examples_round_trip() {
    use support::examples;
    round_trip(&examples::observation()).expect("observation");
    round_trip(&examples::robot_status()).expect("robot status");
    round_trip(&examples::ball_state()).expect("ball state");
    round_trip(&examples::prediction()).expect("prediction");
    round_trip(&examples::intercept()).expect("intercept");
    round_trip(&examples::pitch()).expect("pitch");
}
