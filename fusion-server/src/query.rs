//! Prediction and intercept queries, as asked on `{prefix}/ball/predict` and over HTTP:
//! parameters in, a typed request or a clear error out.

use proto::{Intercept, Prediction};
use thiserror::Error;

/// Longest prediction horizon a query may ask for.
pub const MAX_HORIZON_S: f64 = 10.0;
/// Fastest robot an intercept query may assume.
pub const MAX_ROBOT_SPEED_MPS: f64 = 5.0;
/// Longest query parameter text (`t=1.5`, `robot=ID;speed=MPS`) accepted, in bytes; a
/// longer one is refused before it is parsed.
pub const MAX_QUERY_BYTES: usize = 256;

#[derive(Debug, Clone, PartialEq)]
pub enum BallQuery {
    /// The path predicted `horizon_s` ahead.
    Predict { horizon_s: f64 },
    /// The earliest meeting point for a robot, at its configured speed unless given.
    Intercept {
        robot_id: String,
        speed_mps: Option<f64>,
    },
}

#[derive(Debug, Clone, PartialEq)]
pub enum QueryReply {
    Prediction(Prediction),
    Intercept(Intercept),
}

impl QueryReply {
    pub fn to_json(&self) -> Vec<u8> {
        match self {
            QueryReply::Prediction(p) => proto::encode(p),
            QueryReply::Intercept(i) => proto::encode(i),
        }
    }
}

#[derive(Debug, Clone, PartialEq, Error)]
pub enum QueryError {
    #[error("give t=SECONDS for a prediction or robot=ID[;speed=MPS] for an intercept")]
    Missing,
    #[error("give either t or robot, not both")]
    Ambiguous,
    #[error("{name}={value:?} is not a number in {lo}..={hi}")]
    BadNumber {
        name: &'static str,
        value: String,
        lo: f64,
        hi: f64,
    },
    #[error("robot={0:?} is not a valid robot id")]
    BadRobotId(String),
    #[error("unknown parameter {0:?}")]
    Unknown(String),
    #[error("robot {0:?} has not reported a pose")]
    UnknownRobot(String),
    #[error("no ball estimate yet")]
    NoEstimate,
    #[error("the query's parameters are {bytes} bytes long (limit {MAX_QUERY_BYTES})")]
    TooLarge { bytes: usize },
}

/// Refuses parameter text longer than [`MAX_QUERY_BYTES`], before any parsing.
pub fn check_size(params: &str) -> Result<(), QueryError> {
    if params.len() > MAX_QUERY_BYTES {
        Err(QueryError::TooLarge {
            bytes: params.len(),
        })
    } else {
        Ok(())
    }
}

impl QueryError {
    /// True for errors in the request (rather than in what the server knows).
    pub fn is_bad_request(&self) -> bool {
        !matches!(self, QueryError::UnknownRobot(_) | QueryError::NoEstimate)
    }
}

fn number(name: &'static str, value: &str, lo: f64, hi: f64) -> Result<f64, QueryError> {
    match value.trim().parse::<f64>() {
        Ok(v) if v.is_finite() && (lo..=hi).contains(&v) => Ok(v),
        _ => Err(QueryError::BadNumber {
            name,
            value: value.chars().take(32).collect(),
            lo,
            hi,
        }),
    }
}

/// Parses `name=value` pairs (`t`, `robot`, `speed`).
pub fn parse<'a>(
    pairs: impl IntoIterator<Item = (&'a str, &'a str)>,
) -> Result<BallQuery, QueryError> {
    let (mut t, mut robot, mut speed) = (None, None, None);
    for (k, v) in pairs {
        match k {
            "t" => t = Some(number("t", v, 0.0, MAX_HORIZON_S)?),
            "speed" => speed = Some(number("speed", v, 1e-3, MAX_ROBOT_SPEED_MPS)?),
            "robot" => {
                if !proto::is_valid_id(v) {
                    return Err(QueryError::BadRobotId(v.chars().take(64).collect()));
                }
                robot = Some(v.to_string());
            }
            other => return Err(QueryError::Unknown(other.chars().take(32).collect())),
        }
    }
    match (t, robot) {
        (Some(_), Some(_)) => Err(QueryError::Ambiguous),
        (Some(horizon_s), None) if speed.is_none() => Ok(BallQuery::Predict { horizon_s }),
        (Some(_), None) => Err(QueryError::Unknown("speed".into())),
        (None, Some(robot_id)) => Ok(BallQuery::Intercept {
            robot_id,
            speed_mps: speed,
        }),
        (None, None) => Err(QueryError::Missing),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_the_documented_forms() {
        assert_eq!(
            parse([("t", "1.5")]),
            Ok(BallQuery::Predict { horizon_s: 1.5 })
        );
        assert_eq!(
            parse([("robot", "miro2")]),
            Ok(BallQuery::Intercept {
                robot_id: "miro2".into(),
                speed_mps: None
            })
        );
        assert_eq!(
            parse([("robot", "miro2"), ("speed", "0.4")]),
            Ok(BallQuery::Intercept {
                robot_id: "miro2".into(),
                speed_mps: Some(0.4)
            })
        );
    }

    #[test]
    fn rejects_what_it_cannot_answer() {
        assert_eq!(parse([]), Err(QueryError::Missing));
        assert_eq!(
            parse([("t", "1"), ("robot", "a")]),
            Err(QueryError::Ambiguous)
        );
        for bad in ["-1", "nan", "inf", "11", "x", ""] {
            assert!(
                matches!(parse([("t", bad)]), Err(QueryError::BadNumber { .. })),
                "{bad}"
            );
        }
        assert!(matches!(
            parse([("robot", "a/b")]),
            Err(QueryError::BadRobotId(_))
        ));
        assert!(matches!(
            parse([("robot", "a"), ("speed", "0")]),
            Err(QueryError::BadNumber { .. })
        ));
        assert!(matches!(parse([("x", "1")]), Err(QueryError::Unknown(_))));
        assert!(QueryError::Missing.is_bad_request());
        assert!(!QueryError::NoEstimate.is_bad_request());
    }
}
